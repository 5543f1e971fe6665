/* Per-spring kernels against central finite differences: force = -dE/dx, Hessian = -dF/dx, the
   damping force's direction and sign, the PD projection's length; random configurations in
   stretch and compression. */
#include "harness.h"
#include <msim/kernels.hpp>
#include <random>
#include <Eigen/Eigenvalues>

using msim::Mat3;
using msim::Vec3;

static PetscErrorCode TestKernels(void)
{
  std::mt19937                           rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double                           eps = 1e-6;

  PetscFunctionBeginUser;
  for (int trial = 0; trial < 200; trial++) {
    const Vec3   xi(u(rng), u(rng), u(rng)), xj(u(rng), u(rng), u(rng));
    const double l = (xi - xj).norm(), k = 10 + 1000 * std::abs(u(rng));
    const double L = l * (1.0 + 0.5 * u(rng)); /* stretched or compressed */
    /* force = -grad E (central differences in each coordinate of xi) */
    Vec3 fd;
    for (int c = 0; c < 3; c++) {
      Vec3 p = xi, m = xi;
      p[c] += eps;
      m[c] -= eps;
      fd[c] = -(msim::SpringEnergy(p, xj, k, L) - msim::SpringEnergy(m, xj, k, L)) / (2 * eps);
    }
    const Vec3 f = msim::SpringForce(xi, xj, k, L);
    CHECK((f - fd).norm() <= 1e-6 * (1 + f.norm()), "trial %d: force %g vs FD %g", trial, f.norm(), fd.norm());
    /* force on j is the negative of force on i */
    CHECK((msim::SpringForce(xj, xi, k, L) + f).norm() <= 1e-12 * (1 + f.norm()), "trial %d: action-reaction", trial);
    /* Hessian = -dF/dxi */
    Mat3 Hfd;
    for (int c = 0; c < 3; c++) {
      Vec3 p = xi, m = xi;
      p[c] += eps;
      m[c] -= eps;
      Hfd.col(c) = -(msim::SpringForce(p, xj, k, L) - msim::SpringForce(m, xj, k, L)) / (2 * eps);
    }
    const Mat3 H = msim::SpringHessian(xi, xj, k, L, false);
    CHECK((H - Hfd).norm() <= 1e-5 * (1 + H.norm()), "trial %d: Hessian off by %g", trial, (H - Hfd).norm());
    CHECK((H - H.transpose()).norm() <= 1e-12 * H.norm(), "trial %d: Hessian not symmetric", trial);
    /* PSD projection: smallest eigenvalue >= 0, unchanged under stretch */
    const Mat3                                     Hp = msim::SpringHessian(xi, xj, k, L, true);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(Hp);
    CHECK(es.eigenvalues().minCoeff() >= -1e-9 * k, "trial %d: projected Hessian has eigenvalue %g", trial, es.eigenvalues().minCoeff());
    if (l >= L) CHECK((Hp - H).norm() <= 1e-12 * H.norm(), "trial %d: projection changed a stretched spring", trial);
    /* damping: along the spring, opposing the relative velocity's axial part */
    const Vec3 vi(u(rng), u(rng), u(rng)), vj(u(rng), u(rng), u(rng)), n = (xi - xj) / l;
    const Vec3 fdmp = msim::SpringDampingForce(xi, xj, vi, vj, 3.0);
    CHECK((fdmp - (-3.0 * n.dot(vi - vj)) * n).norm() <= 1e-12 * (1 + fdmp.norm()), "trial %d: damping force", trial);
    CHECK(fdmp.dot(vi - vj) <= 1e-14, "trial %d: damping adds energy", trial);
    /* PD projection: length L along the spring */
    const Vec3 d = msim::SpringProjection(xi, xj, L);
    CHECK(std::abs(d.norm() - L) <= 1e-12 * L && d.dot(xi - xj) > 0, "trial %d: projection", trial);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestKernels)
