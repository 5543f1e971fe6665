/* Per-spring kernels against central finite differences: force = -dE/dx, Hessian = -dF/dx, the
   damping force's direction and sign, the PD projection's length; random configurations in
   stretch and compression. The vectorized sweeps (the slices with their padding, the arrays, the
   fold) against the per-spring kernels on a random graph. */
#include "harness.h"
#include <msim/kernels.hpp>
#include <msim/spring_sweep.h>
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

/* A random graph of 4 m + 3 vertices (three past the last slice) with uneven degrees (padded
   lanes): the sliced sweep plus the array sweep plus the fold give every vertex the force the
   per-spring kernel gives, for the force (-1, 1) and the PD projection (0, h^2), and the energy. */
static PetscErrorCode TestSweeps(void)
{
  std::mt19937                           rng(777);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const PetscInt                         nv = 4 * 25 + 3;
  std::vector<PetscInt>                  a, b, rest;
  std::vector<PetscReal>                 k, L, x(3 * nv);
  MSimSprings                            sp;

  PetscFunctionBeginUser;
  for (auto &c : x) c = u(rng);
  for (PetscInt v = 1; v < nv; v++) {
    const int deg = 1 + (int)(rng() % 7);
    for (int q = 0; q < deg; q++) {
      const PetscInt w = (PetscInt)(rng() % v); /* a lower vertex */
      const Vec3     d = Vec3(x[3 * v], x[3 * v + 1], x[3 * v + 2]) - Vec3(x[3 * w], x[3 * w + 1], x[3 * w + 2]);
      a.push_back(q % 2 ? v : w); /* either end first */
      b.push_back(q % 2 ? w : v);
      k.push_back(10 + 1000 * std::abs(u(rng)));
      L.push_back(d.norm() * (1 + 0.5 * u(rng)));
    }
  }
  PetscCall(MSimSpringsSlice(nv, a, b, k, L, &sp, rest));
  std::vector<PetscInt>  ti, tj;
  std::vector<PetscReal> tk, tL;
  for (PetscInt s : rest) ti.push_back(a[s]), tj.push_back(b[s]), tk.push_back(k[s]), tL.push_back(L[s]);
  sp.n = sp.ninner = (PetscInt)ti.size();
  sp.i = ti, sp.j = tj, sp.k = tk, sp.L = tL;
  {
    PetscInt  count = 0;
    PetscReal ksum = 0, kref = 0;
    MSimSpringsForEach(sp, [&](PetscInt, PetscInt, PetscReal kk, PetscReal) { count++, ksum += kk; });
    for (PetscReal kk : k) kref += kk;
    NOTE("sweep test: %zu springs, %" PetscInt_FMT " in %" PetscInt_FMT " slices of %" PetscInt_FMT " slots, %zu after them\n", a.size(), (PetscInt)a.size() - (PetscInt)rest.size(), sp.nslice, sp.cptr.back(), rest.size());
    CHECK(count == (PetscInt)a.size() && std::abs(ksum - kref) <= 1e-12 * kref, "MSimSpringsForEach visits %" PetscInt_FMT " springs of %zu", count, a.size());
  }
  const double h2 = 1.0 / 900;
  for (int mode = 0; mode < 2; mode++) {
    const PetscReal        alpha = mode ? 0.0 : -1.0, beta = mode ? h2 : 1.0;
    std::vector<PetscReal> f(3 * nv, 0.0), fref(3 * nv, 0.0);
    std::vector<MSimRow4>  f4(nv, MSimRow4{{0, 0, 0, 0}});
    PetscReal              e = 0, eref = 0, fmax = 0, diff = 0;
    for (size_t s = 0; s < a.size(); s++) {
      const Vec3 xi(&x[3 * a[s]]), xj(&x[3 * b[s]]);
      const Vec3 fi = mode ? Vec3(h2 * k[s] * msim::SpringProjection(xi, xj, L[s])) : msim::SpringForce(xi, xj, k[s], L[s]);
      for (int c = 0; c < 3; c++) fref[3 * a[s] + c] += fi[c], fref[3 * b[s] + c] -= fi[c];
      eref += msim::SpringEnergy(xi, xj, k[s], L[s]);
    }
    MSimSpringSweepSlices(sp.nslice, sp.cptr.data(), sp.sj.data(), sp.sk.data(), sp.sL.data(), x.data(), f4[0].v, alpha, beta, &e);
    MSimSpringSweep(sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x.data(), f.data(), alpha, beta, &e);
    MSimSpringFold(4 * sp.nslice, f4[0].v, f.data());
    for (PetscInt i = 0; i < 3 * nv; i++) fmax = std::max(fmax, std::abs(fref[i])), diff = std::max(diff, std::abs(f[i] - fref[i]));
    bool zeroed = true;
    for (const auto &r : f4) zeroed = zeroed && r.v[0] == 0 && r.v[1] == 0 && r.v[2] == 0;
    NOTE("sweep test (%s): max force difference %.2e of %.2e, energy %.15e vs %.15e\n", mode ? "PD projection" : "force", diff, fmax, e, eref);
    CHECK(diff <= 1e-12 * fmax, "sweep (%s): force differs by %g of %g", mode ? "PD projection" : "force", diff, fmax);
    CHECK(std::abs(e - eref) <= 1e-12 * eref, "sweep: energy %g vs %g", e, eref);
    CHECK(zeroed, "the fold left the scratch rows non-zero");
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestAll(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestKernels());
  PetscCall(TestSweeps());
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestAll)
