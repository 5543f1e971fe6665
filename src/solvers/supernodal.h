/* Supernodal storage of a sparse Cholesky factor L (A = L L^T, lower) and its triangular solves,
   carrying up to four right-hand sides in the lanes of one 4-wide vector. Columns with the same
   structure below the diagonal form a supernode: a dense triangle plus a dense block below it, so
   each row below is read and updated once per supernode instead of once per column, and the inner
   loops are dense. A cloth's factor in AMD order has narrow supernodes (4,294 of 2.4 columns on
   average on the 101 x 101 benchmark cloth), so each row below one is gathered and scattered for
   only a few entries: relaxed amalgamation merges neighbouring supernodes, storing the zeros
   that makes explicit, while the entries grow by at most a fraction relax and no supernode is wider
   than max_width columns. On that cloth's PD matrix, x, y and z together take 0.41 ms with the
   defaults (0.3, 16: 2,054 supernodes, 6% more entries) against 0.44-0.46 unmerged and 1.35 ms for
   a column-by-column sweep (runs/bench/README.md). */
#pragma once
#include <cstdint>
#include <vector>

namespace msim {
typedef double V4 __attribute__((vector_size(32)));

inline V4 Splat(double a) { return V4{a, a, a, a}; }

/* b - sum_k l[k] y[k] over k < n: the row update of a dense triangular solve, in four independent
   sums so the FMA latency does not serialize them */
inline V4 RowSubtract(V4 b, const double *l, const V4 *y, long n)
{
  V4   a0 = b, a1 = {0, 0, 0, 0}, a2 = a1, a3 = a1;
  long k  = 0;
  for (; k + 4 <= n; k += 4) {
    a0 -= Splat(l[k]) * y[k];
    a1 -= Splat(l[k + 1]) * y[k + 1];
    a2 -= Splat(l[k + 2]) * y[k + 2];
    a3 -= Splat(l[k + 3]) * y[k + 3];
  }
  for (; k < n; k++) a0 -= Splat(l[k]) * y[k];
  return (a0 + a1) + (a2 + a3);
}

/* z[perm[i]] := row i of nrhs <= 4 columns stored interleaved (lanes past nrhs zero), and back.
   PD's three columns build each row's vector whole: setting its lanes one at a time through
   memory stalled every row on store forwarding (0.07 ms of a 0.52 ms solve on the benchmark
   cloth). */
inline void LoadPermuted(long n, const int *perm, long nrhs, const double *b, V4 *z)
{
  if (nrhs == 3)
    for (long i = 0; i < n; i++) z[perm[i]] = V4{b[3 * i], b[3 * i + 1], b[3 * i + 2], 0};
  else
    for (long i = 0; i < n; i++) {
      V4 v = {0, 0, 0, 0};
      for (long r = 0; r < nrhs; r++) v[r] = b[nrhs * i + r];
      z[perm[i]] = v;
    }
}

inline void StorePermuted(long n, const int *perm, long nrhs, const V4 *z, double *x)
{
  if (nrhs == 3)
    for (long i = 0; i < n; i++) {
      const V4 v   = z[perm[i]];
      x[3 * i]     = v[0];
      x[3 * i + 1] = v[1];
      x[3 * i + 2] = v[2];
    }
  else
    for (long i = 0; i < n; i++)
      for (long r = 0; r < nrhs; r++) x[nrhs * i + r] = z[perm[i]][r];
}

class SupernodalFactor {
public:
  /* From a CSC lower factor whose columns list the diagonal first and their rows ascending; no
     supernode straddles column split (the solves can stop there). relax, max_width: the merging
     above (relax 0: the fundamental supernodes). */
  void Build(int n, const int *colptr, const int *row, const double *val, int split = -1, double relax = 0, int max_width = 1 << 30);
  /* z (n rows of 4 lanes, right-hand sides in the lanes) := A^-1 z, in the factor's ordering */
  void Solve(V4 *z) const;
  /* L y = b and L^T x = y over the first ncols columns only (ncols at a split, or n): Forward
     also updates the rows below them, Backward reads them. */
  void Forward(V4 *z, int ncols) const;
  void Backward(V4 *z, int ncols) const;
  /* For a low-rank update of the factor's matrix (llt_update.h), the sparse forward solve of a
     right-hand side nonzero only in some columns: L y = b over the supernodes sn (ascending) only,
     which must hold those columns and every supernode they reach (the rows below each); and the
     structure that reach reads: a supernode's first column (s = Supernodes(): n), its rows below. */
  void       ForwardSupernodes(V4 *z, const int *sn, int count) const;
  int        SupernodeStart(int s) const { return start_[s]; }
  const int *RowsBelow(int s, int *m) const { *m = rptr_[s + 1] - rptr_[s]; return rows_.data() + rptr_[s]; }
  /* the supernodes holding supernode s's rows below, each once, ascending (what a reach needs of
     them, a few supernodes for up to a few hundred rows), and the supernode holding column c */
  const int *SupernodesBelow(int s, int *m) const { *m = sptr_[s + 1] - sptr_[s]; return sbelow_.data() + sptr_[s]; }
  int        SupernodeOf(int c) const { return snof_[c]; }
  int     Size() const { return n_; }
  int     Supernodes() const { return (int)start_.size() - 1; }
  int64_t Entries() const { return (int64_t)val_.size() + n_; }

private:
  void ForwardSupernode(V4 *z, int s) const; /* Forward's step for supernode s */
  friend class SupernodalCholesky; /* its numeric factorization fills val_ and invdiag_ in place */
  int                  n_ = 0;
  std::vector<int>     start_;   /* first column of each supernode; start_[nsn] = n */
  std::vector<int>     rptr_;    /* rows below supernode s: rows_[rptr_[s] .. rptr_[s+1]) */
  std::vector<int>     rows_;
  std::vector<int>     sptr_;    /* supernodes holding the rows below supernode s: sbelow_[sptr_[s] .. sptr_[s+1]) */
  std::vector<int>     sbelow_;
  std::vector<int>     snof_;    /* the supernode of each column */
  std::vector<int64_t> vptr_;    /* values of supernode s start at val_[vptr_[s]] */
  std::vector<double>  val_;     /* per supernode of width w with m rows below: the strict lower
                                    triangle of its diagonal block row by row, then the m x w block
                                    below it, row-major */
  std::vector<double>  invdiag_; /* 1 / L_jj */
};
} // namespace msim
