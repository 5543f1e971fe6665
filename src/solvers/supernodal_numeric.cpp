/* Left-looking supernodal Cholesky into a kept structure, and its partial refactorization
   (supernodal_numeric.h). Supernode s (columns c0 .. c1-1, rows R below) is computed in a dense
   panel of w + m rows and w columns, row-major: A's entries scattered in, the updates of the
   supernodes below it subtracted in ascending order (each entry one dot product of a descendant's
   two rows), then the panel's dense Cholesky, column by column. The dot products run four rows at
   a time, each row's sum in its own register, so the order of every sum is fixed by the structure
   alone: full and partial factorizations give the same bits. */
#include "supernodal_numeric.h"
#include <algorithm>
#include <cmath>

namespace msim {

void SupernodalCholesky::Analyze(const SupernodalFactor &F, const int *perm, const std::vector<int> &aptr, const std::vector<int> &acol)
{
  const int n = F.n_;
  nsn_        = F.Supernodes();
  std::vector<int> sn_of(n);
  for (int s = 0; s < nsn_; s++)
    for (int c = F.start_[s]; c < F.start_[s + 1]; c++) sn_of[c] = s;
  /* the updates: supernode d's rows below, in runs that fall in one supernode s each */
  uptr_.assign(nsn_ + 1, 0);
  for (int pass = 0; pass < 2; pass++) {
    std::vector<int> next(uptr_.begin(), uptr_.end() - 1);
    for (int d = 0; d < nsn_; d++) {
      const int *R = F.rows_.data() + F.rptr_[d], m = F.rptr_[d + 1] - F.rptr_[d];
      for (int k = 0; k < m;) {
        const int s = sn_of[R[k]], p = k;
        while (k < m && R[k] < F.start_[s + 1]) k++;
        if (pass == 0) uptr_[s + 1]++;
        else {
          ud_[next[s]] = d;
          up_[next[s]] = p;
          uq_[next[s]] = k;
          next[s]++;
        }
      }
    }
    if (pass == 0) {
      for (int s = 0; s < nsn_; s++) uptr_[s + 1] += uptr_[s];
      ud_.resize(uptr_[nsn_]);
      up_.resize(uptr_[nsn_]);
      uq_.resize(uptr_[nsn_]);
    }
  }
  /* A's entries: where each lands in its supernode's panel */
  const int nnz = aptr[n];
  std::vector<int64_t> off(nnz);
  asn_.resize(nnz);
  aptr_.assign(nsn_ + 1, 0);
  for (int i = 0; i < n; i++)
    for (int e = aptr[i]; e < aptr[i + 1]; e++) {
      const int r = std::max(perm[i], perm[acol[e]]), c = std::min(perm[i], perm[acol[e]]), s = sn_of[c];
      const int c0 = F.start_[s], w = F.start_[s + 1] - c0;
      int       pr = r - c0;
      if (r >= c0 + w) {
        const int *R0 = F.rows_.data() + F.rptr_[s], *R1 = F.rows_.data() + F.rptr_[s + 1];
        pr = w + (int)(std::lower_bound(R0, R1, r) - R0); /* in the structure: A's pattern is in L's */
      }
      off[e]  = (int64_t)pr * w + (c - c0);
      asn_[e] = s;
      aptr_[s + 1]++;
    }
  for (int s = 0; s < nsn_; s++) aptr_[s + 1] += aptr_[s];
  aidx_.resize(nnz);
  aoff_.resize(nnz);
  {
    std::vector<int> next(aptr_.begin(), aptr_.end() - 1);
    for (int e = 0; e < nnz; e++) {
      const int k = next[asn_[e]]++;
      aidx_[k]    = e;
      aoff_[k]    = off[e];
    }
  }
  /* flops per supernode (a multiply and a subtraction per term), and the largest panel */
  flops_.assign(nsn_, 0.0);
  size_t panel = 0;
  for (int s = 0; s < nsn_; s++) {
    const double w = F.start_[s + 1] - F.start_[s], m = F.rptr_[s + 1] - F.rptr_[s];
    flops_[s] += w * (w - 1) * (w + 1) / 3 + m * w * w; /* the panel's dense factor */
    for (int k = uptr_[s]; k < uptr_[s + 1]; k++) {
      const double wd = F.start_[ud_[k] + 1] - F.start_[ud_[k]], md = F.rptr_[ud_[k] + 1] - F.rptr_[ud_[k]];
      for (int jj = up_[k]; jj < uq_[k]; jj++) flops_[s] += 2 * wd * (md - jj);
    }
    panel = std::max(panel, (size_t)(w + m) * (size_t)w);
  }
  panel_.assign(panel, 0.0);
  map_.assign(n, -1);
  rel_.resize(n);
  redo_.assign(nsn_, 0);
}

/* sum_k a[k] b[k], k < len, four rows a0..a3 against one row b: four independent sums */
static inline void Dot4(const double *a0, const double *a1, const double *a2, const double *a3, const double *b, int len, double *out)
{
  double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  for (int k = 0; k < len; k++) {
    const double bk = b[k];
    s0 += a0[k] * bk;
    s1 += a1[k] * bk;
    s2 += a2[k] * bk;
    s3 += a3[k] * bk;
  }
  out[0] = s0;
  out[1] = s1;
  out[2] = s2;
  out[3] = s3;
}

static inline double Dot1(const double *a, const double *b, int len)
{
  double s = 0;
  for (int k = 0; k < len; k++) s += a[k] * b[k];
  return s;
}

int SupernodalCholesky::Factor(SupernodalFactor &F, const double *aval, const std::vector<char> *dirty, double *done, double *total)
{
  *done = *total = 0;
  for (int s = 0; s < nsn_; s++) {
    char redo = !dirty || (*dirty)[s];
    for (int k = uptr_[s]; k < uptr_[s + 1] && !redo; k++) redo = redo_[ud_[k]];
    redo_[s] = redo;
    *total += flops_[s];
    if (!redo) continue;
    *done += flops_[s];
    const int  c0 = F.start_[s], w = F.start_[s + 1] - c0, m = F.rptr_[s + 1] - F.rptr_[s], nr = w + m;
    const int *R  = F.rows_.data() + F.rptr_[s];
    double    *P  = panel_.data();
    std::fill(P, P + (size_t)nr * w, 0.0);
    for (int k = aptr_[s]; k < aptr_[s + 1]; k++) P[aoff_[k]] = aval[aidx_[k]];
    for (int c = 0; c < w; c++) map_[c0 + c] = c;
    for (int p = 0; p < m; p++) map_[R[p]] = w + p;
    for (int k = uptr_[s]; k < uptr_[s + 1]; k++) { /* the supernodes below, ascending */
      const int     d = ud_[k], wd = F.start_[d + 1] - F.start_[d], md = F.rptr_[d + 1] - F.rptr_[d], p = up_[k], q = uq_[k];
      const int    *Rd = F.rows_.data() + F.rptr_[d];
      const double *Bd = F.val_.data() + F.vptr_[d] + (size_t)wd * (wd - 1) / 2;
      int          *rel = rel_.data();
      /* a row of d outside s's structure meets d's rows in s's columns in no column of d, so its
         products are exact zeros (stored zeros of merged supernodes): skipped */
      for (int ii = p; ii < md; ii++) rel[ii] = map_[Rd[ii]];
      for (int jj = p; jj < q; jj++) {
        const int     cj = Rd[jj] - c0;
        const double *bj = Bd + (size_t)jj * wd;
        int           ii = jj;
        double        t[4];
        for (; ii + 4 <= md; ii += 4) {
          Dot4(Bd + (size_t)ii * wd, Bd + (size_t)(ii + 1) * wd, Bd + (size_t)(ii + 2) * wd, Bd + (size_t)(ii + 3) * wd, bj, wd, t);
          for (int u = 0; u < 4; u++)
            if (rel[ii + u] >= 0) P[(size_t)rel[ii + u] * w + cj] -= t[u];
        }
        for (; ii < md; ii++)
          if (rel[ii] >= 0) P[(size_t)rel[ii] * w + cj] -= Dot1(Bd + (size_t)ii * wd, bj, wd);
      }
    }
    for (int c = 0; c < w; c++) map_[c0 + c] = -1;
    for (int p = 0; p < m; p++) map_[R[p]] = -1;
    /* the panel's dense Cholesky: column c from the columns left of it */
    for (int c = 0; c < w; c++) {
      const double *pc  = P + (size_t)c * w;
      const double  dia = pc[c] - Dot1(pc, pc, c);
      if (!(dia > 0)) return c0 + c;
      const double ljj = std::sqrt(dia), inv = 1.0 / ljj;
      P[(size_t)c * w + c] = ljj;
      F.invdiag_[c0 + c]   = inv;
      int    r             = c + 1;
      double t[4];
      for (; r + 4 <= nr; r += 4) {
        Dot4(P + (size_t)r * w, P + (size_t)(r + 1) * w, P + (size_t)(r + 2) * w, P + (size_t)(r + 3) * w, pc, c, t);
        for (int u = 0; u < 4; u++) P[(size_t)(r + u) * w + c] = (P[(size_t)(r + u) * w + c] - t[u]) * inv;
      }
      for (; r < nr; r++) P[(size_t)r * w + c] = (P[(size_t)r * w + c] - Dot1(P + (size_t)r * w, pc, c)) * inv;
    }
    double *D = F.val_.data() + F.vptr_[s], *B = D + (size_t)w * (w - 1) / 2;
    for (int r = 1; r < w; r++)
      for (int c = 0; c < r; c++) D[(size_t)r * (r - 1) / 2 + c] = P[(size_t)r * w + c];
    std::copy(P + (size_t)w * w, P + (size_t)nr * w, B);
  }
  return -1;
}
} // namespace msim
