/* The tets' volume term (msim/volume.h, msim/volume_kernels.hpp):
   - one tet's energy, gradient and Hessian against central finite differences, inside and outside
     the barrier's reach, and the PSD projection (no negative eigenvalue; unchanged where the
     block is PSD already);
   - the first zero of the signed volume along a line against a fine sampling of the cubic;
   - through the implicit problem on a compressed tet box (every tet inside the barrier's reach) at
     any rank count: the Jacobian against finite differences of g, g against finite differences of
     Phi, the PD local step's Phi against the objective, and max_step: no tet inverted at X - alpha Y,
     one flat at alpha / 0.8. */
#include "harness.h"
#include <msim/volume.h>
#include <msim/volume_kernels.hpp>
/* the test checks internals: how many tets the system holds for the term (sys->tets), and counts
   inverted tets at the time the step's unknown sees the boundary (imp->step.tx) */
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <random>

using msim::Mat12;
using msim::Vec12;

static double Energy(const msim::TetMaterial &m, double V0, const Vec12 &x, Vec12 *g, Mat12 *H, bool psd)
{
  const double *p[4] = {x.data(), x.data() + 3, x.data() + 6, x.data() + 9};
  return msim::TetEnergy(m, V0, p, g, H, psd);
}

static PetscErrorCode TestKernels(void)
{
  std::mt19937                           gen(7);
  std::uniform_real_distribution<double> u(-1, 1);
  PetscFunctionBeginUser;
  /* trials 6..11: the barrier alone (kv 0), inside its reach only (zero beyond) */
  for (int trial = 0; trial < 12; trial++) {
    const msim::TetMaterial m = {trial < 6 ? 3.0 : 0.0, 2.0, 0.6};
    if (trial >= 6 && trial % 2) continue;
    /* a rest tet, then a deformed one with J in (0, jhat) for even trials (the barrier acts) */
    Vec12 X0, x;
    X0 << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    for (int k = 0; k < 12; k++) X0(k) += 0.1 * u(gen);
    if (trial % 3 == 2) { /* the other orientation: V0 < 0 */
      const Eigen::Vector3d t = X0.segment<3>(3);
      X0.segment<3>(3)        = X0.segment<3>(6);
      X0.segment<3>(6)        = t;
    }
    const double *p0[4] = {X0.data(), X0.data() + 3, X0.data() + 6, X0.data() + 9};
    const double  V0    = msim::TetSignedVolume(p0[0], p0[1], p0[2], p0[3]);
    const double  s     = trial % 2 == 0 ? 0.7 : 1.1; /* scale of the tet: J = s^3 */
    for (int k = 0; k < 12; k++) x(k) = s * X0(k) + 0.03 * u(gen);
    const double *p[4] = {x.data(), x.data() + 3, x.data() + 6, x.data() + 9};
    const double  J    = msim::TetSignedVolume(p[0], p[1], p[2], p[3]) / V0;
    Vec12         g, gfd, gp, gm;
    Mat12         H, Hfd, Hp;
    const double  eps = 1e-6;
    Energy(m, V0, x, &g, &H, false);
    for (int k = 0; k < 12; k++) {
      Vec12 xp = x, xm = x;
      xp(k) += eps;
      xm(k) -= eps;
      gfd(k) = (Energy(m, V0, xp, &gp, NULL, false) - Energy(m, V0, xm, &gm, NULL, false)) / (2 * eps);
      Hfd.col(k) = (gp - gm) / (2 * eps);
    }
    const double eg = (g - gfd).norm() / g.norm(), eH = (H - Hfd).norm() / H.norm();
    NOTE("tet %d: J %.3f, V0 %+.3f: gradient vs FD %.1e, Hessian vs FD %.1e\n", trial, J, V0, eg, eH);
    CHECK(eg < 1e-7, "tet %d: gradient off by %g relative", trial, eg);
    CHECK(eH < 1e-6, "tet %d: Hessian off by %g relative", trial, eH);
    CHECK((H - H.transpose()).norm() <= 1e-14 * H.norm(), "tet %d: Hessian not symmetric", trial);
    /* the projection: PSD, and the identity on a PSD block */
    Energy(m, V0, x, NULL, &Hp, true);
    Eigen::SelfAdjointEigenSolver<Mat12> es(H), ep(Hp);
    const double                         lmin = es.eigenvalues().minCoeff(), pmin = ep.eigenvalues().minCoeff();
    NOTE("        least eigenvalue %.2e, projected %.2e\n", lmin, pmin);
    CHECK(pmin >= -1e-12 * H.norm(), "tet %d: projected Hessian has eigenvalue %g", trial, pmin);
    if (lmin >= 0) CHECK((Hp - H).norm() <= 1e-12 * H.norm(), "tet %d: projection changed a PSD block", trial);
    /* the translations are in its null space: sum of the gradient's blocks is zero */
    CHECK((g.segment<3>(0) + g.segment<3>(3) + g.segment<3>(6) + g.segment<3>(9)).norm() <= 1e-12 * g.norm(), "tet %d: gradient not translation invariant", trial);
  }
  /* the first zero along x - a y against sampling */
  for (int trial = 0; trial < 200; trial++) {
    Vec12 x, y;
    x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    for (int k = 0; k < 12; k++) {
      x(k) += 0.2 * u(gen);
      y(k) = u(gen);
    }
    const double *p[4] = {x.data(), x.data() + 3, x.data() + 6, x.data() + 9}, *q[4] = {y.data(), y.data() + 3, y.data() + 6, y.data() + 9};
    const double  V0 = msim::TetSignedVolume(p[0], p[1], p[2], p[3]), amax = 3.0;
    const double  a  = msim::TetFirstZero(V0, p, q, amax);
    /* sampled: the first sample whose volume has left V0's sign */
    double first = amax;
    for (int k = 1; k <= 30000; k++) {
      const double t = amax * k / 30000;
      Vec12        z = x - t * y;
      if (msim::TetSignedVolume(z.data(), z.data() + 3, z.data() + 6, z.data() + 9) / V0 <= 0) {
        first = t;
        break;
      }
    }
    const bool ok = first == amax ? a == amax || a > amax - 2 * amax / 30000 : a <= first && a >= first - amax / 30000;
    if (!ok) NOTE("line %d: first zero %.9f, sampled %.9f\n", trial, a, first);
    CHECK(ok, "line %d: first zero %g, sampled %g", trial, a, first);
  }
  /* the safe radius (max_step's skip): every vertex moved by just under r, in random directions
     and in the worst one for the volume (against dV/dx_q, the motion that shrinks it fastest),
     leaves J above jhat; and r is not vacuous (a rest-like tet gets r > 1% of its edges) */
  for (int trial = 0; trial < 400; trial++) {
    Vec12 x, g;
    x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    for (int k = 0; k < 12; k++) x(k) += (trial < 200 ? 0.1 : 0.45) * u(gen);
    const double *p[4] = {x.data(), x.data() + 3, x.data() + 6, x.data() + 9};
    const double  V0 = 1.0 / 6.0 * (trial % 2 ? 1 : -1), jhat = 0.2; /* J = V/V0 of either sign */
    const double  V  = msim::TetVolumeGradient(p, g);
    if (!(V / V0 > 0)) continue;
    const double gap = msim::TetSafeGap(V0, p, jhat), L = msim::TetEdgeSquares(p);
    /* the largest r^2 the test accepts, by bisection on the test itself */
    double lo = 0, hi = L;
    for (int it = 0; it < 200; it++) {
      const double mid = 0.5 * (lo + hi);
      (msim::TetWithinSafeRadius(mid, gap, L) ? lo : hi) = mid;
    }
    const double r = std::sqrt(lo) * (1 - 1e-12);
    if (trial < 200 && V / V0 > 0.5) CHECK(r > 0.01 * std::sqrt(L / 3), "tet %d: J %.2f, safe radius %g of edges %g: vacuous", trial, V / V0, r, std::sqrt(L / 3));
    if (V / V0 <= jhat) CHECK(lo == 0, "tet %d: J %.3f <= jhat has a safe radius %g", trial, V / V0, r);
    for (int dir = 0; dir < 20 && lo > 0; dir++) {
      Vec12 z = x;
      for (int q = 0; q < 4; q++) {
        Eigen::Vector3d d;
        if (dir == 0) d = -(V0 > 0 ? 1 : -1) * g.segment<3>(3 * q); /* shrinks |V| fastest */
        else d << u(gen), u(gen), u(gen);
        if (d.norm() > 0) z.segment<3>(3 * q) += r * d / d.norm();
      }
      const double Jz = msim::TetSignedVolume(z.data(), z.data() + 3, z.data() + 6, z.data() + 9) / V0;
      if (!(Jz > jhat)) NOTE("tet %d dir %d: J %.6f -> %.6f within the safe radius %g\n", trial, dir, V / V0, Jz, r);
      CHECK(Jz > jhat, "tet %d: a motion within the safe radius %g brings J %g to %g <= jhat", trial, r, V / V0, Jz);
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestProblem(void)
{
  TestSim      s;
  MSimImplicit imp;
  Mat          J;
  Vec          dX, Y, Z;
  PetscReal    eps = 1e-7, err, nrm, alpha;
  PetscInt     bad;

  PetscFunctionBeginUser;
  /* compressed to J = 0.8^3 = 0.51 with jhat 0.7: every tet is inside the barrier's reach */
  PetscCall(TestSimCreate("-msim_scene box -msim_box_n 4,2,2 -msim_box_size 0.4,0.2,0.2 -msim_young 1e5 -msim_density 1000 -msim_fix_plane x_min -msim_prestretch 0.8 -msim_perturb 0.004 -msim_volume -msim_volume_jhat 0.7 -msim_volume_stiffness 2e4 -msim_integrator implicit_euler", &s));
  CHECK(s.sys->tets.ntet == 4 * 2 * 2 * 6, "the box's tets: %d in the term, %d expected", (int)s.sys->tets.ntet, 4 * 2 * 2 * 6);
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  PetscCall(MSimImplicitSetPSD(imp, PETSC_FALSE));
  PetscCall(VecSet(s.V, 0.3));
  PetscCall(MSimImplicitBeginStep(imp, 0.0, 0.01, s.X, s.V));
  PetscCall(MSimSystemCreateMatrix(s.sys, &J));
  PetscCall(MSimImplicitJacobian(imp, s.X, J));
  PetscCall(VecDuplicate(s.X, &dX));
  PetscCall(VecDuplicate(s.X, &Y));
  PetscCall(VecDuplicate(s.X, &Z));
  {
    PetscRandom r;
    PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &r));
    PetscCall(PetscRandomSetInterval(r, -1e-3, 1e-3));
    PetscCall(VecSetRandom(dX, r));
    PetscCall(PetscRandomSetInterval(r, -0.05, 0.05));
    PetscCall(VecSetRandom(Y, r));
    PetscCall(PetscRandomDestroy(&r));
  }
  PetscCall(JacobianFDError(imp, J, s.X, dX, eps, &err, &nrm));
  NOTE("box in the barrier: Jacobian vs finite differences of g: relative error %.2e\n", (double)(err / nrm));
  CHECK(err <= 1e-6 * nrm, "Jacobian off by %g relative", (double)(err / nrm));
  {
    /* the volume term's own part of the Jacobian: J - J(springs alone) must be nonzero, so the
       check above tests it */
    MSimImplicit springs;
    Mat          Js;
    PetscReal    dn;
    PetscCall(PetscOptionsSetValue(NULL, "-msim_implicit_terms", "springs"));
    PetscCall(MSimImplicitCreate(s.sys, &springs));
    PetscCall(PetscOptionsClearValue(NULL, "-msim_implicit_terms"));
    springs->psd = PETSC_FALSE;
    PetscCall(MSimImplicitBeginStep(springs, 0.0, 0.01, s.X, s.V));
    PetscCall(MSimSystemCreateMatrix(s.sys, &Js));
    PetscCall(MSimImplicitJacobian(springs, s.X, Js));
    PetscCall(MatAXPY(Js, -1.0, J, SUBSET_NONZERO_PATTERN));
    PetscCall(MatNorm(Js, NORM_FROBENIUS, &dn));
    PetscCall(MatNorm(J, NORM_FROBENIUS, &nrm));
    NOTE("the volume term's share of the Jacobian: %.2e relative\n", (double)(dn / nrm));
    CHECK(dn > 1e-3 * nrm, "the volume term adds nothing to the Jacobian (%g relative)", (double)(dn / nrm));
    PetscCall(MSimDestroy(&Js, &springs));
  }
  {
    /* a longer difference than g's: Phi's roundoff (1e-16 Phi) over 2 e (g . d) must stay small */
    PetscReal gd, fd;
    PetscCall(ObjectiveFDError(imp, s.X, dX, 1e-4, &gd, &fd));
    NOTE("g . d %.10e vs dPhi/de %.10e\n", (double)gd, (double)fd);
    CHECK(std::abs(gd - fd) <= 1e-6 * std::abs(gd), "g is not the gradient of Phi");
  }
  {
    PetscReal phi_obj, phi_pd;
    Vec       rhs;
    PetscCall(VecDuplicate(s.X, &rhs));
    PetscCall(MSimImplicitObjective(imp, s.X, &phi_obj));
    PetscCall(VecZeroEntries(rhs));
    PetscCall(MSimImplicitPDRHS(imp, s.X, rhs, &phi_pd));
    NOTE("Phi from the objective %.15e, from the PD local step %.15e\n", (double)phi_obj, (double)phi_pd);
    CHECK(std::abs(phi_obj - phi_pd) <= 1e-12 * std::abs(phi_obj), "PD local step's Phi %g differs from the objective %g", (double)phi_pd, (double)phi_obj);
    PetscCall(VecDestroy(&rhs));
  }
  /* max_step along a long random direction */
  PetscCall(VecScale(Y, 20.0));
  PetscCall(MSimImplicitMaxStep(imp, s.X, Y, &alpha));
  PetscCall(VecWAXPY(Z, -alpha, Y, s.X));
  PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
  NOTE("max_step %.6f: %d tets inverted there\n", (double)alpha, (int)bad);
  CHECK(alpha < 1 && bad == 0, "max_step %g leaves %d tets inverted (or the direction tests nothing)", (double)alpha, (int)bad);
  PetscCall(VecWAXPY(Z, -alpha / 0.8 * (1 + 1e-9), Y, s.X));
  PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
  CHECK(bad >= 1, "at max_step / 0.8 no tet is flat: the step is not the largest");
  PetscCall(VecWAXPY(Z, -alpha / 0.8 * (1 - 1e-6), Y, s.X));
  PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
  CHECK(bad == 0, "just short of max_step / 0.8, %d tets inverted", (int)bad);
  PetscCall(MSimDestroy(&dX, &Y, &Z, &J, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* max_step's skip at any rank count: a box at rest (J ~ 1, every tet outside the barrier's
   reach), a gradient pass at X (the reference and safe radii), then a direction that moves one
   vertex far (its tets must flatten: found by the cubic) and the others by tiny amounts (their
   tets skipped). Expected: the step that flattens the first tet, found here independently by
   bisection on the count of inverted tets; max_step must give 0.8 of it. */
static PetscErrorCode TestSkip(void)
{
  TestSim      s;
  MSimImplicit imp;
  Vec          G, Y, Z;
  PetscReal    alpha = 1, lo = 0, hi = 1;
  PetscInt     bad, skipped = 0, total = 0, nown, n;
  PetscMPIInt  rank;

  PetscFunctionBeginUser;
  PetscCall(TestSimCreate("-msim_scene box -msim_box_n 4,3,3 -msim_box_size 0.4,0.3,0.3 -msim_young 1e5 -msim_density 1000 -msim_fix_plane x_min -msim_perturb 0.002 -msim_volume -msim_integrator implicit_euler", &s));
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  PetscCall(MSimImplicitBeginStep(imp, 0.0, 0.01, s.X, s.V));
  PetscCall(VecDuplicate(s.X, &G));
  PetscCall(VecDuplicate(s.X, &Y));
  PetscCall(VecDuplicate(s.X, &Z));
  PetscCall(VecZeroEntries(G));
  PetscCall(MSimImplicitResidual(imp, s.X, G)); /* the gradient pass takes the reference */
  {
    PetscRandom r;
    PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &r));
    PetscCall(PetscRandomSetInterval(r, -1e-6, 1e-6));
    PetscCall(VecSetRandom(Y, r));
    PetscCall(PetscRandomDestroy(&r));
  }
  /* the free vertex nearest the box's centre (0.2, 0.15, 0.15), moved 0.2 m along (1, 0.5, 0.3):
     two edge lengths, so some of its tets flatten within the step */
  {
    const PetscScalar *x;
    PetscInt           lo_, best = -1;
    PetscReal          d = PETSC_MAX_REAL, dmin;
    PetscInt           pick;
    PetscCall(VecGetOwnershipRange(s.X, &lo_, NULL));
    PetscCall(VecGetLocalSize(s.X, &nown));
    PetscCall(VecGetArrayRead(s.X, &x));
    for (PetscInt v = 0; v < nown / 3; v++) {
      const PetscReal dd = PetscSqr(x[3 * v] - 0.2) + PetscSqr(x[3 * v + 1] - 0.15) + PetscSqr(x[3 * v + 2] - 0.15);
      if (dd < d) {
        d    = dd;
        best = lo_ + 3 * v;
      }
    }
    PetscCall(VecRestoreArrayRead(s.X, &x));
    PetscCallMPI(MPI_Allreduce(&d, &dmin, 1, MPIU_REAL, MPIU_MIN, PETSC_COMM_WORLD));
    pick = d == dmin ? best : PETSC_MAX_INT;
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &pick, 1, MPIU_INT, MPI_MIN, PETSC_COMM_WORLD));
    if (pick >= lo_ && pick < lo_ + nown) {
      const PetscInt    idx[3] = {pick, pick + 1, pick + 2};
      const PetscScalar val[3] = {0.2, 0.1, 0.06};
      PetscCall(VecSetValues(Y, 3, idx, val, INSERT_VALUES));
    }
    PetscCall(VecAssemblyBegin(Y));
    PetscCall(VecAssemblyEnd(Y));
  }
  /* expected: the first alpha at which a tet is flat, by bisection on the inverted count */
  PetscCall(VecWAXPY(Z, -1.0, Y, s.X));
  PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
  CHECK(bad > 0, "the vertex's move inverts nothing at alpha 1: the test tests nothing");
  for (int it = 0; it < 60; it++) {
    const PetscReal mid = 0.5 * (lo + hi);
    PetscCall(VecWAXPY(Z, -mid, Y, s.X));
    PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
    (bad ? hi : lo) = mid;
  }
  PetscCall(MSimImplicitMaxStep(imp, s.X, Y, &alpha));
  /* the skip was in play: most tets within their safe radius (m2 from this max_step) */
  {
    const MSimTets &T = s.sys->tets;
    CHECK(T.gl.size() == 2 * T.V0.size(), "no reference after the gradient pass");
    for (size_t c = 0; c < T.V0.size() && T.gl.size() == 2 * T.V0.size(); c++) {
      const PetscInt *q = &T.slot[4 * c];
      skipped += msim::TetWithinSafeRadius(std::max(std::max(T.m2[q[0]], T.m2[q[1]]), std::max(T.m2[q[2]], T.m2[q[3]])), T.gl[2 * c], T.gl[2 * c + 1]);
    }
    total = (PetscInt)T.V0.size();
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &skipped, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
  }
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  n = s.sys->tets.ntet;
  NOTE("skip: %d of %d tets skipped; max_step %.12f, 0.8 x the first flat tet's step %.12f\n", (int)skipped, (int)n, (double)alpha, (double)(0.8 * lo));
  CHECK(total == n, "the ranks hold %d tets, the term %d", (int)total, (int)n);
  CHECK(skipped > n / 2 && skipped < n, "%d of %d tets skipped: the skip is not tested", (int)skipped, (int)n);
  CHECK(PetscAbsReal(alpha - 0.8 * lo) <= 1e-9, "max_step %.12g, expected 0.8 x %.12g", (double)alpha, (double)lo);
  PetscCall(MSimDestroy(&G, &Y, &Z, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The barrier alone (-msim_volume_stiffness 0) on a perturbed box where some tets are inside the
   barrier's reach (jhat 0.9 against a perturbation of 0.012 m on 0.1 m edges) and most are not,
   at any rank count:
   - a gradient pass takes the reference; then at X + dX, random dX from well within the safe
     radii to beyond them, the passes that skip the tets the reference proves above jhat (energy
     alone, energy and gradient, Hessian) give what the passes over every tet give (T.noskip) to
     roundoff: the skipped tets are zero there;
   - through the implicit problem, its passes skipping: the Jacobian against finite differences of
     g, and g against finite differences of Phi;
   - max_step along a long random direction: no tet inverted at X - alpha Y, one flat at
     alpha / 0.8. */
static PetscErrorCode TestBarrierAlone(void)
{
  TestSim      s;
  MSimImplicit imp;
  Mat          H, Hn;
  Vec          G, Gn, Xs, dX, Y, Z;
  PetscInt     below = 0, n, bad, skipped_any = 0;
  PetscReal    alpha, err, nrm;

  PetscFunctionBeginUser;
  PetscCall(TestSimCreate("-msim_scene box -msim_box_n 4,3,3 -msim_box_size 0.4,0.3,0.3 -msim_young 1e5 -msim_density 1000 -msim_fix_plane x_min -msim_perturb 0.012 -msim_volume -msim_volume_stiffness 0 -msim_volume_jhat 0.9 -msim_integrator implicit_euler", &s));
  MSimTets &T = s.sys->tets;
  n           = T.ntet;
  /* kappa's default with kv 0: a tenth of the springs' modulus (1e5 Pa here), not kv */
  CHECK(T.kv == 0 && PetscAbsReal(T.kappa - 1e4) <= 1e-6 * 1e4, "barrier alone: kv %g, kappa %g (expected 0 and 1e4 Pa)", (double)T.kv, (double)T.kappa);
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  PetscCall(MSimImplicitSetPSD(imp, PETSC_FALSE));
  PetscCall(VecSet(s.V, 0.1));
  PetscCall(MSimImplicitBeginStep(imp, 0.0, 0.01, s.X, s.V));
  PetscCall(VecDuplicate(s.X, &G));
  PetscCall(VecDuplicate(s.X, &Gn));
  PetscCall(VecDuplicate(s.X, &Xs));
  PetscCall(VecDuplicate(s.X, &dX));
  PetscCall(VecDuplicate(s.X, &Y));
  PetscCall(VecDuplicate(s.X, &Z));
  PetscCall(MSimSystemCreateMatrix(s.sys, &H));
  PetscCall(MSimSystemCreateMatrix(s.sys, &Hn));
  T.refresh = true;
  PetscCall(MSimImplicitResidual(imp, s.X, G)); /* the gradient pass takes the reference */
  CHECK(T.gl.size() == 2 * T.V0.size() && T.r2slot.size() == (size_t)s.sys->nloc, "no reference after the gradient pass");
  for (size_t c = 0; c < T.V0.size() && T.gl.size() == 2 * T.V0.size(); c++) below += T.gl[2 * c] <= 0;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &below, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
  NOTE("barrier alone: %d of %d tets below jhat at X\n", (int)below, (int)n);
  CHECK(below > 0 && below < n / 2, "%d of %d tets below jhat: the mix the skip needs is missing", (int)below, (int)n);
  for (int k = 0; k < 5; k++) {
    const PetscReal amp = std::pow(10.0, -6.0 + k); /* 1e-6 .. 1e-2 m */
    PetscReal       e_skip = 0, e_all = 0, e_only = 0, dg, gn, dh, hn, r[3];
    PetscInt        computed;
    PetscCall(SetRandom(dX, -amp, amp));
    PetscCall(VecWAXPY(Xs, 1.0, dX, s.X));
    /* skipping passes (the reference kept: refresh off) */
    T.noskip  = false;
    T.refresh = false;
    PetscCall(VecZeroEntries(G));
    PetscCall(MSimSystemVolumeGradient(s.sys, imp->step.tx, Xs, 1.0, G, &e_skip, PETSC_FALSE));
    computed  = (PetscInt)T.active.size();
    T.refresh = false;
    PetscCall(MSimSystemVolumeGradient(s.sys, imp->step.tx, Xs, 0.0, NULL, &e_only, PETSC_FALSE));
    PetscCall(MatZeroEntries(H));
    PetscCall(MSimSystemVolumeHessian(s.sys, imp->step.tx, Xs, 1.0, PETSC_FALSE, H));
    /* every tet */
    T.noskip  = true;
    T.refresh = false;
    PetscCall(VecZeroEntries(Gn));
    PetscCall(MSimSystemVolumeGradient(s.sys, imp->step.tx, Xs, 1.0, Gn, &e_all, PETSC_FALSE));
    PetscCall(MatZeroEntries(Hn));
    PetscCall(MSimSystemVolumeHessian(s.sys, imp->step.tx, Xs, 1.0, PETSC_FALSE, Hn));
    T.noskip = false;
    r[0]     = e_skip;
    r[1]     = e_only;
    r[2]     = e_all;
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, r, 3, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &computed, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    PetscCall(VecNorm(Gn, NORM_2, &gn));
    PetscCall(VecAXPY(G, -1.0, Gn));
    PetscCall(VecNorm(G, NORM_2, &dg));
    PetscCall(MatNorm(Hn, NORM_FROBENIUS, &hn));
    PetscCall(MatAXPY(Hn, -1.0, H, UNKNOWN_NONZERO_PATTERN));
    PetscCall(MatNorm(Hn, NORM_FROBENIUS, &dh));
    NOTE("  |dX| <= %.0e m: %d of %d tets computed; energy %.15e (skipping) %.15e (energy alone) %.15e (every tet); gradient differs by %.1e, Hessian by %.1e relative\n", (double)amp, (int)computed, (int)n, (double)r[0], (double)r[1], (double)r[2], (double)(dg / gn), (double)(dh / hn));
    if (computed < n) skipped_any++;
    CHECK(r[2] > 0 && PetscAbsReal(r[0] - r[2]) <= 1e-14 * r[2] && PetscAbsReal(r[1] - r[2]) <= 1e-14 * r[2], "|dX| <= %g: energies %.17g, %.17g skipping, %.17g over every tet", (double)amp, (double)r[0], (double)r[1], (double)r[2]);
    CHECK(gn > 0 && dg <= 1e-14 * gn, "|dX| <= %g: the skipping gradient differs by %g relative", (double)amp, (double)(dg / gn));
    CHECK(hn > 0 && dh <= 1e-14 * hn, "|dX| <= %g: the skipping Hessian differs by %g relative", (double)amp, (double)(dh / hn));
    CHECK(computed >= below, "|dX| <= %g: %d tets computed, fewer than the %d below jhat", (double)amp, (int)computed, (int)below);
  }
  CHECK(skipped_any >= 3, "the skip left out tets at only %d of 5 sizes: not tested", (int)skipped_any);
  /* finite differences through the problem, whose passes skip (from the reference at X) */
  {
    Mat J;
    PetscCall(MSimSystemCreateMatrix(s.sys, &J));
    T.refresh = true;
    PetscCall(MSimImplicitResidual(imp, s.X, G)); /* a fresh reference at X */
    PetscCall(MSimImplicitJacobian(imp, s.X, J));
    PetscCall(SetRandom(dX, -1e-3, 1e-3));
    PetscCall(JacobianFDError(imp, J, s.X, dX, 1e-7, &err, &nrm));
    NOTE("barrier alone: Jacobian vs finite differences of g: relative error %.2e (%d tets computed in the last pass)\n", (double)(err / nrm), (int)T.active.size());
    CHECK(err <= 1e-6 * nrm, "barrier alone: Jacobian off by %g relative", (double)(err / nrm));
    PetscReal gd, fd;
    PetscCall(ObjectiveFDError(imp, s.X, dX, 1e-4, &gd, &fd));
    NOTE("barrier alone: g . d %.10e vs dPhi/de %.10e\n", (double)gd, (double)fd);
    CHECK(std::abs(gd - fd) <= 1e-6 * std::abs(gd), "barrier alone: g is not the gradient of Phi");
    PetscCall(MatDestroy(&J));
  }
  /* max_step is the full term's (the skip changes nothing there) */
  PetscCall(SetRandom(Y, -1.0, 1.0));
  alpha = 1;
  PetscCall(MSimImplicitMaxStep(imp, s.X, Y, &alpha));
  PetscCall(VecWAXPY(Z, -alpha, Y, s.X));
  PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
  NOTE("barrier alone: max_step %.6f, %d tets inverted there\n", (double)alpha, (int)bad);
  CHECK(alpha < 1 && bad == 0, "barrier alone: max_step %g leaves %d tets inverted (or the direction tests nothing)", (double)alpha, (int)bad);
  PetscCall(VecWAXPY(Z, -alpha / 0.8 * (1 + 1e-9), Y, s.X));
  PetscCall(MSimSystemVolumeCountInverted(s.sys, imp->step.tx, Z, &bad));
  CHECK(bad >= 1, "barrier alone: at max_step / 0.8 no tet is flat");
  PetscCall(MSimDestroy(&G, &Gn, &Xs, &dX, &Y, &Z, &H, &Hn, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestVolume(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestKernels());
  PetscCall(TestProblem());
  PetscCall(TestSkip());
  PetscCall(TestBarrierAlone());
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestVolume)
