/* Per-tet kernels of the volume term (src/springs/volume.cpp), pure functions of the 4 vertex
   positions, so that the unit test checks them by finite differences. With the signed volume
     V(x) = (x1 - x0) . ((x2 - x0) x (x3 - x0)) / 6,   J = V / V0   (V0 signed: J = 1 at rest
   whatever the file's orientation), the tet's energy is |V0| psi(J) with
     psi(J) = kv/2 (J - 1)^2                                   (Teschner et al. 2004)
            + kappa b(J),  b(J) = -(J - Jhat)^2 log(J / Jhat) on (0, Jhat), 0 beyond
   (IPC's log barrier, Li et al. 2020, on J instead of a distance: C2 at Jhat, infinite at J = 0).
   psi'' = kv + kappa b'' >= 0 on (0, inf), so the only indefinite part of the Hessian is
   psi' D^2 V; the PSD projection clamps the 12 x 12 block's negative eigenvalues. */
#pragma once
#include <petscsys.h>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace msim {
typedef Eigen::Matrix<double, 12, 1>  Vec12;
typedef Eigen::Matrix<double, 12, 12> Mat12;

struct TetMaterial {
  double kv, kappa, jhat; /* volume stiffness (Pa), barrier stiffness (Pa), barrier's reach in J */
};

/* psi(J) and its first two derivatives; J <= 0 gives psi = +inf (with the barrier) */
inline void TetPsi(const TetMaterial &m, double J, double *psi, double *dpsi, double *d2psi)
{
  double p = 0.5 * m.kv * (J - 1) * (J - 1), d = m.kv * (J - 1), d2 = m.kv;
  if (m.kappa > 0 && J < m.jhat) {
    if (J <= 0) {
      p = INFINITY;
    } else {
      const double r = J - m.jhat, l = std::log(J / m.jhat);
      p += m.kappa * (-r * r * l);
      d += m.kappa * (-2 * r * l - r * r / J);
      d2 += m.kappa * (-2 * l - 4 * r / J + r * r / (J * J));
    }
  }
  if (psi) *psi = p;
  if (dpsi) *dpsi = d;
  if (d2psi) *d2psi = d2;
}

/* plain loops on 3-arrays: the hot passes (PD's right-hand side, the objective, max_step) call
   these once per tet per iteration, and Eigen's fixed-size temporaries cost more than the work */
inline void Cross3(const double *a, const double *b, double *c)
{
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
inline double Dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

inline double TetSignedVolume(const double *x0, const double *x1, const double *x2, const double *x3)
{
  double e1[3], e2[3], e3[3], c[3];
  for (int k = 0; k < 3; k++) {
    e1[k] = x1[k] - x0[k];
    e2[k] = x2[k] - x0[k];
    e3[k] = x3[k] - x0[k];
  }
  Cross3(e2, e3, c);
  return Dot3(e1, c) * (1.0 / 6.0);
}

/* V and dV/dx (12: x0, x1, x2, x3) */
inline double TetVolumeGradient(const double *const x[4], double *g)
{
  double e[3][3];
  for (int q = 0; q < 3; q++)
    for (int k = 0; k < 3; k++) e[q][k] = x[q + 1][k] - x[0][k];
  Cross3(e[1], e[2], g + 3);
  Cross3(e[2], e[0], g + 6);
  Cross3(e[0], e[1], g + 9);
  for (int k = 0; k < 3; k++) {
    g[3 + k] *= 1.0 / 6.0;
    g[6 + k] *= 1.0 / 6.0;
    g[9 + k] *= 1.0 / 6.0;
    g[k] = -(g[3 + k] + g[6 + k] + g[9 + k]);
  }
  return Dot3(e[0], g + 3);
}
inline double TetVolumeGradient(const double *const x[4], Vec12 &g) { return TetVolumeGradient(x, g.data()); }

/* D^2 V (12 x 12): in the edge vectors e_k = x_k - x0 the blocks are (e_i, e_j) = eps_ijk [e_k]x / 6
   (zero on the diagonal), mapped to x by e = T x */
inline void TetVolumeHessian(const double *const x[4], Mat12 &H)
{
  const Eigen::Vector3d a = Eigen::Map<const Eigen::Vector3d>(x[0]);
  Eigen::Vector3d       e[3];
  for (int k = 0; k < 3; k++) e[k] = Eigen::Map<const Eigen::Vector3d>(x[k + 1]) - a;
  auto cross = [](const Eigen::Vector3d &v) {
    Eigen::Matrix3d c;
    c << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0;
    return c;
  };
  Eigen::Matrix<double, 9, 9> He = Eigen::Matrix<double, 9, 9>::Zero();
  He.block<3, 3>(0, 3) = -cross(e[2]) / 6.0; /* d2V / de1 de2 */
  He.block<3, 3>(0, 6) = cross(e[1]) / 6.0;  /* d2V / de1 de3 */
  He.block<3, 3>(3, 6) = -cross(e[0]) / 6.0; /* d2V / de2 de3 */
  He.block<3, 3>(3, 0) = He.block<3, 3>(0, 3).transpose();
  He.block<3, 3>(6, 0) = He.block<3, 3>(0, 6).transpose();
  He.block<3, 3>(6, 3) = He.block<3, 3>(3, 6).transpose();
  /* H = T^T He T with T = [-I I 0 0; -I 0 I 0; -I 0 0 I] */
  H.setZero();
  H.block<9, 9>(3, 3) = He;
  for (int i = 0; i < 3; i++) {
    Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
    for (int j = 0; j < 3; j++) s += He.block<3, 3>(3 * j, 3 * i);
    H.block<3, 3>(0, 3 * i + 3) = -s; /* (x0, x_{i+1}): -sum_j He(j, i) */
    H.block<3, 3>(3 * i + 3, 0) = -s.transpose();
  }
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) s += He.block<3, 3>(3 * i, 3 * j);
  H.block<3, 3>(0, 0) = s;
}

