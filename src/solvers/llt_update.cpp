/* The low-rank diagonal update of msimllt's factor (llt_update.h). */
#include "llt_update.h"
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>

namespace msim {


void LowRankUpdate::Forget()
{
  Clear();
  cache_.clear();
}

void LowRankUpdate::Clear()
{
  k_ = 0;
  gptr_.assign(1, 0);
  rptr_.assign(1, 0);
  run_.clear();
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
  /* the supernodes that columns c[0 .. nc) reach, ascending (a supernode's rows below lie in
     later ones), through the supernodes holding each one's rows below (walking the rows
     themselves cost about a million valgrind instructions a build on the 101 x 101 cloth) */
  auto reach = [&](const int *c, int nc) {
    std::priority_queue<int, std::vector<int>, std::greater<int>> q;
    sn_.clear();
    for (int l = 0; l < nc; l++)
      if (!mark_[F.SupernodeOf(c[l])]) {
        mark_[F.SupernodeOf(c[l])] = 1;
        q.push(F.SupernodeOf(c[l]));
      }
    while (!q.empty()) {
      const int s = q.top();
      int       m;
      q.pop();
      sn_.push_back(s);
      const int *S = F.SupernodesBelow(s, &m);
      for (int p = 0; p < m; p++)
        if (!mark_[S[p]]) {
          mark_[S[p]] = 1;
          q.push(S[p]);
        }
    }
    for (int t : sn_) mark_[t] = 0;
  };
  /* the columns of Y not yet known for this base, four (lanes) at a time: e_j in lane l, the
     forward sweep over the supernodes the four reach; each column kept on its own reach's rows.
     Lane l's numbers are the same whichever columns share the sweep (the lanes never mix; another
     lane's supernodes only subtract zeros from it), so a column is a function of the base alone */
  std::vector<int> fresh;
  for (int c : col)
    if (!cache_.count(c)) fresh.push_back(c);
  for (size_t g = 0; g < fresh.size(); g += 4) {
    const int l1 = (int)std::min<size_t>(4, fresh.size() - g);
    for (int l = 0; l < l1; l++) work_[fresh[g + l]][l] = 1.0;
    reach(&fresh[g], l1);
    std::vector<int> all(sn_);
    F.ForwardSupernodes(work_.data(), all.data(), (int)all.size());
    for (int s : all) {
      const int c0 = F.SupernodeStart(s), w = F.SupernodeStart(s + 1) - c0;
      int       m;
      F.RowsBelow(s, &m);
      *flops += 2.0 * l1 * ((double)w * (w - 1) / 2 + (double)m * w + w);
    }
    for (int l = 0; l < l1; l++) {
      ColumnY &y = cache_[fresh[g + l]];
      reach(&fresh[g + l], 1);
      for (int s : sn_)
        for (int c = F.SupernodeStart(s); c < F.SupernodeStart(s + 1); c++) {
          y.rows.push_back(c);
          y.vals.push_back(work_[c][l]);
        }
    }
    for (int s : all)
      for (int c = F.SupernodeStart(s); c < F.SupernodeStart(s + 1); c++) work_[c] = V4{0, 0, 0, 0};
  }
  /* the groups of four of the changed columns in order, on the union of their rows */
  std::vector<int> pos(n, -1), yrow; /* yrow: the rows of yval_ */
  for (int g = 0; g < ng; g++) {
    const int l1 = std::min(4, k - 4 * g);
    reach(&col[4 * g], l1); /* the union of the four columns' rows */
    for (int t : sn_) {
      const int c0 = F.SupernodeStart(t), c1 = F.SupernodeStart(t + 1);
      if (run_.size() > (size_t)rptr_[g] && run_.back().row + run_.back().count == c0) run_.back().count += c1 - c0;
      else run_.push_back(Run{c0, c1 - c0});
      for (int c = c0; c < c1; c++) {
        pos[c] = (int)yrow.size();
        yrow.push_back(c);
      }
    }
    rptr_.push_back((int)run_.size());
    yval_.resize(yrow.size(), V4{0, 0, 0, 0});
    for (int l = 0; l < l1; l++) {
      const ColumnY &y = cache_[col[4 * g + l]];
      for (size_t p = 0; p < y.rows.size(); p++) yval_[pos[y.rows[p]]][l] = y.vals[p];
    }
    gptr_.push_back((int)yrow.size());
  }
  /* the cache holds every row that has differed from this base; a contact patch sliding over the
     cloth would fill it with nearly every row, each with its whole path, so past the factor's own
     size only the current columns are kept (each is a function of the base alone: the bits do
     not depend on what was kept) */
  {
    size_t held = 0;
    for (const auto &e : cache_) held += e.second.rows.size();
    if (held > (size_t)F.Entries()) {
      std::unordered_map<int, ColumnY> now;
      for (int c : col) now[c] = std::move(cache_[c]);
      cache_.swap(now);
    }
  }
  /* C = D^-1 + Y^T Y: group g's columns scattered, dotted with every later group's */
  k_ = k;
  c_.assign((size_t)k * k, 0.0);
  for (int g = 0; g < ng; g++) {
    const int lg = std::min(4, k - 4 * g);
    for (int p = gptr_[g]; p < gptr_[g + 1]; p++) work_[yrow[p]] = yval_[p];
    for (int h = g; h < ng; h++) {
      const int lh  = std::min(4, k - 4 * h);
      V4        acc[4] = {{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}};
      for (int p = gptr_[h]; p < gptr_[h + 1]; p++) {
        const V4 wg = work_[yrow[p]], yh = yval_[p];
        for (int a = 0; a < 4; a++) acc[a] += Splat(wg[a]) * yh;
      }
      *flops += 32.0 * (gptr_[h + 1] - gptr_[h]);
      for (int a = 0; a < lg; a++)
        for (int b = 0; b < lh; b++) {
          const int i = 4 * g + a, j = 4 * h + b;
          c_[(size_t)i + (size_t)k * j] = c_[(size_t)j + (size_t)k * i] = acc[a][b];
        }
    }
    for (int p = gptr_[g]; p < gptr_[g + 1]; p++) work_[yrow[p]] = V4{0, 0, 0, 0};
  }
  for (int i = 0; i < k; i++) c_[(size_t)i * (k + 1)] += 1.0 / d[i];
  {
    /* A = B + P D P^T with B positive definite is positive definite exactly when C has as many
       negative eigenvalues as D has negative entries (Sylvester's law of inertia on the two
       congruent block forms of [[B, P], [P^T, -D^-1]]): certainly so where no change is negative;
       otherwise C's eigenvalues (a symmetric solver: C is then indefinite, which Eigen's LDLT does
       not promise to handle), and on a mismatch the caller refactors, whose factorization names
       the matrix's non-positive pivot as it would without an update */
    int negd = 0;
    for (int i = 0; i < k; i++) negd += d[i] < 0;
    if (negd) {
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Eigen::Map<const Eigen::MatrixXd>(c_.data(), k, k), Eigen::EigenvaluesOnly);
      int negc = eig.info() == Eigen::Success ? 0 : -1;
      for (int i = 0; negc >= 0 && i < k; i++) negc += eig.eigenvalues()[i] < 0;
      *flops += 4.0 / 3.0 * k * (double)k * k;
      if (negc != negd) {
        std::vector<double>().swap(c_);
        std::vector<V4>().swap(work_);
        Clear();
        return false;
      }
    }
  }
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

/* acc[r] += lane r of z's rows times the group's rows of Y (y, lanes: its four columns) for
   r < R: with R a constant the four sums stay in registers (a run-time count of right-hand sides
   kept them in memory, 30 instructions a row of Y). Each sum runs over the rows in ascending
   order, as before. */
template <int R>
static void GroupTranspose(const V4 *z, const std::vector<LowRankUpdate::Run> &run, int r0, int r1, const V4 *y, V4 *acc)
{
  V4 a[R];
  for (int r = 0; r < R; r++) a[r] = V4{0, 0, 0, 0};
  for (int u = r0; u < r1; u++) {
    const V4 *zr = z + run[u].row;
    for (int q = 0; q < run[u].count; q++, y++)
      for (int r = 0; r < R; r++) a[r] += Splat(zr[q][r]) * *y;
  }
  for (int r = 0; r < R; r++) acc[r] = a[r];
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
    const V4 *y = yval_.data() + gptr_[g];
    switch (nrhs) {
    case 1: GroupTranspose<1>(z, run_, rptr_[g], rptr_[g + 1], y, acc); break;
    case 2: GroupTranspose<2>(z, run_, rptr_[g], rptr_[g + 1], y, acc); break;
    case 3: GroupTranspose<3>(z, run_, rptr_[g], rptr_[g + 1], y, acc); break;
    default: GroupTranspose<4>(z, run_, rptr_[g], rptr_[g + 1], y, acc); break;
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
    const V4 *y = yval_.data() + gptr_[g];
    for (int u = rptr_[g]; u < rptr_[g + 1]; u++) {
      V4 *zr = z + run_[u].row;
      for (int q = 0; q < run_[u].count; q++, y++) zr[q] -= (Splat((*y)[0]) * s[0] + Splat((*y)[1]) * s[1]) + (Splat((*y)[2]) * s[2] + Splat((*y)[3]) * s[3]);
    }
  }
  *flops = (8.0 * nrhs + 32.0) * (double)yval_.size() + 2.0 * nrhs * k * (double)k;
}
} // namespace msim
