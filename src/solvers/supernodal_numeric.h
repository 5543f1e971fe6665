/* The numeric Cholesky factorization A = L L^T into a SupernodalFactor's kept structure
   (supernodal.h), left-looking by supernodes, and its partial refactorization: when only some of
   A's values changed since the last factorization (PD's contact weights change a few rows'
   diagonal), only the supernodes that those entries reach are recomputed, the changed columns'
   supernodes and every supernode they update, transitively (their paths to the root of the
   elimination tree). Every supernode is computed by one fixed sequence of operations from A's
   values and the supernodes below it, so a partial refactorization is bit for bit the full one of
   the same matrix with the same analysis, whatever the history of changes (restarts factor from
   scratch and must agree bitwise). */
#pragma once
#include "supernodal.h"
#include <cstdint>
#include <vector>

namespace msim {
/* The structure of L for A's lower triangle by rows (as Analyze takes it) in the ordering perm,
   as CSC columns (colptr, row), each column's diagonal first and its rows ascending: the
   elimination tree (Liu's algorithm) and each row's pattern from its subtree. */
void SymbolicCholesky(int n, const int *perm, const std::vector<int> &aptr, const std::vector<int> &acol, std::vector<int> &colptr, std::vector<int> &row);

class SupernodalCholesky {
public:
  /* The kept analysis: the structure of F (built from a factor of A's pattern in the ordering
     perm: row i of A is row perm[i] of the factor) and A's lower triangle by rows in A's
     numbering (row i: columns acol[aptr[i] .. aptr[i+1]), each <= i), whose values Factor takes in
     that order. */
  void Analyze(const SupernodalFactor &F, const int *perm, const std::vector<int> &aptr, const std::vector<int> &acol);
  /* The whole analysis for the ordering perm: L's structure (SymbolicCholesky), F built on it
     with no numbers yet (split at column split, -1 for none; relax, max_width: amalgamation),
     and Analyze. The serial factor and each rank's local one take this same path. */
  void AnalyzeOrdering(SupernodalFactor &F, int n, const int *perm, const std::vector<int> &aptr, const std::vector<int> &acol, int split, double relax, int max_width);
  /* dirty := the supernodes holding an entry of aval whose bits differ from old's (-0 is not 0:
     a partial refactorization must give the full one's bits), for Factor */
  void MarkChanged(const std::vector<double> &aval, const std::vector<double> &old, std::vector<char> &dirty) const;
  /* F's values from A's (aval, in Analyze's order). dirty: nullptr for all supernodes, else the
     supernodes whose columns hold a changed entry of A (nsn flags): those and every supernode
     they reach are recomputed. Returns -1, or the first column whose pivot is not positive.
     *done, *total: the flops of the recomputed supernodes and of all of them. */
  int Factor(SupernodalFactor &F, const double *aval, const std::vector<char> *dirty, double *done, double *total);
  /* L's trailing block, rows and columns c0 .. n-1 (no supernode may straddle c0: Build's split),
     into out, column-major, (n - c0)^2 doubles, its upper part zero */
  void TrailingBlock(const SupernodalFactor &F, int c0, double *out) const;
  int                     Supernodes() const { return nsn_; }

private:
  int                  nsn_ = 0;
  std::vector<int>     uptr_, ud_, up_, uq_; /* updates of supernode s: from supernode ud_[k], its rows
                                                below from index up_[k], those before uq_[k] being s's
                                                columns; k in uptr_[s] .. uptr_[s+1), ascending d */
  std::vector<int>     aptr_, aidx_;         /* A's entries of supernode s: aval[aidx_[k]] goes to */
  std::vector<int64_t> aoff_;                /* offset aoff_[k] of s's dense panel */
  std::vector<int>     asn_;
  std::vector<double>  flops_;               /* per supernode */
  std::vector<V4>      panel_;               /* work: (w + m) x w, blocks of 4 rows, one vector per column */
  std::vector<V4>      tbuf_;                /* work: a descendant's rows in s's columns, transposed */
  std::vector<double>  lrow_;                /* work: the row of the current pivot */
  std::vector<double>  ljj_;                 /* L's diagonal (F keeps its inverse) */
  std::vector<int>     map_, rel_, cofs_;           /* work: a row's place in the current panel, -1 if none */
  std::vector<char>    redo_;
};
} // namespace msim
