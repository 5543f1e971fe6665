/* The self-friction term (src/implicit/terms/self_friction.cpp) on its own, at any rank count:
   - its gradient against central differences of its energy, and its Hessian against central
     differences of its gradient, both in the static (slip below eps = eps_v h) and the sliding
     regime, with moving handles (a fixed vertex's slip is v_fix h);
   - its Hessian is PSD (x^T H x >= 0 in random directions) and symmetric;
   - what the lag makes exact: at x = x_n every slip is 0, so the gradient is 0 and the energy is
     sum_pairs mu lambda eps / 3 > 0 (f0(0) = eps/3); a rigid translation of every vertex (also the
     handles' slip, so only with the handles at rest) leaves every pair's relative slip 0 (the
     weights of a pair sum to 0), so the energy does not change; friction opposes the slip
     (g . (x - x_n) > 0).
   Includes msim/private/implicitimpl.h to call the one term's ops (the problem's Jacobian also
   holds the self-contact barrier's, whose Hessian freezes the closest points and so is not the
   derivative of its gradient). The pairs: a 6 x 6 cloth with the contact distance 0.9 of its edge,
   so that its flat, perturbed rest state already has vertex-disjoint pairs within dhat. */
#include "harness.h"
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

static PetscErrorCode FindTerm(MSimImplicit imp, const char name[], MSimImplicitTerm *term)
{
  PetscFunctionBeginUser;
  *term = NULL;
  for (PetscInt k = 0; k < imp->nterms; k++) {
    PetscBool same;
    PetscCall(PetscStrcmp(imp->terms[k]->type, name, &same));
    if (same) *term = imp->terms[k];
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Energy(MSimImplicitTerm t, Vec X, PetscReal *e)
{
  PetscFunctionBeginUser;
  *e = 0;
  PetscCall(t->ops.energy(t, X, e));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Gradient(MSimImplicitTerm t, Vec X, Vec G)
{
  PetscFunctionBeginUser;
  PetscCall(VecZeroEntries(G));
  PetscCall(t->ops.gradient(t, X, G));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Hessian(MSimImplicitTerm t, Vec X, Mat J)
{
  PetscFunctionBeginUser;
  PetscCall(MatZeroEntries(J));
  PetscCall(t->ops.hessian(t, X, PETSC_TRUE, J));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the term's derivatives at X = Xn + a R against central differences along D */
static PetscErrorCode CheckDerivatives(TestSim *s, MSimImplicitTerm t, Vec Xn, Vec R, Vec D, PetscReal a, const char *regime)
{
  Vec       X, Xp, G, Gp, Gm, HD;
  Mat       J;
  PetscReal ep, em, gd, fd = 1e-4 * a, fh = PetscMax(1e-6 * a, 1e-10), err, nrm, dHd, asym;

  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(Xn, &X));
  PetscCall(VecDuplicate(Xn, &Xp));
  PetscCall(VecDuplicate(Xn, &G));
  PetscCall(VecDuplicate(Xn, &Gp));
  PetscCall(VecDuplicate(Xn, &Gm));
  PetscCall(VecDuplicate(Xn, &HD));
  PetscCall(VecWAXPY(X, a, R, Xn));
  PetscCall(Gradient(t, X, G));
  {
    Vec S;
    PetscCall(VecDuplicate(Xn, &S));
    PetscCall(VecWAXPY(S, -1.0, Xn, X));
    PetscCall(VecDot(G, S, &gd));
    CHECK(gd > 0, "%s: friction does not oppose the slip (g . (x - x_n) = %g)", regime, (double)gd);
    PetscCall(VecDestroy(&S));
  }
  /* gradient vs energy: D scaled to the slip so the central difference stays in one regime */
  PetscCall(VecWAXPY(Xp, fd, D, X));
  PetscCall(Energy(t, Xp, &ep));
  PetscCall(VecWAXPY(Xp, -fd, D, X));
  PetscCall(Energy(t, Xp, &em));
  /* the Hessian's differences: a smaller step (the gradient has no large constant to lose digits
     to, and its third derivative grows like 1/y^2 for a pair slipping y), but not below 1e-10 m,
     where the positions (~1 m) keep too few digits of the difference */
  PetscCall(VecWAXPY(Xp, fh, D, X));
  PetscCall(Gradient(t, Xp, Gp));
  PetscCall(VecWAXPY(Xp, -fh, D, X));
  PetscCall(Gradient(t, Xp, Gm));
  PetscCall(VecDot(G, D, &gd));
  NOTE("%s regime: g . d %.6e, (E(x + h d) - E(x - h d)) / 2h %.6e\n", regime, (double)gd, (double)((ep - em) / (2 * fd)));
  CHECK(PetscAbsReal(gd - (ep - em) / (2 * fd)) <= 1e-5 * PetscAbsReal(gd) && gd != 0, "%s: gradient vs energy's differences: %g vs %g", regime, (double)gd, (double)((ep - em) / (2 * fd)));
  PetscCall(MSimSystemCreateMatrix(s->sys, &J));
  PetscCall(Hessian(t, X, J));
  PetscCall(MatMult(J, D, HD));
  PetscCall(VecAXPY(Gp, -1.0, Gm));
  PetscCall(VecScale(Gp, 1.0 / (2 * fh)));
  PetscCall(VecNorm(HD, NORM_2, &nrm));
  PetscCall(VecAXPY(Gp, -1.0, HD));
  PetscCall(VecNorm(Gp, NORM_2, &err));
  NOTE("%s regime: Hessian vs differences of the gradient: relative error %.2e (|H d| %.3e)\n", regime, (double)(err / nrm), (double)nrm);
  CHECK(nrm > 0 && err <= 1e-5 * nrm, "%s: Hessian off by %g relative", regime, (double)(err / nrm));
  /* PSD and symmetric */
  {
    PetscRandom r;
    Mat         Jt;
    PetscReal   jn, worst = PETSC_MAX_REAL;
    PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &r));
    PetscCall(PetscRandomSetInterval(r, -1, 1));
    PetscCall(MatNorm(J, NORM_FROBENIUS, &jn));
    for (int k = 0; k < 20; k++) {
      PetscReal dd;
      PetscCall(VecSetRandom(HD, r));
      PetscCall(MatMult(J, HD, Gm));
      PetscCall(VecDot(HD, Gm, &dHd));
      PetscCall(VecDot(HD, HD, &dd));
      worst = PetscMin(worst, dHd / (jn * dd));
    }
    NOTE("%s regime: min over 20 random x of x^T H x / (|H|_F |x|^2) = %.3e\n", regime, (double)worst);
    CHECK(worst >= -1e-12, "%s: Hessian not PSD: x^T H x / (|H| |x|^2) = %g", regime, (double)worst);
    PetscCall(MatTranspose(J, MAT_INITIAL_MATRIX, &Jt));
    PetscCall(MatAXPY(Jt, -1.0, J, DIFFERENT_NONZERO_PATTERN));
    PetscCall(MatNorm(Jt, NORM_FROBENIUS, &asym));
    CHECK(asym <= 1e-12 * jn, "%s: Hessian not symmetric: %g relative", regime, (double)(asym / jn));
    PetscCall(MatDestroy(&Jt));
    PetscCall(PetscRandomDestroy(&r));
  }
  PetscCall(MSimDestroy(&J, &HD, &Gm, &Gp, &G, &Xp, &X));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Run(const char *opts, PetscBool handles_move)
{
  TestSim          s;
  MSimImplicit     imp;
  MSimImplicitTerm t, self;
  Vec              R, D, G, T;
  PetscReal        h = 0.01, e0, e1, gn, eps, mu = 0.4;

  PetscFunctionBeginUser;
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  PetscCall(FindTerm(imp, "self_friction", &t));
  PetscCall(FindTerm(imp, "self_contact", &self));
  CHECK(t && t->ops.energy && self && self->ops.energy, "self_friction is not active with -msim_self_contact -msim_friction %g", (double)mu);
  if (!(t && t->ops.energy)) {
    PetscCall(MSimDestroy(&imp, &s));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MSimImplicitBeginStep(imp, 0.0, h, s.X, s.V));
  eps = 1e-3 * s.sys->diameter * h; /* -msim_friction_eps's default times h */
  PetscCall(VecDuplicate(s.X, &R));
  PetscCall(VecDuplicate(s.X, &D));
  PetscCall(VecDuplicate(s.X, &G));
  PetscCall(VecDuplicate(s.X, &T));
  {
    PetscRandom r;
    PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &r));
    PetscCall(PetscRandomSetInterval(r, -1, 1));
    PetscCall(VecSetRandom(R, r));
    PetscCall(VecSetRandom(D, r));
    PetscCall(PetscRandomDestroy(&r));
  }
  {
    PetscReal rn;
    PetscCall(VecNorm(R, NORM_INFINITY, &rn));
    PetscCall(VecScale(R, 1.0 / rn)); /* |R|_inf = 1 */
    PetscCall(VecNorm(D, NORM_INFINITY, &rn));
    PetscCall(VecScale(D, 1.0 / rn));
  }
  /* at x_n: every slip 0 (the handles' too only when they rest) */
  PetscCall(Energy(t, s.X, &e0));
  PetscCall(Gradient(t, s.X, G));
  PetscCall(VecNorm(G, NORM_2, &gn));
  NOTE("%s handles: energy at x_n %.6e, |g| %.3e (eps %.3e m)\n", handles_move ? "moving" : "resting", (double)e0, (double)gn, (double)eps);
  CHECK(e0 > 0, "no pair in self-contact at x_n (energy %g)", (double)e0);
  if (!handles_move) {
    CHECK(gn == 0, "gradient at x_n not 0: %g", (double)gn);
    /* a rigid translation: every pair's relative slip stays 0 */
    {
      /* every vertex shifted by (0.37, -1.3, 2.1) eps */
      PetscScalar *ta;
      PetscInt     n;
      PetscCall(VecGetLocalSize(T, &n));
      PetscCall(VecGetArray(T, &ta));
      for (PetscInt k = 0; k < n; k += 3) ta[k] = 0.37 * eps, ta[k + 1] = -1.3 * eps, ta[k + 2] = 2.1 * eps;
      PetscCall(VecRestoreArray(T, &ta));
    }
    PetscCall(VecAXPY(T, 1.0, s.X));
    PetscCall(Energy(t, T, &e1));
    NOTE("rigid translation by 2.5 eps: energy %.10e vs %.10e at x_n\n", (double)e1, (double)e0);
    CHECK(PetscAbsReal(e1 - e0) <= 1e-10 * e0, "a rigid translation changed the friction energy: %g vs %g", (double)e1, (double)e0);
  }
  PetscCall(CheckDerivatives(&s, t, s.X, R, D, 0.1 * eps, "static"));
  PetscCall(CheckDerivatives(&s, t, s.X, R, D, 50 * eps, "sliding"));
  PetscCall(MSimDestroy(&T, &G, &D, &R, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Body(void)
{
  PetscFunctionBeginUser;
  /* edge 0.2 m: vertex-disjoint elements of the flat grid are 0.141 m apart, within dhat 0.18 (on
     purpose; the start check runs in MSimRun, not here, and -msim_self_contact_start_gap 0 is the
     option a run of this start would need) */
  PetscCall(Run("-msim_cloth_n 6 -msim_fix none -msim_perturb 0.02 -msim_self_contact -msim_self_contact_distance 0.18 -msim_self_contact_start_gap 0 -msim_friction 0.4 -msim_integrator implicit_euler", PETSC_FALSE));
  PetscCall(Run("-msim_cloth_n 6 -msim_fix corners -msim_fix_velocity 0.3,-0.2,0.1 -msim_perturb 0.02 -msim_self_contact -msim_self_contact_distance 0.18 -msim_self_contact_start_gap 0 -msim_friction 0.4 -msim_integrator implicit_euler", PETSC_TRUE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(Body)
