/* Left-looking supernodal Cholesky into a kept structure, and its partial refactorization
   (supernodal_numeric.h). Supernode s (columns c0 .. c1-1, rows R below) is computed in a dense
   panel of w + m rows and w columns (blocks of 4 rows, one vector per column): A's entries scattered in, the updates of the
   supernodes below it subtracted in ascending order (each entry one dot product of a descendant's
   two rows), then the panel's dense Cholesky, column by column. Every entry's sum runs in one
   register in a fixed order (its terms by ascending descendant, then ascending column), which the
   structure alone sets: full and partial factorizations give the same bits. */
#include "supernodal_numeric.h"
#include <algorithm>
#include <cmath>
#include <cstring>

namespace msim {

void SymbolicCholesky(int n, const int *perm, const std::vector<int> &aptr, const std::vector<int> &acol, std::vector<int> &colptr, std::vector<int> &row)
{
  /* the strict upper pattern by rows of the permuted matrix: row k lists the columns c < k */
  std::vector<int> uptr(n + 1, 0), ucol(aptr[n]);
  for (int i = 0; i < n; i++)
    for (int e = aptr[i]; e < aptr[i + 1]; e++)
      if (acol[e] != i) uptr[std::max(perm[i], perm[acol[e]]) + 1]++;
  for (int k = 0; k < n; k++) uptr[k + 1] += uptr[k];
  {
    std::vector<int> next(uptr.begin(), uptr.end() - 1);
    for (int i = 0; i < n; i++)
      for (int e = aptr[i]; e < aptr[i + 1]; e++)
        if (acol[e] != i) ucol[next[std::max(perm[i], perm[acol[e]])]++] = std::min(perm[i], perm[acol[e]]);
  }
  /* the elimination tree, with path compression through ancestor */
  std::vector<int> parent(n, -1), ancestor(n, -1), mark(n, -1);
  for (int k = 0; k < n; k++)
    for (int e = uptr[k]; e < uptr[k + 1]; e++)
      for (int c = ucol[e]; c != -1 && c < k;) {
        const int up = ancestor[c];
        ancestor[c]  = k;
        if (up == -1) parent[c] = k;
        c = up;
      }
  /* row k of L: the columns on the tree paths from row k's entries up to k (ereach); counted, then
     placed column by column in ascending k */
  std::vector<int> count(n, 1);
  auto             reach = [&](int k, auto &&visit) {
    mark[k] = k;
    for (int e = uptr[k]; e < uptr[k + 1]; e++)
      for (int c = ucol[e]; mark[c] != k; c = parent[c]) {
        mark[c] = k;
        visit(c);
      }
  };
  for (int k = 0; k < n; k++) reach(k, [&](int c) { count[c]++; });
  colptr.assign(n + 1, 0);
  for (int c = 0; c < n; c++) colptr[c + 1] = colptr[c] + count[c];
  row.resize(colptr[n]);
  std::vector<int> next(colptr.begin(), colptr.end() - 1);
  std::fill(mark.begin(), mark.end(), -1);
  for (int k = 0; k < n; k++) {
    row[next[k]++] = k; /* the diagonal first: no row < k comes after it in column k */
    reach(k, [&](int c) { row[next[c]++] = k; });
  }
}

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
      off[e]  = (((int64_t)(pr >> 2) * w + (c - c0)) << 2) + (pr & 3);
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
  size_t panel = 0, tsize = 0;
  for (int s = 0; s < nsn_; s++) {
    const double w = F.start_[s + 1] - F.start_[s], m = F.rptr_[s + 1] - F.rptr_[s];
    flops_[s] += w * (w - 1) * (w + 1) / 3 + m * w * w; /* the panel's dense factor */
    for (int k = uptr_[s]; k < uptr_[s + 1]; k++) {
      const double wd = F.start_[ud_[k] + 1] - F.start_[ud_[k]], md = F.rptr_[ud_[k] + 1] - F.rptr_[ud_[k]];
      for (int jj = up_[k]; jj < uq_[k]; jj++) flops_[s] += 2 * wd * (md - jj);
    }
    panel = std::max(panel, (size_t)(w + m + 3) / 4 * (size_t)w);
    for (int k = uptr_[s]; k < uptr_[s + 1]; k++) {
      const size_t wd = F.start_[ud_[k] + 1] - F.start_[ud_[k]];
      tsize = std::max(tsize, wd * (size_t)((uq_[k] - up_[k] + 3) / 4));
    }
  }
  panel_.assign(panel, V4{0, 0, 0, 0});
  lrow_.assign(n, 0.0);
  ljj_.assign(n, 0.0);
  cofs_.resize(n);
  tbuf_.assign(tsize, V4{0, 0, 0, 0});
  map_.assign(n, -1);
  rel_.resize(n);
  redo_.assign(nsn_, 0);
}