/* The tet's energy |V0| psi(J) and, where asked, its gradient and Hessian (psd: projected) */
inline double TetEnergy(const TetMaterial &m, double V0, const double *const x[4], Vec12 *grad, Mat12 *hess, bool psd)
{
  Vec12        g;
  const double V = TetVolumeGradient(x, g), J = V / V0, w = std::fabs(V0);
  double       psi, dpsi, d2psi;
  TetPsi(m, J, &psi, &dpsi, &d2psi);
  if (grad) *grad = (w * dpsi / V0) * g;
  if (hess) {
    Mat12 HV;
    TetVolumeHessian(x, HV);
    *hess = (w * d2psi / (V0 * V0)) * (g * g.transpose()) + (w * dpsi / V0) * HV;
    if (psd) {
      Eigen::SelfAdjointEigenSolver<Mat12> es(*hess);
      const Vec12                          lam = es.eigenvalues().cwiseMax(0.0);
      *hess = es.eigenvectors() * lam.asDiagonal() * es.eigenvectors().transpose();
    }
  }
  return w * psi;
}

/* A safe radius: if each of the 4 vertices moves by less than r from x, the tet keeps
   6 |V| > 6 |V0| jhat (so J > jhat: outside the barrier's reach, and far from inverting). With
   the edges e_i = x_i - x_0 moved by d_i (|d_i| < 2 r), Hadamard's inequality on the 7 terms of
   det(e + d) - det(e) bounds the loss by 2 r S2 + 4 r^2 S1 + 8 r^3, S2 = sum_{i<j} |e_i||e_j|
   <= L = sum |e_i|^2, S1 = sum |e_i| <= sqrt(3 L). With r = t sqrt(L) and t <= 0.1 the loss is
   below L^1.5 t (2 + 0.4 sqrt(3) + 0.08) < 2.78 L^1.5 t, so any r with r^2 < g^2 / (2.78^2 L^2)
   and r^2 <= L / 100 is safe, g = 6 |V| - 6 |V0| jhat (none where g <= 0). The passes keep g and
   L per tet (TetSafeGap) and the test multiplies (TetWithinSafeRadius): no square root and no
   division in the per-iteration loops. */
