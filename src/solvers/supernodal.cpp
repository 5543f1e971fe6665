/* Supernodal triangular solves. The kernels keep their running sums in registers (several
   independent sums, so the FMA latency does not serialize them) and touch each row of z below a
   supernode once. Written with GCC vector extensions: one AVX instruction per 4-lane operation
   where the build enables AVX2 (CMake's MSIM_ARCH), two SSE instructions otherwise. */
#include "supernodal.h"
#include <algorithm>
#include <iterator>

namespace msim {

void SupernodalFactor::Build(int n, const int *colptr, const int *row, const double *val, int split, double relax, int max_width)
{
  n_ = n;
  /* the fundamental supernodes: column j+1 continues one when its structure is column j's
     without row j */
  std::vector<int> fund(1, 0);
  for (int j = 0; j + 1 < n; j++) {
    const int cj = colptr[j + 1] - colptr[j], cj1 = colptr[j + 2] - colptr[j + 1];
    if (!(cj >= 2 && row[colptr[j] + 1] == j + 1 && cj == cj1 + 1) || j + 1 == split) fund.push_back(j + 1);
  }
  fund.push_back(n);
  /* relaxed amalgamation, left to right: the next fundamental supernode joins the current group
     when the group's stored entries, zeros now included, stay within (1 + relax) of what the
     parts store apart. Rows below the group are the union of its columns' rows. */
  auto stored = [](int64_t w, int64_t m) { return w * (w - 1) / 2 + m * w; };
  std::vector<int>              rows_below, merged, tail;
  std::vector<std::vector<int>> group_rows;
  start_.assign(1, 0);
  int64_t apart = 0;
  for (size_t f = 0; f + 1 < fund.size(); f++) {
    const int t0 = fund[f], t1 = fund[f + 1], wt = t1 - t0, mt = colptr[t0 + 1] - colptr[t0] - wt;
    tail.assign(row + colptr[t0] + wt, row + colptr[t0 + 1]);
    const int g0 = start_.back(), wg = t0 - g0;
    if (wg > 0) {
      merged.clear();
      std::set_union(std::upper_bound(rows_below.begin(), rows_below.end(), t1 - 1), rows_below.end(), tail.begin(), tail.end(), std::back_inserter(merged));
      const int64_t w = t1 - g0, together = stored(w, (int64_t)merged.size()), parts = apart + stored(wt, mt);
      if (t0 != split && w <= max_width && together <= (1 + relax) * parts) {
        rows_below.swap(merged);
        apart = parts;
        continue;
      }
      group_rows.push_back(rows_below);
      start_.push_back(t0);
    }
    rows_below.swap(tail);
    apart = stored(wt, mt);
  }
  group_rows.push_back(rows_below);
  start_.push_back(n);
  const int nsn = (int)start_.size() - 1;
  rptr_.assign(nsn + 1, 0);
  sptr_.assign(nsn + 1, 0);
  sbelow_.clear();
  vptr_.assign(nsn + 1, 0);
  for (int s = 0; s < nsn; s++) {
    const int w = start_[s + 1] - start_[s], m = (int)group_rows[s].size();
    rptr_[s + 1] = rptr_[s] + m;
    vptr_[s + 1] = vptr_[s] + stored(w, m);
  }
  rows_.resize(rptr_[nsn]);
  snof_.resize(n);
  for (int s = 0; s < nsn; s++) std::fill(snof_.begin() + start_[s], snof_.begin() + start_[s + 1], s);
  val_.assign(vptr_[nsn], 0.0);
  invdiag_.resize(n);
  std::vector<int> pos(n, -1); /* a row's place among the rows below the current supernode */
  for (int s = 0; s < nsn; s++) {
    const int c0 = start_[s], c1 = start_[s + 1], w = c1 - c0, m = (int)group_rows[s].size();
    double   *D = val_.data() + vptr_[s], *B = D + (size_t)w * (w - 1) / 2; /* data(): val_ may be empty (a diagonal matrix) */
    for (int p = 0; p < m; p++) pos[rows_[rptr_[s] + p] = group_rows[s][p]] = p;
    std::vector<int>().swap(group_rows[s]);
    for (int p = 0; p < m; p++) /* the rows ascending: a supernode's rows come together */
      if (sbelow_.size() == (size_t)sptr_[s] || sbelow_.back() != snof_[rows_[rptr_[s] + p]]) sbelow_.push_back(snof_[rows_[rptr_[s] + p]]);
    sptr_[s + 1] = (int)sbelow_.size();
    for (int c = 0; c < w; c++) {
      const int off = colptr[c0 + c];
      invdiag_[c0 + c] = 1.0 / val[off];
      for (int q = off + 1; q < colptr[c0 + c + 1]; q++) {
        const int r = row[q] - c0;
        if (row[q] < c1) D[(size_t)r * (r - 1) / 2 + c] = val[q];
        else B[(size_t)pos[row[q]] * w + c] = val[q];
      }
    }
  }
}

/* z(R[p .. p+U)) -= B[p .. p+U, :] y: U rows of the block below a supernode together, so each y[c]
   is loaded once for all of them; two sums per row */
template <int U>
static inline void ForwardRows(const double *B, int w, const int *R, V4 *z, const V4 *y, int p)
{
  V4            a[U][2];
  const double *b = B + (size_t)p * w;
  int           c = 0;
  for (int u = 0; u < U; u++) a[u][0] = a[u][1] = V4{0, 0, 0, 0};
  for (; c + 2 <= w; c += 2) {
    const V4 y0 = y[c], y1 = y[c + 1];
    for (int u = 0; u < U; u++) {
      a[u][0] += Splat(b[(size_t)u * w + c]) * y0;
      a[u][1] += Splat(b[(size_t)u * w + c + 1]) * y1;
    }
  }
  if (c < w)
    for (int u = 0; u < U; u++) a[u][0] += Splat(b[(size_t)u * w + c]) * y[c];
  for (int u = 0; u < U; u++) z[R[p + u]] -= a[u][0] + a[u][1];
}

/* y[c .. c+S) -= B[:, c .. c+S)^T z(R): S columns of the block below a supernode, U rows at a
   time, S x U independent sums in registers */
template <int S, int U>
static inline void BackwardColumns(const double *B, int w, int m, const int *R, const V4 *z, V4 *y, int c)
{
  V4  acc[U][S];
  int p = 0;
  for (int u = 0; u < U; u++)
    for (int k = 0; k < S; k++) acc[u][k] = V4{0, 0, 0, 0};
  for (; p + U <= m; p += U)
    for (int u = 0; u < U; u++) {
      const V4      x = z[R[p + u]];
      const double *b = B + (size_t)(p + u) * w + c;
      for (int k = 0; k < S; k++) acc[u][k] += Splat(b[k]) * x;
    }
  for (; p < m; p++) {
    const V4      x = z[R[p]];
    const double *b = B + (size_t)p * w + c;
    for (int k = 0; k < S; k++) acc[0][k] += Splat(b[k]) * x;
  }
  for (int k = 0; k < S; k++) {
    V4 t = acc[0][k];
    for (int u = 1; u < U; u++) t += acc[u][k];
    y[c + k] -= t;
  }
}

inline void SupernodalFactor::ForwardSupernode(V4 *z, int s) const
{
  const int     c0 = start_[s], w = start_[s + 1] - c0, m = rptr_[s + 1] - rptr_[s];
  const double *D = val_.data() + vptr_[s], *B = D + (size_t)w * (w - 1) / 2;
  const int    *R = rows_.data() + rptr_[s];
  V4           *y = z + c0;
  for (int c = 0; c < w; c++) /* the dense triangle */
    y[c] = RowSubtract(y[c], D + (size_t)c * (c - 1) / 2, y, c) * Splat(invdiag_[c0 + c]);
  int p = 0;
  for (; p + 4 <= m; p += 4) ForwardRows<4>(B, w, R, z, y, p);
  for (; p < m; p++) ForwardRows<1>(B, w, R, z, y, p);
}

void SupernodalFactor::Forward(V4 *z, int ncols) const
{
  const int nsn = (int)start_.size() - 1;
  for (int s = 0; s < nsn && start_[s] < ncols; s++) ForwardSupernode(z, s);
}

void SupernodalFactor::ForwardSupernodes(V4 *z, const int *sn, int count) const
{
  for (int k = 0; k < count; k++) ForwardSupernode(z, sn[k]);
}

void SupernodalFactor::Backward(V4 *z, int ncols) const
{
  int last = (int)start_.size() - 2;
  while (last >= 0 && start_[last] >= ncols) last--;
  for (int s = last; s >= 0; s--) {
    const int     c0 = start_[s], w = start_[s + 1] - c0, m = rptr_[s + 1] - rptr_[s];
    const double *D = val_.data() + vptr_[s], *B = D + (size_t)w * (w - 1) / 2;
    const int    *R = rows_.data() + rptr_[s];
    V4           *y = z + c0;
    int           c = 0;
    for (; c + 4 <= w; c += 4) BackwardColumns<4, 2>(B, w, m, R, z, y, c);
    switch (w - c) {
    case 3: BackwardColumns<3, 2>(B, w, m, R, z, y, c); break;
    case 2: BackwardColumns<2, 4>(B, w, m, R, z, y, c); break;
    case 1: BackwardColumns<1, 4>(B, w, m, R, z, y, c); break;
    }
    for (c = w - 1; c >= 0; c--) { /* the dense triangle, transposed */
      const V4      x = y[c] * Splat(invdiag_[c0 + c]);
      const double *d = D + (size_t)c * (c - 1) / 2;
      y[c]            = x;
      for (int k = 0; k < c; k++) y[k] -= Splat(d[k]) * x;
    }
  }
}

void SupernodalFactor::Solve(V4 *z) const
{
  Forward(z, n_);
  Backward(z, n_);
}
} // namespace msim
