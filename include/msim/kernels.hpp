/* Pure per-spring kernels: energy, force, Hessian block, damping. No PETSc, no state: unit-tested
   against finite differences (tests/unit/test_kernels.cpp). Conventions: d = xi - xj, l = |d|,
   n = d / l, E = k/2 (l - L)^2. The force on i is -dE/dxi; the force on j is its negative. */
#pragma once
#include <Eigen/Core>
#include <cmath>

namespace msim {
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

inline double SpringEnergy(const Vec3 &xi, const Vec3 &xj, double k, double L)
{
  const double e = (xi - xj).norm() - L;
  return 0.5 * k * e * e;
}

/* Force on vertex i. */
inline Vec3 SpringForce(const Vec3 &xi, const Vec3 &xj, double k, double L)
{
  const Vec3   d = xi - xj;
  const double l = d.norm();
  return (-k * (l - L) / l) * d;
}

/* d2E/dxi2 = k [a I + (1 - a) n n^T], a = 1 - L/l. The (i,j) block is its negative. Under
   compression (l < L) the transverse eigenvalue k a is negative; psd clamps it to zero, which keeps
   M + h^2 K positive definite so CG and Cholesky apply. */
inline Mat3 SpringHessian(const Vec3 &xi, const Vec3 &xj, double k, double L, bool psd)
{
  const Vec3   d = xi - xj;
  const double l = d.norm();
  double       a = 1.0 - L / l;
  if (psd && a < 0.0) a = 0.0;
  const Vec3 n = d / l;
  return k * (a * Mat3::Identity() + (1.0 - a) * (n * n.transpose()));
}

/* Damping force on i: -kd ((vi - vj) . n) n, along the spring only. */
inline Vec3 SpringDampingForce(const Vec3 &xi, const Vec3 &xj, const Vec3 &vi, const Vec3 &vj, double kd)
{
  const Vec3 n = (xi - xj).normalized();
  return (-kd * n.dot(vi - vj)) * n;
}

/* Projective dynamics local step: the point of the spring's constraint set closest to d = xi - xj,
   a vector of length L along d. */
inline Vec3 SpringProjection(const Vec3 &xi, const Vec3 &xj, double L)
{
  const Vec3   d = xi - xj;
  const double l = d.norm();
  return (L / l) * d;
}
} // namespace msim