inline double TetEdgeSquares(const double *const x[4])
{
  double L = 0;
  for (int q = 1; q < 4; q++)
    for (int k = 0; k < 3; k++) L += (x[q][k] - x[0][k]) * (x[q][k] - x[0][k]);
  return L;
}
/* g of the tet at x (sign of V0 taken: positive while J > jhat) */
inline double TetSafeGap(double V0, const double *const x[4], double jhat)
{
  const double V = TetSignedVolume(x[0], x[1], x[2], x[3]);
  return 6 * ((V0 > 0 ? V : -V) - std::fabs(V0) * jhat);
}
/* whether a motion of every vertex by less than sqrt(m2) is within the safe radius of (g, L);
   false for NaN */
inline bool TetWithinSafeRadius(double m2, double g, double L) { return g > 0 && m2 < 0.01 * L && 7.7284 * m2 * L * L < g * g; }

/* The first alpha in (0, amax] at which the signed volume of x - alpha y reaches 0 (the cubic
   c0 + c1 a + c2 a^2 + c3 a^3, with the sign of V0 so that it starts positive), or amax when it
   never does. Monotone pieces between the derivative's roots, each bisected where its end is not
   positive: exact up to roundoff, never a root missed between samples. With low, *low gets the
   least value of 6 x the signed volume (sign of V0) over [0, amax] (up to roundoff): where it is
   above 6 |V0| jhat no point of the motion reaches the barrier. */
inline double TetFirstZero(double V0, const double *const x[4], const double *const y[4], double amax, double *low = nullptr)
{
  double e[3][3], d[3][3], ee[3], ed[3], de[3], dd[3];
  for (int q = 0; q < 3; q++)
    for (int k = 0; k < 3; k++) {
      e[q][k] = x[q + 1][k] - x[0][k];
      d[q][k] = y[0][k] - y[q + 1][k]; /* x - alpha y: edges e + alpha d */
    }
  Cross3(e[1], e[2], ee);
  Cross3(e[1], d[2], ed);
  Cross3(d[1], e[2], de);
  Cross3(d[1], d[2], dd);
  const double s  = V0 > 0 ? 1.0 : -1.0;
  const double c0 = s * Dot3(e[0], ee);
  const double c1 = s * (Dot3(d[0], ee) + Dot3(e[0], de) + Dot3(e[0], ed));
  const double c2 = s * (Dot3(d[0], de) + Dot3(d[0], ed) + Dot3(e[0], dd));
  const double c3 = s * Dot3(d[0], dd);
  auto         f  = [&](double t) { return ((c3 * t + c2) * t + c1) * t + c0; };
  const double lb = c0 - amax * (std::fabs(c1) + amax * (std::fabs(c2) + amax * std::fabs(c3)));
  if (!(c0 > 0)) { /* already flat or inverted */
    if (low) *low = c0;
    return 0.0;
  }
  /* most tets: a lower bound of the cubic on [0, amax] that stays positive */
  if (lb > 0 && !low) return amax;
  /* the ends of the monotone pieces: 0, the roots of 3 c3 t^2 + 2 c2 t + c1 in (0, amax), amax */
  double ends[4] = {0, amax, amax, amax};
  int    n       = 1;
  if (c3 != 0) {
    const double disc = c2 * c2 - 3 * c3 * c1;
    if (disc >= 0) {
      const double q = -(c2 + std::copysign(std::sqrt(disc), c2)), r1 = q / (3 * c3), r2 = q != 0 ? c1 / q : r1;
      const double lo = std::min(r1, r2), hi = std::max(r1, r2);
      if (lo > 0 && lo < amax) ends[n++] = lo;
      if (hi > 0 && hi < amax && hi != lo) ends[n++] = hi;
    }
  } else if (c2 != 0) {
    const double r = -c1 / (2 * c2);
    if (r > 0 && r < amax) ends[n++] = r;
  }
  ends[n++] = amax;
  if (low) { /* the cubic's least value on [0, amax]: at an end of a monotone piece */
    *low = c0;
    for (int k = 1; k < n; k++) *low = std::min(*low, f(ends[k]));
    if (lb > 0) return amax;
  }
  for (int k = 0; k + 1 < n; k++) {
    double lo = ends[k], hi = ends[k + 1];
    if (f(hi) > 0) continue;
    for (int it = 0; it < 100 && hi - lo > 1e-15 * hi; it++) {
      const double mid = 0.5 * (lo + hi);
      (f(mid) > 0 ? lo : hi) = mid;
    }
    return lo;
  }
  return amax;
}
} // namespace msim
