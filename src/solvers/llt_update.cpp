/* The low-rank diagonal update of msimllt's factor (llt_update.h). */
#include "llt_update.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>

namespace msim {


void LowRankUpdate::Clear()
{
  k_ = 0;
  gptr_.assign(1, 0);
  yrow_.clear();
  yval_.clear();
  lu_.reset();
}

bool LowRankUpdate::Build(const SupernodalFactor &F, const std::vector<int> &col, const std::vector<double> &d, double *flops)
{
  const int n = F.Size(), nsn = F.Supernodes(), k = (int)col.size(), ng = (k + 3) / 4;
  Clear();
  *flops = 0;
  if (!k) return true;
  work_.assign(n, V4{0, 0, 0, 0});
  mark_.assign(nsn, 0);
  std::vector<int> sn_of(n); /* the supernode holding each column */
  for (int s = 0; s < nsn; s++)
    for (int c = F.SupernodeStart(s); c < F.SupernodeStart(s + 1); c++) sn_of[c] = s;
  /* Y, four columns (lanes) at a time: e_j in lane l, the forward sweep over the supernodes the
     group's columns reach (smallest first: a supernode's rows below lie in later ones) */
  for (int g = 0; g < ng; g++) {
    const int                                         l1 = std::min(4, k - 4 * g);
    std::priority_queue<int, std::vector<int>, std::greater<int>> q;
    sn_.clear();
    for (int l = 0; l < l1; l++) {
      const int c = col[4 * g + l], s = sn_of[c];
      work_[c][l] = 1.0;
      if (!mark_[s]) {
        mark_[s] = 1;
        q.push(s);
      }
    }
    while (!q.empty()) {
      const int s = q.top();
      int       m;
      q.pop();
      sn_.push_back(s);
      const int *R = F.RowsBelow(s, &m);
      for (int p = 0; p < m; p++) {
        const int t = sn_of[R[p]];
        if (!mark_[t]) {
          mark_[t] = 1;
          q.push(t);
        }
      }
    }
    F.ForwardSupernodes(work_.data(), sn_.data(), (int)sn_.size());
    for (int s : sn_) {
      const int c0 = F.SupernodeStart(s), c1 = F.SupernodeStart(s + 1), w = c1 - c0;
      int       m;
      F.RowsBelow(s, &m);
      *flops += 2.0 * l1 * ((double)w * (w - 1) / 2 + (double)m * w + w);
      for (int c = c0; c < c1; c++) {
        yrow_.push_back(c);
        yval_.push_back(work_[c]);
        work_[c] = V4{0, 0, 0, 0};
      }
      mark_[s] = 0;
    }
    gptr_.push_back((int)yrow_.size());
  }
  /* C = D^-1 + Y^T Y: group g's columns scattered, dotted with every later group's */
  k_ = k;
  c_.assign((size_t)k * k, 0.0);
  for (int g = 0; g < ng; g++) {
    const int lg = std::min(4, k - 4 * g);
    for (int p = gptr_[g]; p < gptr_[g + 1]; p++) work_[yrow_[p]] = yval_[p];
    for (int h = g; h < ng; h++) {
      const int lh  = std::min(4, k - 4 * h);
      V4        acc[4] = {{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}};
      for (int p = gptr_[h]; p < gptr_[h + 1]; p++) {
        const V4 wg = work_[yrow_[p]], yh = yval_[p];
        for (int a = 0; a < 4; a++) acc[a] += Splat(wg[a]) * yh;
      }
      *flops += 32.0 * (gptr_[h + 1] - gptr_[h]);
      for (int a = 0; a < lg; a++)
        for (int b = 0; b < lh; b++) {
          const int i = 4 * g + a, j = 4 * h + b;
          c_[(size_t)i + (size_t)k * j] = c_[(size_t)j + (size_t)k * i] = acc[a][b];
        }
    }
    for (int p = gptr_[g]; p < gptr_[g + 1]; p++) work_[yrow_[p]] = V4{0, 0, 0, 0};
  }
  for (int i = 0; i < k; i++) c_[(size_t)i * (k + 1)] += 1.0 / d[i];
  /* C is indefinite where some change is negative: LU with partial pivoting (Eigen's; k is a few
     dozen) */
  lu_.reset(new Eigen::PartialPivLU<Eigen::MatrixXd>(Eigen::Map<const Eigen::MatrixXd>(c_.data(), k, k)));
  std::vector<double>().swap(c_);
  *flops += 2.0 / 3.0 * k * (double)k * k;
  std::vector<V4>().swap(work_);
  bool finite = true;
  for (int i = 0; i < k; i++) finite = finite && std::isfinite(lu_->matrixLU()(i, i)) && lu_->matrixLU()(i, i) != 0;
  if (!finite) {
    Clear();
    return false;
  }
  t_.assign((size_t)4 * k, 0.0);
  return true;
}

void LowRankUpdate::Apply(V4 *z, int nrhs, double *flops) const
{
  const int k = k_, ng = (k + 3) / 4;
  *flops = 0;
  if (!k) return;
  /* t = Y^T z: row i of t holds column i of Y dotted with each lane of z */
  for (int g = 0; g < ng; g++) {
    V4 acc[4] = {{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}};
    /* acc[r]: lane r of z dotted with the group's four columns (the lanes of y) */
    for (int p = gptr_[g]; p < gptr_[g + 1]; p++) {
      const V4 y = yval_[p], x = z[yrow_[p]];
      for (int r = 0; r < nrhs; r++) acc[r] += Splat(x[r]) * y;
    }
    for (int a = 0; a < 4 && 4 * g + a < k; a++)
      for (int r = 0; r < 4; r++) t_[(size_t)(4 * g + a) + (size_t)k * r] = acc[r][a];
  }
  Eigen::Map<Eigen::MatrixXd> t(t_.data(), k, 4);
  const Eigen::MatrixXd       s4 = lu_->solve(t);
  t                               = s4;
  /* z -= Y s */
  for (int g = 0; g < ng; g++) {
    V4 s[4] = {{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}};
    for (int a = 0; a < 4 && 4 * g + a < k; a++) s[a] = V4{t_[(size_t)(4 * g + a)], t_[(size_t)(4 * g + a) + k], t_[(size_t)(4 * g + a) + 2 * (size_t)k], t_[(size_t)(4 * g + a) + 3 * (size_t)k]};
    for (int p = gptr_[g]; p < gptr_[g + 1]; p++) {
      const V4 y = yval_[p];
      z[yrow_[p]] -= (Splat(y[0]) * s[0] + Splat(y[1]) * s[1]) + (Splat(y[2]) * s[2] + Splat(y[3]) * s[3]);
    }
  }
  *flops = (8.0 * nrhs + 32.0) * (double)yrow_.size() + 2.0 * nrhs * k * (double)k;
}
} // namespace msim