/* lane l of a panel's 4-row block */
static inline double &Lane(V4 *P, int w, int r, int c) { return ((double *)(P + (size_t)(r >> 2) * w + c))[r & 3]; }

/* Supernode d's update of the panel of s: for d's rows ii >= jj in p .. md and jj < q (s's
   columns), P(rel[ii], Rd[jj] - c0) -= row ii . row jj over d's w columns. Rows jj are transposed
   into T (k-major, 4 per vector), so each of 4 rows ii times 4 rows jj is one vector FMA per k;
   each entry's sum runs over k in order from 0. */
static void UpdatePanel(V4 *P, int w, int c0, const double *Bd, int wd, const int *Rd, int md, int p, int q, const int *rel, V4 *T, int *cofs)
{
  const int nq = q - p, nb = (nq + 3) / 4;
  double   *t  = (double *)T;
  for (int k = 0; k < wd; k++)
    for (int j = 0; j < 4 * nb; j++) t[((size_t)k * nb) * 4 + j] = j < nq ? Bd[(size_t)(p + j) * wd + k] : 0.0;
  for (int j = 0; j < nq; j++) cofs[j] = 4 * (Rd[p + j] - c0); /* column j's place in a panel row */
  for (int ii = p; ii < md; ii += 4) {
    const int U = std::min(4, md - ii), jmax = std::min(nq, ii + U - p); /* columns j <= the last row's */
    const double *b0 = Bd + (size_t)ii * wd, *b1 = U > 1 ? b0 + wd : b0, *b2 = U > 2 ? b0 + 2 * wd : b0, *b3 = U > 3 ? b0 + 3 * wd : b0;
    for (int jb = 0; jb < jmax; jb += 4) {
      V4        a0 = {0, 0, 0, 0}, a1 = a0, a2 = a0, a3 = a0;
      const V4 *tk = T + jb / 4;
      for (int k = 0; k < wd; k++, tk += nb) {
        const V4 x = *tk;
        a0 += Splat(b0[k]) * x;
        a1 += Splat(b1[k]) * x;
        a2 += Splat(b2[k]) * x;
        a3 += Splat(b3[k]) * x;
      }
      const V4 a[4] = {a0, a1, a2, a3};
      for (int u = 0; u < U; u++) {
        const int r = rel[ii + u];
        if (r < 0) continue; /* outside s's structure: exact zeros (see Factor) */
        double   *row  = (double *)(P + (size_t)(r >> 2) * w) + (r & 3);
        const int jend = std::min(std::min(jb + 4, nq), ii + u - p + 1);
        if (jend == jb + 4) { /* a whole block of 4 columns, below the diagonal */
          row[cofs[jb]] -= a[u][0];
          row[cofs[jb + 1]] -= a[u][1];
          row[cofs[jb + 2]] -= a[u][2];
          row[cofs[jb + 3]] -= a[u][3];
        } else
          for (int j = jb; j < jend; j++) row[cofs[j]] -= a[u][j - jb];
      }
    }
  }
}

void SupernodalCholesky::AnalyzeOrdering(SupernodalFactor &F, int n, const int *perm, const std::vector<int> &aptr, const std::vector<int> &acol, int split, double relax, int max_width)
{
  std::vector<int> colptr, row;
  SymbolicCholesky(n, perm, aptr, acol, colptr, row);
  const std::vector<double> zero(row.size(), 0.0); /* the numbers come from Factor */
  F.Build(n, colptr.data(), row.data(), zero.data(), split, relax, max_width);
  Analyze(F, perm, aptr, acol);
}

