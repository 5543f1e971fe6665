/* Per-spring kernels against central finite differences: force = -dE/dx, Hessian = -dF/dx, the
   damping force's direction and sign, the PD projection's length; random configurations in
   stretch and compression. The vectorized sweeps (the slices with their padding, the arrays, the
   ring and the rows of 4) against the per-spring kernels on a grid-like strip with random extra
   springs, shifted and gathered slots alike. */
#include "harness.h"
#include <msim/kernels.hpp>
#include <msim/system.h>
/* the sweep test fills the system's spring storage (MSimSprings) by hand and walks it with
   MSimSpringsForEach: both are the system's internals */
#include <msim/private/systemimpl.h>
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
   per-spring kernel gives, for the force (-1, 1) and the PD projection (0, h^2), and the energy;
   also the force with spring damping. */
static PetscErrorCode TestSweeps(void)
{
  std::mt19937                           rng(777);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const PetscInt                         nv = 4 * 40 + 3, width = 7;
  std::vector<PetscInt>                  a, b, rest;
  std::vector<PetscReal>                 k, L, x(3 * nv);
  MSimSlices                             sl;
  MSimSweepScratch                       w;

  PetscFunctionBeginUser;
  for (auto &c : x) c = u(rng);
  auto add = [&](PetscInt v, PetscInt q) {
    const Vec3 d = Vec3(x[3 * v], x[3 * v + 1], x[3 * v + 2]) - Vec3(x[3 * q], x[3 * q + 1], x[3 * q + 2]);
    a.push_back(a.size() % 2 ? v : q); /* either end first */
    b.push_back(a.size() % 2 ? v : q);
    if (a.back() == b.back()) b.back() = (b.back() == v ? q : v);
    k.push_back(10 + 1000 * std::abs(u(rng)));
    L.push_back(d.norm() * (1 + 0.5 * u(rng)));
  };
  /* grid-like springs (a strip of the given width: left, up, both diagonals, two up), some left
     out so that not every lane has every offset, and random ones to any lower vertex */
  for (PetscInt v = 1; v < nv; v++) {
    for (PetscInt off : {1, width, width - 1, width + 1, 2 * width})
      if (v >= off && rng() % 10) add(v, v - off);
    const int deg = (int)(rng() % 4);
    for (int q = 0; q < deg; q++) add(v, (PetscInt)(rng() % v));
  }
  PetscCall(MSimSlicesCreate(nv, a, b, k, L, &sl, rest));
  PetscCall(MSimSweepScratchSetUp(&sl, PETSC_TRUE, &w));
  MSimSprings sp;
  sp.slices = sl;
  for (PetscInt s : rest) sp.i.push_back(a[s]), sp.j.push_back(b[s]), sp.k.push_back(k[s]), sp.L.push_back(L[s]);
  sp.n = sp.ninner = (PetscInt)sp.i.size();
  {
    PetscInt  count = 0, shifted = 0;
    PetscReal ksum = 0, kref = 0;
    MSimSpringsForEach(sp, [&](PetscInt, PetscInt, PetscReal kk, PetscReal) { count++, ksum += kk; });
    for (PetscReal kk : k) kref += kk;
    for (PetscInt c = 0; c < sl.nslice; c++) shifted += sl.cmid[c] - sl.cptr[c];
    NOTE("sweep test: %zu springs, %" PetscInt_FMT " in %" PetscInt_FMT " slices of %" PetscInt_FMT " slots (%" PetscInt_FMT " shifted), %zu after them; ring of %" PetscInt_FMT ", lag %" PetscInt_FMT "\n", a.size(), (PetscInt)a.size() - (PetscInt)rest.size(), sl.nslice, sl.cptr.back(), shifted, rest.size(), w.W, w.lag);
    CHECK(count == (PetscInt)a.size() && std::abs(ksum - kref) <= 1e-12 * kref, "MSimSpringsForEach visits %" PetscInt_FMT " springs of %zu", count, a.size());
    CHECK(shifted > 0 && shifted < sl.cptr.back(), "the test needs shifted and gathered slots (%" PetscInt_FMT " of %" PetscInt_FMT " shifted)", shifted, sl.cptr.back());
    CHECK(4 * w.W < 3 * nv, "the test needs a ring that wraps (%" PetscInt_FMT " entries, %" PetscInt_FMT " vertices)", w.W, nv);
    for (PetscInt c = 0; c < sl.nslice; c++)
      for (PetscInt q = sl.cptr[c]; q < sl.cmid[c]; q++)
        for (PetscInt l = 0; l < 4; l++) CHECK(sl.sj[4 * q + l] == sl.sj[4 * q] + l && sl.sj[4 * q] < 4 * c, "slot %" PetscInt_FMT " is not a run of lower vertices", q);
  }
  const double h2 = 1.0 / 900;
  for (int mode = 0; mode < 2; mode++) {
    const PetscReal        alpha = mode ? 0.0 : -1.0, beta = mode ? h2 : 1.0;
    std::vector<PetscReal> fref(3 * nv, 0.0);
    PetscReal              eref = 0, fmax = 0;
    for (size_t s = 0; s < a.size(); s++) {
      const Vec3 xi(&x[3 * a[s]]), xj(&x[3 * b[s]]);
      const Vec3 fi = mode ? Vec3(h2 * k[s] * msim::SpringProjection(xi, xj, L[s])) : msim::SpringForce(xi, xj, k[s], L[s]);
      for (int c = 0; c < 3; c++) fref[3 * a[s] + c] += fi[c], fref[3 * b[s] + c] -= fi[c];
      eref += msim::SpringEnergy(xi, xj, k[s], L[s]);
    }
    for (PetscReal v : fref) fmax = std::max(fmax, std::abs(v));
    /* twice: the scratch must be back to zero after a sweep */
    for (int pass = 0; pass < 2; pass++) {
      std::vector<PetscReal> f(3 * nv, 0.0);
      PetscReal              e = 0, eonly = 0, diff = 0;
      MSimSpringSweepSlices(&sl, &w, x.data(), f.data(), NULL, NULL, alpha, beta, &e);
      MSimSpringSweep(sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x.data(), f.data(), alpha, beta, &e);
      MSimSpringSweepSlices(&sl, &w, x.data(), NULL, NULL, NULL, alpha, beta, &eonly);
      MSimSpringSweep(sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x.data(), NULL, alpha, beta, &eonly);
      for (PetscInt i = 0; i < 3 * nv; i++) diff = std::max(diff, std::abs(f[i] - fref[i]));
      NOTE("sweep test (%s, pass %d): max force difference %.2e of %.2e, energy %.15e vs %.15e\n", mode ? "PD projection" : "force", pass, diff, fmax, e, eref);
      CHECK(diff <= 1e-12 * fmax, "sweep (%s): force differs by %g of %g", mode ? "PD projection" : "force", diff, fmax);
      CHECK(std::abs(e - eref) <= 1e-12 * eref && std::abs(eonly - eref) <= 1e-12 * eref, "sweep: energy %g (energy only %g) vs %g", e, eonly, eref);
    }
    {
      /* with a base (the weight m g): the sliced rows are written whole, whatever they held */
      std::vector<PetscReal> f(3 * nv, 0.0), m(3 * nv);
      MSimSweepBase          base = {m.data(), {0.5, -2.0, -9.81}};
      PetscReal              diff = 0, wmax = 0;
      for (PetscInt i = 0; i < 3 * nv; i++) m[i] = 1 + std::abs(u(rng)), f[i] = i < 12 * sl.nslice ? 1e30 : 0.0;
      MSimSpringSweepSlices(&sl, &w, x.data(), f.data(), &base, NULL, alpha, beta, NULL);
      MSimSpringSweep(sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x.data(), f.data(), alpha, beta, NULL);
      for (PetscInt i = 0; i < 3 * nv; i++) {
        const PetscReal wi = i < 12 * sl.nslice ? m[i] * base.a[i % 3] : 0.0;
        diff = std::max(diff, std::abs(f[i] - fref[i] - wi)), wmax = std::max(wmax, std::abs(wi));
      }
      NOTE("sweep test (%s, with the weight as base): max difference %.2e\n", mode ? "PD projection" : "force", diff);
      CHECK(diff <= 1e-12 * (fmax + wmax), "sweep with a base (%s): rows differ by %g", mode ? "PD projection" : "force", diff);
    }
  }
  {
    /* with spring damping: the sliced sweep (shifted and gathered slots, velocities through the
       ring) plus the damped slot sweep over the rest give every vertex SpringForce +
       SpringDampingForce; the slot sweep, given every vertex as owned, reads only xown / vown */
    std::vector<PetscReal> v(3 * nv), fref(3 * nv, 0.0), f(3 * nv, 0.0);
    const PetscReal        kd = 80.0;
    PetscReal              fmax = 0, diff = 0, dmax = 0;
    for (auto &c : v) c = 5 * u(rng);
    for (size_t s = 0; s < a.size(); s++) {
      const Vec3 xi(&x[3 * a[s]]), xj(&x[3 * b[s]]), vi(&v[3 * a[s]]), vj(&v[3 * b[s]]);
      const Vec3 fd = msim::SpringDampingForce(xi, xj, vi, vj, kd), fi = msim::SpringForce(xi, xj, k[s], L[s]) + fd;
      for (int c = 0; c < 3; c++) fref[3 * a[s] + c] += fi[c], fref[3 * b[s] + c] -= fi[c];
      dmax = std::max(dmax, fd.norm());
    }
    for (PetscReal q : fref) fmax = std::max(fmax, std::abs(q));
    MSimSweepDamping damp = {v.data(), kd};
    MSimSpringSweepSlices(&sl, &w, x.data(), f.data(), NULL, &damp, -1.0, 1.0, NULL);
    MSimSpringForceSlotsDamped(0, sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), nv, x.data(), NULL, v.data(), NULL, kd, f.data());
    for (PetscInt i = 0; i < 3 * nv; i++) diff = std::max(diff, std::abs(f[i] - fref[i]));
    NOTE("sweep test (force with damping): max difference %.2e of %.2e (damping forces up to %.2e)\n", diff, fmax, dmax);
    CHECK(dmax > 1e-2 * fmax, "the damping test needs damping forces that matter (%g of %g)", dmax, fmax);
    CHECK(diff <= 1e-12 * fmax, "damped sweep: force differs by %g of %g", diff, fmax);
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
