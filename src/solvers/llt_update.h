/* A low-rank diagonal update of a Cholesky factor's matrix, applied in the solves instead of
   refactoring (msimllt, serial). PD's contact weights change A only on the diagonal of the few rows
   whose vertices are near an obstacle: with the base B = L L^T (the last matrix factored) and
   A = B + P D P^T (P the unit columns of the k changed rows, D their changes, of either sign),
   Woodbury's identity gives
     A^-1 b = L^-T (z - Y C^-1 Y^T z),  z = L^-1 b,  Y = L^-1 P,  C = D^-1 + Y^T Y (k x k, dense),
   C nonsingular whenever A and B are SPD. Y's column for row j is nonzero only on the elimination
   tree's path from j to the root, so it costs a sparse forward solve over that path's supernodes
   (about a thousandth of the factor's flops per row on the 101 x 101 cloth, against about two
   thirds of them for a partial refactorization, whose root supernodes are always reached). Y is
   built four columns at a time, one per lane, over the union of their paths, and stored so, with
   the rows of those supernodes; each column is kept while the base is, so a later update of the
   same base computes only its new rows' columns. Everything here is a fixed function of (B's factor, the changed
   rows in ascending order, D): the same base and matrix give the same bits whatever came before. */
#pragma once
#include "supernodal.h"
#include <Eigen/Dense>
#include <memory>
#include <unordered_map>
#include <vector>

namespace msim {
class LowRankUpdate {
public:
  /* Y and C's LU for the factor F of the base and the changes d[i] (nonzero) at F's columns
     col[i] (ascending). Returns false when C is singular (A not SPD, or roundoff at its limit):
     the caller refactors. *flops: the work, as PetscLogFlops takes it. */
  bool Build(const SupernodalFactor &F, const std::vector<int> &col, const std::vector<double> &d, double *flops);
  /* z := z - Y C^-1 Y^T z for z = L^-1 b (F.Forward's result, n rows of 4 lanes, the first nrhs
     used, the others zero), before F.Backward; *flops: the work */
  void Apply(V4 *z, int nrhs, double *flops) const;
  void Clear();
  /* Clear, and forget Y's columns: the base's factor changed */
  void Forget();
  int  Rank() const { return k_; }
  struct Run {
    int row, count; /* rows row .. row + count - 1 of z: the next count of a group's rows of Y */
  };
  /* stored rows of Y (groups of four columns) */
  long Rows() const { return (long)yval_.size(); }

private:
  int                 k_ = 0;
  std::vector<int>    gptr_;    /* group g's rows of Y: yval_[gptr_[g] .. gptr_[g+1]) */
  std::vector<V4>     yval_;    /* Y's four columns of the group in the lanes (zero past k) */
  std::vector<int>    rptr_;    /* group g's rows as runs of consecutive rows (whole supernodes): */
  std::vector<Run>    run_;     /* run_[rptr_[g] .. rptr_[g+1]), ascending, so the solves index z
                                   by a run's start instead of by a row index per row */
  std::vector<double> c_;       /* C, k x k column-major, while it is built */
  std::unique_ptr<Eigen::PartialPivLU<Eigen::MatrixXd>> lu_; /* C's LU */
  mutable std::vector<double> t_; /* work: Y^T z, k x 4 column-major */
  std::vector<V4>     work_;    /* work: n rows, zero between uses */
  std::vector<int>    sn_;      /* work: the supernodes a group reaches */
  std::vector<char>   mark_;    /* work: per supernode */
  struct ColumnY {
    std::vector<int>    rows; /* the rows of the supernodes the column reaches, ascending */
    std::vector<double> vals;
  };
  std::unordered_map<int, ColumnY> cache_; /* Y's columns computed for this base, by changed column */
};
} // namespace msim