void SupernodalCholesky::MarkChanged(const std::vector<double> &aval, const std::vector<double> &old, std::vector<char> &dirty) const
{
  dirty.assign(nsn_, 0);
  for (size_t e = 0; e < aval.size(); e++)
    if (std::memcmp(&aval[e], &old[e], sizeof(double))) dirty[asn_[e]] = 1;
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
    const int  c0 = F.start_[s], w = F.start_[s + 1] - c0, m = F.rptr_[s + 1] - F.rptr_[s], nr = w + m, nb = (nr + 3) / 4;
    const int *R  = F.rows_.data() + F.rptr_[s];
    V4        *P  = panel_.data();
    std::fill(P, P + (size_t)nb * w, V4{0, 0, 0, 0});
    double *Pd = (double *)P;
    for (int k = aptr_[s]; k < aptr_[s + 1]; k++) Pd[aoff_[k]] = aval[aidx_[k]];
    for (int c = 0; c < w; c++) map_[c0 + c] = c;
    for (int p = 0; p < m; p++) map_[R[p]] = w + p;
    for (int k = uptr_[s]; k < uptr_[s + 1]; k++) { /* the supernodes below, ascending */
      const int d = ud_[k], wd = F.start_[d + 1] - F.start_[d], md = F.rptr_[d + 1] - F.rptr_[d];
      const int *Rd = F.rows_.data() + F.rptr_[d];
      /* a row of d outside s's structure meets d's rows in s's columns in no column of d, so its
         products are exact zeros (stored zeros of merged supernodes): skipped */
      for (int ii = up_[k]; ii < md; ii++) rel_[ii] = map_[Rd[ii]];
      UpdatePanel(P, w, c0, F.val_.data() + F.vptr_[d] + (size_t)wd * (wd - 1) / 2, wd, Rd, md, up_[k], uq_[k], rel_.data(), tbuf_.data(), cofs_.data());
    }
    for (int c = 0; c < w; c++) map_[c0 + c] = -1;
    for (int p = 0; p < m; p++) map_[R[p]] = -1;
    /* the panel's dense Cholesky, column c from the columns left of it, 4 rows per vector */
    for (int c = 0; c < w; c++) {
      double dia = Lane(P, w, c, c);
      for (int k = 0; k < c; k++) dia -= Lane(P, w, c, k) * Lane(P, w, c, k);
      if (!(dia > 0)) return c0 + c;
      const double ljj = std::sqrt(dia), inv = 1.0 / ljj;
      Lane(P, w, c, c)   = ljj;
      F.invdiag_[c0 + c] = inv;
      ljj_[c0 + c]       = ljj;
      double *l = lrow_.data();
      for (int k = 0; k < c; k++) l[k] = Lane(P, w, c, k);
      const int first = (c + 1) >> 2;
      for (int rb = first; rb < nb; rb++) {
        V4       *pr = P + (size_t)rb * w;
        V4        a  = {0, 0, 0, 0};
        for (int k = 0; k < c; k++) a += pr[k] * Splat(l[k]);
        const V4 v = (pr[c] - a) * Splat(inv);
        if (rb == first)
          for (int lane = 0; lane < 4; lane++) {
            if (4 * rb + lane > c) pr[c][lane] = v[lane];
          }
        else pr[c] = v;
      }
    }
    double *D = F.val_.data() + F.vptr_[s], *B = D + (size_t)w * (w - 1) / 2;
    for (int r = 1; r < w; r++)
      for (int c = 0; c < r; c++) D[(size_t)r * (r - 1) / 2 + c] = Lane(P, w, r, c);
    for (int r = w; r < nr; r++)
      for (int c = 0; c < w; c++) B[(size_t)(r - w) * w + c] = Lane(P, w, r, c);
  }
  return -1;
}
void SupernodalCholesky::TrailingBlock(const SupernodalFactor &F, int c0, double *out) const
{
  const int n = F.n_, N = n - c0;
  std::fill(out, out + (size_t)N * N, 0.0);
  for (int s = 0; s < nsn_; s++) {
    const int s0 = F.start_[s], w = F.start_[s + 1] - s0, m = F.rptr_[s + 1] - F.rptr_[s];
    if (s0 < c0) continue;
    const double *D = F.val_.data() + F.vptr_[s], *B = D + (size_t)w * (w - 1) / 2;
    const int    *R = F.rows_.data() + F.rptr_[s];
    for (int c = 0; c < w; c++) {
      double *col = out + (size_t)(s0 + c - c0) * N;
      col[s0 + c - c0] = ljj_[s0 + c];
      for (int r = c + 1; r < w; r++) col[s0 + r - c0] = D[(size_t)r * (r - 1) / 2 + c];
      for (int p = 0; p < m; p++) col[R[p] - c0] = B[(size_t)p * w + c];
    }
  }
}
} // namespace msim
