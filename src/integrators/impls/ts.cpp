/* Hands each step to a PETSc TS. Explicit types (euler, rk, ssp, basicsymplectic) get the
   right-hand side on U = [x; v] (each rank: its 3 nown positions, then velocities): -ts_type rk
   -ts_rk_type 4 -ts_adapt_type none is RK4; -ts_type basicsymplectic -ts_basicsymplectic_type 1 is
   symplectic Euler through the "position"/"momentum" splits. Implicit types get the implicit form
   with its analytic Jacobian (ts_forms.h): first order on U (beuler, theta, cn, bdf, rosw,
   arkimex, alpha; not irk, which needs an AIJ Jacobian), second order on x and v (alpha2). An adaptive TS (-ts_adapt_type basic,
   dsp) takes its own steps inside each -msim_dt, which then sets the interval of frames,
   monitors and checkpoints; it starts each interval with the step it proposed last, which a
   checkpoint carries (as the one vector of the integrator's history, every entry that step), so
   a restart of a one-step type with an embedded error estimate (rosw, arkimex) repeats the
   uninterrupted run bit for bit with -ts_adapt_type basic (dsp's controller filters the last
   steps' error estimates, private too: a warning; so does an rk tableau that reuses its last
   stage's derivative as the next step's first, FSAL, as 5dp). Types whose TS keeps a history of its own (theta, cn and beuler's
   adaptive error estimate from the previous step's state, bdf's past states, alpha2's
   acceleration) hold it in PETSc's private structs, which no public call reads or sets: a restart
   starts it afresh and says so in a warning (alpha2 at radius 0.5: 20 steps restarted at step 10
   differ from the uninterrupted run). */
#include <msim/integrator.h>
#include <initializer_list>
#include "ts_forms.h"
#include <msim/contact.h>
#include <msim/solvers.h>
#include <msim/private/integratorimpl.h>
#include <msim/private/systemimpl.h>
#include <msim/destroy.h>
#include <msim/signals.h>
#include <msim/run.h>

typedef enum { TS_FORM_EXPLICIT, TS_FORM_FIRST_ORDER, TS_FORM_SECOND_ORDER } TSForm;

typedef struct {
  TS          ts;
  Vec         U, A;
  Vec         X2, V2; /* second order: TS2SetSolution's x and v */
  IS          is_pos, is_mom;
  TSForm      form;
  MSimTSForms forms;
  PetscReal   h_next;          /* the step the TS proposed last (adaptive) */
  PetscBool   adaptive;        /* the TS's error control chooses its steps (-ts_adapt_type not none) */
  PetscInt    max_substeps;    /* -msim_ts_max_substeps: internal steps allowed per -msim_dt */
  PetscBool   max_substeps_set; /* given by the user (else a fixed-step TS gets its own, smaller default) */
  PetscReal   stage_atol, stage_rtol; /* an adaptive TS's -ts_atol, -ts_rtol, for StageConverged */
  PetscReal   stage_fprev;     /* the stage solve's |F| at the iteration before (StageConverged) */
  PetscInt    substeps, nrejected; /* internal steps and rejections in the run so far */
  PetscBool   monitored_start; /* -ts_monitor and kin called on the start state, as TSSolve does before its first step */
  Vec         H;               /* the checkpoint's history: h_next in every entry */
  PetscReal   fnorm0, fnorm;   /* the current stage solve's first and latest |F| (StageMonitor) */
  char        refused[192];    /* the last stage solve CheckStage refused, in words */
  PetscBool   linearised_noted; /* the note that a fixed-count solve (ksponly) makes a linearised scheme is out */
  PetscInt    stage_failures;  /* stage solves that failed in the current interval (StageReasonView) */
  SNESConvergedReason stage_failed_reason; /* the last one's reason */
} TSInteg;

/* du/dt = [v; M^-1 f(x, v)] */
static PetscErrorCode RHS_Full(TS ts, PetscReal t, Vec U, Vec F, void *ctx)
{
  MSimIntegrator integ = (MSimIntegrator)ctx;
  TSInteg       *d     = (TSInteg *)integ->data;
  Vec            X, V, Fx, Fv;

  PetscFunctionBeginUser;
  PetscCall(VecGetSubVector(U, d->is_pos, &X));
  PetscCall(VecGetSubVector(U, d->is_mom, &V));
  PetscCall(VecGetSubVector(F, d->is_pos, &Fx));
  PetscCall(VecGetSubVector(F, d->is_mom, &Fv));
  PetscCall(VecCopy(V, Fx));
  PetscCall(MSimSystemAcceleration(integ->sys, t, X, V, Fv));
  PetscCall(VecRestoreSubVector(F, d->is_mom, &Fv));
  PetscCall(VecRestoreSubVector(F, d->is_pos, &Fx));
  PetscCall(VecRestoreSubVector(U, d->is_mom, &V));
  PetscCall(VecRestoreSubVector(U, d->is_pos, &X));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Split RHS of basicsymplectic: the position split receives the momentum (here velocity) part and
   returns dx/dt = v; the momentum split receives the positions and returns dv/dt = M^-1 f(x). */
static PetscErrorCode RHS_Position(TS ts, PetscReal t, Vec V, Vec F, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(VecCopy(V, F));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode RHS_Momentum(TS ts, PetscReal t, Vec X, Vec F, void *ctx)
{
  MSimIntegrator integ = (MSimIntegrator)ctx;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemAcceleration(integ->sys, t, X, NULL, F));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Every SNES type calls its monitors with the norm of each iterate (ksponly evaluates F at its
   result only when a monitor is set), so this sees each stage solve's first and last |F|. */
static PetscErrorCode StageMonitor(SNES snes, PetscInt it, PetscReal fnorm, void *ctx)
{
  TSInteg *d = (TSInteg *)ctx;

  PetscFunctionBeginUser;
  if (it == 0) d->fnorm0 = fnorm;
  d->fnorm = fnorm;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Called at the end of every stage solve (SNESSolve's reason views): counts the failed ones, which
   the TS retries at a quarter of the step, for the message of a fixed-step run that runs out of
   internal steps */
static PetscErrorCode StageReasonView(SNES snes, void *ctx)
{
  TSInteg            *d = (TSInteg *)ctx;
  SNESConvergedReason reason;

  PetscFunctionBeginUser;
  PetscCall(SNESGetConvergedReason(snes, &reason));
  if (reason < 0) {
    d->stage_failures++;
    d->stage_failed_reason = reason;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Whether Newton's own correction J^-1 F from the solve's result is below -snes_stol |x|, the
   step test the solve stopped on: true after a full Newton step near roundoff, false where a
   method's short step was a stall (qn, anderson), with the SNES's Jacobian and KSP. */
static PetscErrorCode NewtonStepShort(SNES snes, PetscReal stol, PetscBool *is_short)
{
  Vec                x, F, e;
  Mat                J, P;
  KSP                ksp;
  KSPConvergedReason kreason;
  PetscReal          enorm, xnorm;

  PetscFunctionBeginUser;
  PetscCall(SNESGetSolution(snes, &x));
  PetscCall(SNESGetFunction(snes, &F, NULL, NULL));
  PetscCall(SNESGetJacobian(snes, &J, &P, NULL, NULL));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(SNESComputeFunction(snes, x, F));
  PetscCall(SNESComputeJacobian(snes, x, J, P));
  PetscCall(KSPSetOperators(ksp, J, P));
  PetscCall(VecDuplicate(x, &e));
  PetscCall(KSPSolve(ksp, F, e));
  PetscCall(KSPGetConvergedReason(ksp, &kreason));
  PetscCall(VecNorm(e, NORM_2, &enorm));
  PetscCall(VecNorm(x, NORM_2, &xnorm));
  PetscCall(VecDestroy(&e));
  *is_short = (PetscBool)(kreason >= 0 && enorm <= stol * xnorm);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* TSAdaptCheckStage's hook, after a stage solve that its SNES did not report as failed. PETSc
   takes any positive reason as converged, but qn and anderson also stop on a short step
   (CONVERGED_SNORM_RELATIVE) with |F| barely below where it started, or above. Such a stage is
   refused unless |F| meets the SNES's own tolerance or Newton's correction from it is as short
   (Newton itself stops there near roundoff at tight tolerances), and the run stops on it: retried
   at a quarter of the step, as TS would, these solvers stall again, and the steps they do accept
   stay that short (a bdf cloth crawled at 1e-20 s steps). A fixed count (ksponly's one linear
   solve, CONVERGED_ITS) is a linearised scheme the user chose: accepted, with a note once. The
   monitor's residual is the largest |F| of the interval's accepted stage solves (0 for rosw,
   linearly implicit by design). */
static PetscErrorCode CheckStage(TSAdapt adapt, TS ts, PetscReal t, Vec Y, PetscBool *accept)
{
  MSimIntegrator      integ;
  TSInteg            *d;
  SNES                snes;
  SNESType            stype;
  TSType              type;
  SNESConvergedReason reason;
  PetscReal           atol, rtol, stol, tol, t0, h;
  PetscInt            maxit, maxf;

  PetscFunctionBeginUser;
  PetscCall(TSGetApplicationContext(ts, &integ));
  d       = (TSInteg *)integ->data;
  *accept = PETSC_TRUE;
  PetscCall(TSGetSNES(ts, &snes));
  PetscCall(SNESGetConvergedReason(snes, &reason));
  PetscCall(TSGetType(ts, &type));
  if (!strcmp(type, TSROSW)) PetscFunctionReturn(PETSC_SUCCESS); /* linearly implicit: its own ksponly solves, no nonlinear stage */
  PetscCall(SNESGetType(snes, &stype));
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &maxit, &maxf));
  tol = PetscMax(atol, rtol * d->fnorm0);
  if (reason == SNES_CONVERGED_ITS && !d->linearised_noted) {
    d->linearised_noted = PETSC_TRUE;
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: note: -snes_type %s with -ts_type %s stops each implicit stage after a fixed count (a linearised scheme), not at -snes_atol/-snes_rtol: the monitor's residual is |F| where it stopped\n", stype, type));
  }
  if (reason != SNES_CONVERGED_ITS && !(d->fnorm <= tol)) PetscCall(NewtonStepShort(snes, stol, accept));
  if (!*accept) {
    PetscCall(TSGetTime(ts, &t0));
    PetscCall(TSGetTimeStep(ts, &h));
    PetscCall(PetscSNPrintf(d->refused, sizeof(d->refused), "-snes_type %s stalled (%s) at |F| = %.3g > max(-snes_atol, -snes_rtol |F0|) = %.3g in the step from t = %g with h = %g", stype, SNESConvergedReasons[reason], (double)d->fnorm, (double)tol, (double)t0, (double)h));
    PetscCall(TSSetConvergedReason(ts, TS_DIVERGED_NONLINEAR_SOLVE));
  } else integ->residual = PetscMax(integ->residual, d->fnorm);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The stage solves' convergence test under an adaptive TS whose -snes_atol/-snes_rtol/-snes_stol
   the user left alone: PETSc's default test stops at |F| <= 1e-8 |F0|, which is not in the units of
   -ts_atol/-ts_rtol, and the error control then measures the solves' error, not the scheme's
   (alpha2 on a damped chain: 1.4e-7 m off at -ts_atol/-ts_rtol 1e-6, 2.9e-6 m at 1e-7, more
   steps for a worse answer). A relative stop is accepted only once the last step of the solve is
   below a tenth of the TS's tolerance on the unknowns (positions for alpha2; positions and
   velocities for the first-order types), or once |F| no longer halves (roundoff: at -ts_atol
   1e-14 on a cloth no step gets that short); Newton's next correction is then far smaller still. */
static PetscErrorCode StageConverged(SNES snes, PetscInt it, PetscReal xnorm, PetscReal snorm, PetscReal fnorm, SNESConvergedReason *reason, void *ctx)
{
  TSInteg *d = (TSInteg *)ctx;

  PetscFunctionBeginUser;
  PetscCall(SNESConvergedDefault(snes, it, xnorm, snorm, fnorm, reason, NULL));
  if ((*reason == SNES_CONVERGED_FNORM_RELATIVE || *reason == SNES_CONVERGED_SNORM_RELATIVE) && snorm > 0.1 * (d->stage_atol + d->stage_rtol * xnorm) && fnorm < 0.5 * d->stage_fprev) *reason = SNES_CONVERGED_ITERATING;
  d->stage_fprev = fnorm;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* An adaptive TS with nonlinear stages: the stage solves tied to -ts_atol/-ts_rtol where the user
   set none of -snes_atol/-snes_rtol/-snes_stol (StageConverged); where -snes_rtol or -snes_atol was
   set above a hundredth of the TS's tolerance (alpha2's -snes_rtol 1e-8 at 1e-7: 29 x the tolerance
   off), one warning */
static PetscErrorCode SetStageTolerance(MSimIntegrator integ, TSInteg *d, SNES snes, TSType type)
{
  const char *prefix;
  PetscBool   atol_set, rtol_set, stol_set;
  PetscReal   atol, rtol, stol, tol;
  PetscInt    maxit, maxf;

  PetscFunctionBeginUser;
  PetscCall(TSGetTolerances(d->ts, &d->stage_atol, NULL, &d->stage_rtol, NULL));
  PetscCall(SNESGetOptionsPrefix(snes, &prefix));
  PetscCall(PetscOptionsHasName(NULL, prefix, "-snes_atol", &atol_set));
  PetscCall(PetscOptionsHasName(NULL, prefix, "-snes_rtol", &rtol_set));
  PetscCall(PetscOptionsHasName(NULL, prefix, "-snes_stol", &stol_set));
  if (!atol_set && !rtol_set && !stol_set) {
    PetscCall(SNESSetConvergenceTest(snes, StageConverged, d, NULL));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &maxit, &maxf));
  tol = d->stage_atol > 0 && d->stage_rtol > 0 ? PetscMin(d->stage_atol, d->stage_rtol) : PetscMax(d->stage_atol, d->stage_rtol);
  /* -snes_atol alike: an absolute |F| the solves may stop at, loose against the same hundredth of
     the tolerance (was not warned about: -snes_atol 1e-2 at -ts_atol 1e-4 ran silently) */
  if (rtol > 1e-2 * tol || atol > 1e-2 * tol) {
    char what[128];
    if (rtol > 1e-2 * tol && atol > 1e-2 * tol) PetscCall(PetscSNPrintf(what, sizeof(what), "-snes_rtol %g of their first residual or at |F| <= -snes_atol %g", (double)rtol, (double)atol));
    else if (rtol > 1e-2 * tol) PetscCall(PetscSNPrintf(what, sizeof(what), "-snes_rtol %g of their first residual", (double)rtol));
    else PetscCall(PetscSNPrintf(what, sizeof(what), "|F| <= -snes_atol %g", (double)atol));
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: adaptive -ts_type %s: the stage solves stop at %s, looser than the error control's tolerance %g needs (1e-2 of it), so the solves' error can exceed the scheme's and a tighter -ts_atol/-ts_rtol give a worse answer; lower %s, or leave -snes_atol/-snes_rtol/-snes_stol unset and msim ties the stage solves to -ts_atol/-ts_rtol\n", type, what, (double)tol, rtol > 1e-2 * tol && atol > 1e-2 * tol ? "-snes_rtol and -snes_atol" : rtol > 1e-2 * tol ? "-snes_rtol" : "-snes_atol"));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Whether type is one of types */
static PetscBool TypeIn(TSType type, std::initializer_list<TSType> types)
{
  for (TSType t : types)
    if (!strcmp(type, t)) return PETSC_TRUE;
  return PETSC_FALSE;
}

/* The form each TS type is served with; PETSC_FALSE for a type msim has no analytic form for
   (not irk: its stages need the Jacobian as an AIJ matrix (MatKAIJ), and msim's is a nest) */
static PetscErrorCode ClassifyType(TSType type, TSForm *form, PetscBool *known)
{
  PetscFunctionBeginUser;
  *known = PETSC_TRUE;
  if (TypeIn(type, {TSEULER, TSRK, TSSSP, TSBASICSYMPLECTIC})) *form = TS_FORM_EXPLICIT;
  else if (TypeIn(type, {TSBEULER, TSTHETA, TSCN, TSBDF, TSROSW, TSARKIMEX, TSALPHA})) *form = TS_FORM_FIRST_ORDER;
  else if (TypeIn(type, {TSALPHA2})) *form = TS_FORM_SECOND_ORDER;
  else *known = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* du/dt = N u with N the lower shift (N e_k = e_{k+1}): one step of h = 1 from e_0 of any
   Runge-Kutta method is R(N) e_0 = (c_0, c_1, ...), its stability polynomial's coefficients */
static PetscErrorCode RHS_Shift(TS ts, PetscReal t, Vec U, Vec F, void *ctx)
{
  const PetscScalar *u;
  PetscScalar       *f;
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(U, &n));
  PetscCall(VecGetArrayRead(U, &u));
  PetscCall(VecGetArray(F, &f));
  f[0] = 0;
  for (PetscInt k = 1; k < n; k++) f[k] = u[k - 1];
  PetscCall(VecRestoreArray(F, &f));
  PetscCall(VecRestoreArrayRead(U, &u));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The stability polynomial of the explicit TS ts (degree 0 where it has none msim knows: basicsymplectic
   is a splitting). rk: c_k = b^T A^(k-1) 1 from its tableau; ssp, whose schemes (rks2, rks3, rk104)
   PETSc writes as low-storage loops with no tableau: one step of a TS of the same scheme and
   stage count on du/dt = N u (RHS_Shift), on each rank alone */
static PetscErrorCode StabilityPolynomial(TS ts, TSType type, PetscInt *degree, PetscReal c[])
{
  PetscFunctionBeginUser;
  *degree = 0;
  if (!strcmp(type, TSEULER)) {
    *degree = 1;
    c[0] = c[1] = 1;
  } else if (!strcmp(type, TSRK)) {
    PetscInt         s;
    const PetscReal *A, *b;
    PetscReal        v[MSIM_STABILITY_MAX_DEGREE], w[MSIM_STABILITY_MAX_DEGREE];
    PetscCall(TSRKGetTableau(ts, &s, &A, &b, NULL, NULL, NULL, NULL, NULL));
    if (s > MSIM_STABILITY_MAX_DEGREE) PetscFunctionReturn(PETSC_SUCCESS);
    for (PetscInt i = 0; i < s; i++) v[i] = 1;
    c[0] = 1;
    for (PetscInt k = 1; k <= s; k++) { /* v = A^(k-1) 1 */
      c[k] = 0;
      for (PetscInt i = 0; i < s; i++) c[k] += b[i] * v[i];
      for (PetscInt i = 0; i < s; i++) {
        w[i] = 0;
        for (PetscInt j = 0; j < s; j++) w[i] += A[i * s + j] * v[j];
      }
      for (PetscInt i = 0; i < s; i++) v[i] = w[i];
    }
    *degree = s;
  } else if (!strcmp(type, TSSSP)) {
    TS                 probe;
    TSAdapt            adapt;
    TSSSPType          ssptype;
    PetscInt           s, n;
    Vec                u;
    const PetscScalar *a;
    PetscCall(TSSSPGetType(ts, &ssptype));
    PetscCall(TSSSPGetNumStages(ts, &s));
    n = PetscMax(s, 10) + 1; /* rk104 takes 10 stages whatever the count says */
    if (n > MSIM_STABILITY_MAX_DEGREE + 1) PetscFunctionReturn(PETSC_SUCCESS);
    PetscCall(TSCreate(PETSC_COMM_SELF, &probe));
    PetscCall(TSSetProblemType(probe, TS_NONLINEAR));
    PetscCall(TSSetType(probe, TSSSP));
    PetscCall(TSSSPSetType(probe, ssptype));
    PetscCall(TSSSPSetNumStages(probe, s));
    PetscCall(TSGetAdapt(probe, &adapt));
    PetscCall(TSAdaptSetType(adapt, TSADAPTNONE));
    PetscCall(VecCreateSeq(PETSC_COMM_SELF, n, &u));
    PetscCall(VecSet(u, 0));
    PetscCall(VecSetValue(u, 0, 1, INSERT_VALUES));
    PetscCall(VecAssemblyBegin(u));
    PetscCall(VecAssemblyEnd(u));
    PetscCall(TSSetRHSFunction(probe, NULL, RHS_Shift, NULL));
    PetscCall(TSSetSolution(probe, u));
    PetscCall(TSSetTimeStep(probe, 1));
    PetscCall(TSSetMaxSteps(probe, 1)); /* TSSetUp wants an end */
    PetscCall(TSStep(probe));
    PetscCall(VecGetArrayRead(u, &a));
    for (PetscInt k = 0; k < n; k++) c[k] = PetscRealPart(a[k]);
    PetscCall(VecRestoreArrayRead(u, &a));
    PetscCall(VecDestroy(&u));
    PetscCall(TSDestroy(&probe));
    for (*degree = n - 1; *degree > 0 && c[*degree] == 0; (*degree)--) { }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Stability limits for the guard: an explicit type's largest h omega_max on the imaginary axis
   (undamped springs), from its stability polynomial where it has one (rk 4: 2 sqrt(2); 3: sqrt(3);
   euler, rk 1fe and 2a, ssp rks2: 0, unstable at every step without drag), basicsymplectic's 2;
   implicit ones have none. An adaptive TS with an error estimate takes its own steps inside
   -msim_dt, which is then no step of its: no guard (one without an estimate, as rk 4, cannot
   adapt: PETSc refuses it at its first step, after the guard's warning as before) */
static PetscErrorCode SetStabilityLimit(MSimIntegrator integ, TSInteg *d, TSType type)
{
  TSAdapt   adapt;
  PetscBool none, estimate = PETSC_FALSE;

  PetscFunctionBeginUser;
  integ->stability_limit  = PETSC_INFINITY;
  integ->stability_degree = 0;
  if (d->form != TS_FORM_EXPLICIT) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(TSGetAdapt(d->ts, &adapt));
  PetscCall(PetscObjectTypeCompare((PetscObject)adapt, TSADAPTNONE, &none));
  if (!strcmp(type, TSRK)) {
    const PetscReal *bembed;
    PetscCall(TSRKGetTableau(d->ts, NULL, NULL, NULL, NULL, &bembed, NULL, NULL, NULL));
    estimate = (PetscBool)(bembed != NULL);
  }
  if (!none && estimate) PetscFunctionReturn(PETSC_SUCCESS);
  if (!strcmp(type, TSBASICSYMPLECTIC)) integ->stability_limit = 2.0;
  PetscCall(StabilityPolynomial(d->ts, type, &integ->stability_degree, integ->stability_poly));
  if (integ->stability_degree > 0) PetscCall(MSimStabilityPolynomialLimit(integ->stability_degree, integ->stability_poly, 0, &integ->stability_limit));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Refuses alpha or alpha2 with alpha_f < 1 (any -ts_alpha_radius > 0) and an obstacle. Their
   forces are evaluated at x_n + alpha_f (x_{n+1} - x_n); the penalty, switched on and off within a
   step and stiffer than a step resolves (kc 12000 N/m on 0.01 kg: omega h = 11 at h = 0.01), then
   gains energy at landings where the penalty comes and goes, with no bound: a 10 x 10 cloth dropped
   5 cm flat on a frictionless plane (0.49 J released), 200 steps of 0.01 s, reached 3.99 J at
   radius 0.5, 3.55 J at 0.2, 12.1 J at 0.9 (alpha2) and 11.6 J at 0.9 (alpha), still flying. With
   alpha_f = 1 (radius 0) the forces are those of x_{n+1} and the same landings only lose energy
   (at h = 0.02, 0.01, 0.005; a one-vertex model of the scheme over 150 random kc, masses, steps and
   heights gained at most 5e-14 of the released energy, and up to 7.5e3 times it at radius 0.5). */
static PetscErrorCode CheckAlphaContact(MSimIntegrator integ, TS ts, TSType type)
{
  MSimContact ct;
  PetscReal   am, af, gamma, beta;

  PetscFunctionBeginUser;
  if (!TypeIn(type, {TSALPHA, TSALPHA2})) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimContactGet(integ->sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  if (!strcmp(type, TSALPHA2)) PetscCall(TSAlpha2GetParams(ts, &am, &af, &gamma, &beta));
  else PetscCall(TSAlphaGetParams(ts, &am, &af, &gamma));
  PetscCheck(af >= 1, integ->comm, PETSC_ERR_SUP, "-ts_type %s with alpha_f = %g < 1 (-ts_alpha_radius > 0) and an obstacle is not supported: it evaluates the penalty between x_n and x_{n+1}, where a contact that comes and goes within a step adds energy without bound (a cloth dropped 5 cm on a plane: 3.99 J from 0.49 J at radius 0.5); use -ts_alpha_radius 0 (forces at x_{n+1}), beuler or bdf", type, (double)af);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Refuses theta and cn (theta 0.5) with theta < 0.99 and an obstacle, for the reason alpha is
   refused above: the forces weigh x_n by 1 - theta, so the penalty, stiffer than a step resolves,
   gains energy where a contact comes and goes within a step. Measured on a 12 x 12 cloth (1 kg,
   -msim_fix none, h = 0.02) by the largest rise of the monitor's total + contact_energy above its
   start: dropped on a sphere (0.5,0.5,-0.4,0.3, 15 steps) +51.4 J at theta 0.5 (total alone
   +42.1 J, where it stays), +0.62 J at 0.6, +0.03 J at 0.7, none from 0.8; dropped 10 cm and 5 cm
   on a plane (40 steps) +17.6 / +12.5 J at 0.5, +2.2 / +7.6 J at 0.7, +3.9 / +1.4 J at 0.9,
   +0.35 / +0.014 J at 0.95, none at 0.97, 0.98, 0.99 and 1 (with -ts_theta_endpoint, none at 0.99
   and 1 either). Theta 1 is beuler; 0.99 keeps a margin over the last theta that gained (0.95) */
static PetscErrorCode CheckThetaContact(MSimIntegrator integ, TS ts, TSType type)
{
  MSimContact ct;
  PetscReal   theta;

  PetscFunctionBeginUser;
  if (!TypeIn(type, {TSTHETA, TSCN})) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimContactGet(integ->sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(TSThetaGetTheta(ts, &theta));
  PetscCheck(theta >= 0.99, integ->comm, PETSC_ERR_SUP, "-ts_type %s with theta = %g < 0.99 and an obstacle is not supported: it evaluates the penalty partly at x_n, where a contact that comes and goes within a step adds energy (a cloth dropped on a sphere: +42 J from rest at theta 0.5, and landings gain up to theta 0.95); use -ts_type beuler, bdf, theta with -ts_theta_theta 0.99 to 1, or msim's own schemes (-msim_integrator implicit_euler or bdf2) with the barrier", type, (double)theta);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SetFromOptions_TS(MSimIntegrator integ)
{
  TSInteg *d = (TSInteg *)integ->data;

  PetscFunctionBeginUser;
  PetscOptionsBegin(integ->comm, NULL, "msim ts integrator", NULL);
  PetscCall(MSimOptionsInt("-msim_ts_max_substeps", "Most internal steps the TS may take within one -msim_dt before the run stops as diverged (default 100000 for an adaptive TS; 20 for a fixed-step one, whose extra steps are retries of failed stage solves at a quarter of the step)", NULL, d->max_substeps, &d->max_substeps, &d->max_substeps_set));
  PetscOptionsEnd();
  PetscCheck(d->max_substeps >= 1, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_ts_max_substeps must be >= 1 (got %" PetscInt_FMT ")", d->max_substeps);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -ts_atol and -ts_rtol: the error control's tolerance atol + rtol |u| per unknown, which an
   adaptive TS alone reads (PETSc 3.18's TSErrorWeightedNorm, and SetStageTolerance here). PETSc
   takes them as given: on a 7 x 7 cloth under bdf (9 internal steps in 5 -msim_dt, 2 rejected, at
   the default), -ts_atol -1 took one internal step per -msim_dt, none rejected (the control off in
   effect), -ts_atol -1e-4 ended in a NaN stage, and both 0 again took one step per -msim_dt:
   TSErrorWeightedNorm skips each unknown whose tolerance is 0 and, with none left, returns an error
   norm of 0, so every step is accepted at the largest size the controller allows. A fixed-step TS
   never reads them, and refuses them as it refuses -ts_dt */
static PetscErrorCode CheckTolerances(MSimIntegrator integ, TSInteg *d)
{
  const char *prefix;
  PetscReal   atol, rtol;

  PetscFunctionBeginUser;
  if (!d->adaptive) {
    PetscCall(TSGetOptionsPrefix(d->ts, &prefix));
    for (const char *name : {"-ts_atol", "-ts_rtol"}) {
      PetscBool given;
      PetscCall(PetscOptionsHasName(NULL, prefix, name, &given));
      PetscCheck(!given, integ->comm, PETSC_ERR_SUP, "%s is not read by a fixed-step TS: it bounds an adaptive TS's error estimate (-ts_adapt_type basic or dsp); a fixed-step one takes one step per -msim_dt", name);
    }
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(TSGetTolerances(d->ts, &atol, NULL, &rtol, NULL));
  PetscCheck(atol >= 0, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-ts_atol must be >= 0 (got %g)", (double)atol);
  PetscCheck(rtol >= 0, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-ts_rtol must be >= 0 (got %g)", (double)rtol);
  PetscCheck(atol > 0 || rtol > 0, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-ts_atol and -ts_rtol are both 0: the error control would accept every step (its tolerance atol + rtol |u| must be > 0)");
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Setup_TS(MSimIntegrator integ)
{
  TSInteg   *d   = (TSInteg *)integ->data;
  MSimSystem sys = integ->sys;
  TSType     type;
  PetscBool  known;

  PetscFunctionBeginUser;
  PetscCall(VecCreateMPI(integ->comm, 6 * sys->nown, 6 * sys->nfree, &d->U));
  PetscCall(ISCreateStride(integ->comm, 3 * sys->nown, 6 * sys->rstart, 1, &d->is_pos));
  PetscCall(ISCreateStride(integ->comm, 3 * sys->nown, 6 * sys->rstart + 3 * sys->nown, 1, &d->is_mom));
  PetscCall(TSCreate(integ->comm, &d->ts));
  PetscCall(TSSetProblemType(d->ts, TS_NONLINEAR));
  PetscCall(TSSetType(d->ts, TSRK));
  PetscCall(TSRKSetType(d->ts, TSRK4));
  PetscCall(TSSetTimeStep(d->ts, integ->dt));
  PetscCall(TSSetMaxSteps(d->ts, PETSC_MAX_INT - 1)); /* msim drives the steps one TSStep at a time; PETSC_MAX_INT reads as unset */
  PetscCall(TSSetMaxTime(d->ts, PETSC_MAX_REAL));
  /* a failed nonlinear solve retries the step at a quarter of its size (TSAdaptCheckStage,
     -ts_adapt_scale_solve_failed), up to
     -ts_max_reject times, and a step that still fails stops the run as diverged through msim's
     own path (the last good state kept), not as an error inside TSStep */
  PetscCall(TSSetMaxSNESFailures(d->ts, -1));
  PetscCall(TSSetErrorIfStepFails(d->ts, PETSC_FALSE));
  PetscCall(TSSetFromOptions(d->ts));
  PetscCall(TSGetType(d->ts, &type));
  PetscCall(ClassifyType(type, &d->form, &known));
  PetscCheck(known, integ->comm, PETSC_ERR_SUP, "-ts_type %s: msim's ts integrator has no analytic form for this type; use an explicit type (euler, rk, ssp, basicsymplectic), a first-order implicit one (beuler, theta, cn, bdf, rosw, arkimex, alpha) or alpha2", type);
  if (!strcmp(type, TSTHETA)) {
    PetscReal theta;
    PetscCall(TSThetaGetTheta(d->ts, &theta));
    /* theta 0 is forward Euler written implicitly: its stage Jacobian's shift 1/(theta h) is
       infinite (a NaN residual at the first solve); past 1 the scheme leaves its family */
    PetscCheck(theta > 0 && theta <= 1, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-ts_theta_theta must be in (0, 1] (got %g)", (double)theta);
  }
  PetscCall(SetStabilityLimit(integ, d, type));
  PetscCall(CheckAlphaContact(integ, d->ts, type));
  PetscCall(CheckThetaContact(integ, d->ts, type));
  switch (d->form) {
  case TS_FORM_EXPLICIT:
    PetscCall(TSSetRHSFunction(d->ts, NULL, RHS_Full, integ));
    PetscCall(TSRHSSplitSetIS(d->ts, "position", d->is_pos));
    PetscCall(TSRHSSplitSetIS(d->ts, "momentum", d->is_mom));
    PetscCall(TSRHSSplitSetRHSFunction(d->ts, "position", NULL, RHS_Position, integ));
    PetscCall(TSRHSSplitSetRHSFunction(d->ts, "momentum", NULL, RHS_Momentum, integ));
    PetscCall(TSSetSolution(d->ts, d->U));
    PetscCheck(strcmp(type, TSBASICSYMPLECTIC) || (sys->damping == 0 && sys->drag == 0), integ->comm, PETSC_ERR_ARG_INCOMP, "-ts_type basicsymplectic needs forces independent of velocity: set -msim_damping 0 -msim_drag 0");
    break;
  case TS_FORM_FIRST_ORDER:
    /* ARKIMEX: the whole force is in the implicit form, whose explicit first stage needs an
       identity mass (dF/dU' = I) */
    PetscCall(MSimTSFormsCreate(sys, d->is_pos, d->is_mom, &d->forms));
    PetscCall(MSimTSFormsSetFirstOrder(d->forms, d->ts, (PetscBool)!strcmp(type, TSARKIMEX)));
    PetscCall(TSSetSolution(d->ts, d->U));
    break;
  case TS_FORM_SECOND_ORDER:
    PetscCall(MSimTSFormsCreate(sys, d->is_pos, d->is_mom, &d->forms));
    PetscCall(MSimTSFormsSetSecondOrder(d->forms, d->ts));
    PetscCall(VecDuplicate(sys->X0, &d->X2));
    PetscCall(VecDuplicate(sys->X0, &d->V2));
    PetscCall(TS2SetSolution(d->ts, d->X2, d->V2));
    break;
  }
  if (d->forms) {
    SNES snes;
    PetscCall(TSGetSNES(d->ts, &snes));
    PetscCall(MSimSNESCheckServed(snes));
    if (!strcmp(type, TSROSW)) {
      /* rosw's stages are linear systems in its Jacobian, solved once each (ksponly, its default;
         newtonls makes the same solve and stops); a SNES that iterates without that solve crawls:
         qn on a 10 x 10 cloth took 1.9 million iterations for 9 steps of 0.01 s (adaptive), or
         stopped at -snes_max_it 10000 (fixed step) */
      SNESType  stype;
      PetscBool linear;
      PetscCall(SNESGetType(snes, &stype));
      PetscCall(PetscStrInList(stype, "ksponly,newtonls", ',', &linear));
      PetscCheck(linear, integ->comm, PETSC_ERR_SUP, "-snes_type %s with -ts_type rosw is not supported: rosw's stages are linear systems, each one solve with its Jacobian (ksponly, its default, or newtonls), which %s iterates without (qn on a 10 x 10 cloth: 1.9 million iterations in 9 steps); drop -snes_type, or use a nonlinearly implicit type (beuler, bdf, arkimex)", stype, stype);
    }
    PetscCall(MSimSNESSetUpPD(snes)); /* pd (or pd as the preconditioner) is refused here, not at the first stage */
    {
      /* a nonlinear preconditioner gets the TS's stage function with PETSc's default linear
         solver, which the nest Jacobian does not take (ngmres over newtonls: "no ILU for a nest"),
         or wants an objective the TS has none of (ntr) */
      PetscBool has_npc;
      PetscCall(SNESHasNPC(snes, &has_npc));
      PetscCheck(!has_npc, integ->comm, PETSC_ERR_SUP, "-npc_snes_type with -msim_integrator ts is not supported: the stage solves take one SNES (newtonls by default); nonlinear preconditioners serve the implicit schemes (implicit_euler, bdf2, implicit_midpoint, newmark)");
    }
    PetscCall(MSimTSFormsSetFromOptions(d->forms, d->ts));
  }
  PetscCall(TSSetUp(d->ts));
  {
    TSAdapt adapt;
    PetscCall(TSGetAdapt(d->ts, &adapt));
    PetscCall(PetscObjectTypeCompare((PetscObject)adapt, TSADAPTNONE, &known));
    d->adaptive = (PetscBool)!known;
    PetscCall(CheckTolerances(integ, d));
    if (d->forms) { /* after the options, which could cancel a monitor set before them */
      SNES snes;
      PetscCall(TSGetSNES(d->ts, &snes));
      PetscCall(SNESMonitorSet(snes, StageMonitor, d, NULL));
      PetscCall(SNESConvergedReasonViewSet(snes, StageReasonView, d, NULL));
      PetscCall(TSSetApplicationContext(d->ts, integ));
      PetscCall(TSAdaptSetCheckStage(adapt, CheckStage));
      if (d->adaptive && strcmp(type, TSROSW)) PetscCall(SetStageTolerance(integ, d, snes, type)); /* rosw's stages are linear solves */
      if (!d->adaptive && !strcmp(type, TSROSW)) {
        /* its linear stages take the penalty's stiffness at the step's start: a vertex that lands
           within a step meets a penalty no stage resolved. A 10 x 10 cloth dropped 5 cm on a
           plane diverged at its landing at h = 0.01 and 0.005 (ran at 0.002, and adaptive at
           0.01, as do fixed-step beuler, bdf and arkimex): warned, since small steps run */
        MSimContact ct;
        PetscCall(MSimContactGet(integ->sys, &ct));
        if (ct) PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: -ts_type rosw with a fixed step and an obstacle: its linear stages take the contact penalty's stiffness at each step's start, so a vertex that lands within a step meets it unresolved (a cloth dropped 5 cm on a plane diverged at -msim_dt 0.01 and 0.005); use -ts_adapt_type basic, a nonlinearly implicit type (beuler, bdf, arkimex) or a smaller -msim_dt\n"));
      }
      PetscCall(MSimStopSignalSetSNES(snes)); /* after the stage test it wraps */
    }
    /* a fixed-step TS takes one step per -msim_dt unless a stage solve fails, each failure
       retrying at a quarter of the step: a box landing with -msim_volume under beuler (a scene ts
       now refuses; tests/ts_implicit.py fails stages by Newton's iteration limit) shrank its
       steps to 1e-11 s and ran for 11+ minutes in one interval at the default 100000 */
    if (!d->adaptive && !d->max_substeps_set) d->max_substeps = 20;
  }
  /* an adaptive TS's first internal step (a fixed-step one always takes -msim_dt): -ts_dt where
     given, else -msim_dt, except for beuler, theta or cn: their error estimate needs the previous
     step's state, so PETSc accepts their first step unchecked (a whole -msim_dt of 0.3 s ended
     5e-2 m off at any tolerance); they start at 1e-3 -msim_dt, where that step's error is small,
     and the controller grows the steps */
  {
    const char *prefix;
    PetscBool   given;
    PetscCall(TSGetOptionsPrefix(d->ts, &prefix));
    /* msim steps the TS itself (TSStep from each interval's start, landing on its end), so the
       options of TSSolve's loop never act: -ts_max_time 0.05 with -msim_steps 10 -msim_dt 0.01 ran
       to 0.1 s without a word (PETSc reads them, so no unused-option warning either) */
    for (const char *name : {"-ts_max_time", "-ts_max_steps", "-ts_init_time", "-ts_exact_final_time", "-ts_time_span"}) {
      PetscCall(PetscOptionsHasName(NULL, prefix, name, &given));
      PetscCheck(!given, integ->comm, PETSC_ERR_SUP, "%s is not read by -msim_integrator ts: msim steps the TS itself, -msim_steps intervals of -msim_dt from t = 0, each landed exactly; set those", name);
    }
    /* TSSolve's other work, read by TSSetFromOptions and never done under TSStep: a trajectory
       (-ts_save_trajectory and -ts_trajectory_type stored nothing) and the adjoint solve after
       it (-ts_trajectory_type visualization wrote no file); and -ts_monitor_solution_vtk, which
       Step_TS's TSMonitor calls but which wrote no file either (its VTK viewer writes a DM's
       vector; the TS has no DM), all without a word */
    for (const char *name : {"-ts_save_trajectory", "-ts_trajectory_type", "-ts_adjoint_solve", "-ts_monitor_solution_vtk"}) {
      PetscCall(PetscOptionsHasName(NULL, prefix, name, &given));
      PetscCheck(!given, integ->comm, PETSC_ERR_SUP, "%s is not supported with -msim_integrator ts: msim steps the TS itself (TSStep), without TSSolve's %s; %s", name, strcmp(name, "-ts_monitor_solution_vtk") ? "trajectory or adjoint" : "VTK output of a DM's solution",
                 strcmp(name, "-ts_monitor_solution_vtk") ? "msim has no sensitivities; -msim_output DIR writes the states as a series, -msim_monitor_csv the energies" : "-msim_output DIR writes the states as a series (-msim_output_every k); -ts_monitor prints each internal step");
    }
    /* PETSc counts failed stage solves over the TS's whole life (TSSolve's, here the run's: a
       restart counts afresh) and stops at the N-th, which is not msim's retry count: each failed
       solve is retried at a quarter of the step up to -ts_max_reject times per internal step,
       within -msim_ts_max_substeps internal steps per -msim_dt */
    /* msim ends a run whose step fails in a line of its own, the last finite state kept, and a
       stop signal inside a step (a stage solve told to stop) ends as a failed TSStep that msim
       turns into the last whole step's checkpoint; TSSetFromOptions reads -ts_error_if_step_fails
       after msim set it false, and with it either became PETSc's bare "TSStep has failed due to
       DIVERGED_STEP_REJECTED", nothing kept */
    {
      PetscBool fail = PETSC_FALSE;
      PetscCall(PetscOptionsGetBool(NULL, prefix, "-ts_error_if_step_fails", &fail, &given));
      PetscCheck(!given || !fail, integ->comm, PETSC_ERR_SUP, "-ts_error_if_step_fails is not supported by -msim_integrator ts: msim ends a run whose step fails with an error line of its own, keeping the last finite state (and a stop signal's checkpoint), which PETSc's error would lose; drop it");
    }
    {
      /* -1, PETSc's "unlimited", is what msim sets itself: accepted */
      PetscInt nfail = -1;
      PetscCall(PetscOptionsGetInt(NULL, prefix, "-ts_max_snes_failures", &nfail, &given));
      given = (PetscBool)(given && nfail != -1);
    }
    PetscCheck(!given, integ->comm, PETSC_ERR_SUP, "-ts_max_snes_failures is not supported by -msim_integrator ts: PETSc counts failed stage solves over the whole run (afresh at a restart), not per step; each failed solve is retried at a quarter of the step up to -ts_max_reject times, within -msim_ts_max_substeps internal steps per -msim_dt: set those");
    PetscCall(PetscOptionsHasName(NULL, prefix, "-ts_dt", &given));
    PetscCheck(!given || d->adaptive, integ->comm, PETSC_ERR_SUP, "-ts_dt with a fixed-step TS is not read: each -msim_dt is one of its steps; set -msim_dt (an adaptive TS, -ts_adapt_type basic or dsp, starts from -ts_dt)");
    if (given) PetscCall(TSGetTimeStep(d->ts, &d->h_next));
    else d->h_next = d->adaptive && TypeIn(type, {TSBEULER, TSTHETA, TSCN}) ? 1e-3 * integ->dt : integ->dt;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* (X, V) into the TS's solution, or back */
static PetscErrorCode CopyState(TSInteg *d, Vec X, Vec V, PetscBool into_ts)
{
  Vec Ux, Uv;

  PetscFunctionBeginUser;
  if (d->form == TS_FORM_SECOND_ORDER) {
    PetscCall(VecCopy(into_ts ? X : d->X2, into_ts ? d->X2 : X));
    PetscCall(VecCopy(into_ts ? V : d->V2, into_ts ? d->V2 : V));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecGetSubVector(d->U, d->is_pos, &Ux));
  PetscCall(VecCopy(into_ts ? X : Ux, into_ts ? Ux : X));
  PetscCall(VecRestoreSubVector(d->U, d->is_pos, &Ux));
  PetscCall(VecGetSubVector(d->U, d->is_mom, &Uv));
  PetscCall(VecCopy(into_ts ? V : Uv, into_ts ? Uv : V));
  PetscCall(VecRestoreSubVector(d->U, d->is_mom, &Uv));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* From t to t + dt in the TS's own steps: one with a fixed-step TS; with an adaptive one as many
   as its error control takes, the last shortened to land on t + dt. */
static PetscErrorCode Step_TS(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  TSInteg            *d    = (TSInteg *)integ->data;
  const PetscReal     tend = t + integ->dt, eps = 1e-12 * PetscMax(1.0, PetscAbsReal(tend));
  PetscReal           tcur = t, h, h_next0;
  PetscInt            snes0, ksp0, snes1, ksp1, rej0, rej1, n = 0;
  TSConvergedReason   reason;

  PetscFunctionBeginUser;
  PetscCall(CopyState(d, X, V, PETSC_TRUE));
  integ->residual     = 0;
  d->refused[0]       = 0;
  d->stage_failures   = 0;
  /* a fixed-step TS tries the whole -msim_dt again in every interval (a failed solve shortens only
     the step that failed) */
  if (!d->adaptive) d->h_next = integ->dt;
  h_next0 = d->h_next; /* what a stop inside the step restores */
  PetscCall(TSGetSNESIterations(d->ts, &snes0));
  PetscCall(TSGetKSPIterations(d->ts, &ksp0));
  PetscCall(TSGetStepRejections(d->ts, &rej0));
  PetscCall(TSSetTime(d->ts, t));
  while (tend - tcur > eps) {
    if (n > 0) { /* SIGINT or SIGTERM: the time loop polls after each step, which may never end here */
      int sig = 0;
      PetscCall(MSimStopSignalPollInStep(&sig));
      if (sig) break;
    }
    if (n >= d->max_substeps) { /* stops as a failed step does, the last finite state kept (was an error from inside the step: no such state, no frame of it) */
      TSType type;
      char   why[256];
      PetscCall(TSGetType(d->ts, &type));
      if (d->adaptive) PetscCall(PetscStrncpy(why, "raise it, or loosen -ts_atol/-ts_rtol", sizeof(why)));
      else if (d->stage_failures > 0) {
        /* a fixed-step TS keeps the quarter step a failed solve left for the rest of the interval */
        SNES      snes;
        SNESType  stype;
        PetscReal atol, rtol, stol;
        PetscInt  maxit, maxf;
        PetscCall(TSGetSNES(d->ts, &snes));
        PetscCall(SNESGetType(snes, &stype));
        PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &maxit, &maxf));
        if (d->stage_failed_reason == SNES_DIVERGED_MAX_IT) PetscCall(PetscSNPrintf(why, sizeof(why), "%" PetscInt_FMT " stage solves stopped at -snes_max_it %" PetscInt_FMT " (-snes_type %s: DIVERGED_MAX_IT), each retried at a quarter step, which a fixed-step TS keeps: raise -snes_max_it or lower -msim_dt", d->stage_failures, maxit, stype));
        else PetscCall(PetscSNPrintf(why, sizeof(why), "%" PetscInt_FMT " stage solves failed (-snes_type %s: %s last), each retried at a quarter step, which a fixed-step TS keeps: lower -msim_dt", d->stage_failures, stype, SNESConvergedReasons[d->stage_failed_reason]));
      } else PetscCall(PetscStrncpy(why, "raise it or lower -msim_dt", sizeof(why)));
      integ->failed      = PETSC_TRUE;
      integ->failed_what = "the TS ran out of internal steps";
      integ->failed_t    = tcur;
      PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-ts_type %s: -msim_ts_max_substeps %" PetscInt_FMT " steps within one -msim_dt %g reached t = %g of %g, the last proposing h = %g: %s)", type, d->max_substeps, (double)integ->dt, (double)tcur, (double)tend, (double)d->h_next, why));
      break;
    }
    h = PetscMin(d->h_next, tend - tcur);
    if (tend - tcur - h <= eps) h = tend - tcur;
    PetscCall(TSSetTimeStep(d->ts, h));
    /* msim steps with TSStep, and only TSSolve calls the monitors set by -ts_monitor (and
       -ts_monitor_solution etc.): call them as it does, on the start state (with the step about to
       be tried) and after each internal step below; nothing runs where none is set */
    if (!d->monitored_start) {
      PetscInt step;
      Vec      U;
      PetscCall(TSGetStepNumber(d->ts, &step));
      PetscCall(TSGetSolution(d->ts, &U));
      PetscCall(TSMonitor(d->ts, step, t, U));
      d->monitored_start = PETSC_TRUE;
    }
    PetscCall(TSStep(d->ts));
    if (MSimStopSignalAgreedInStep()) break; /* inside a stage solve */
    PetscCall(TSGetConvergedReason(d->ts, &reason));
    if (reason < 0) break;
    PetscCall(TSGetTime(d->ts, &tcur));
    {
      PetscInt step;
      Vec      U;
      PetscCall(TSGetStepNumber(d->ts, &step));
      PetscCall(TSGetSolution(d->ts, &U));
      PetscCall(TSMonitor(d->ts, step, tcur, U));
    }
    PetscCall(TSGetTimeStep(d->ts, &h));
    /* a step shortened to land on t + dt says little of the next: keep the proposal before it */
    if (tend - tcur > eps || n == 0) d->h_next = h > 0 ? h : d->h_next;
    n++;
  }
  if (MSimStopSignalAgreedInStep()) {
    /* stopped inside the step: X and V still hold its start (the TS's internal steps between
       intervals are no state a checkpoint keeps), and its proposal for the next step is the
       start's; the time loop keeps that state */
    d->h_next      = h_next0;
    integ->stopped = PETSC_TRUE;
    PetscCall(TSSetConvergedReason(d->ts, TS_CONVERGED_ITERATING));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  d->substeps += n;
  PetscCall(TSGetSNESIterations(d->ts, &snes1));
  PetscCall(TSGetKSPIterations(d->ts, &ksp1));
  PetscCall(TSGetStepRejections(d->ts, &rej1));
  d->nrejected += rej1 - rej0;
  integ->nonlinear_its = snes1 - snes0;
  integ->linear_its    = ksp1 - ksp0;
  PetscCall(TSGetConvergedReason(d->ts, &reason));
  if (reason < 0) {
    TSType              type;
    SNESType            stype = NULL;
    SNESConvergedReason sreason = SNES_CONVERGED_ITERATING;
    PetscCall(TSGetType(d->ts, &type));
    if (d->forms) { /* the last try's stage solve: failed in its SNES's words, refused by CheckStage, or converged */
      SNES snes;
      PetscCall(TSGetSNES(d->ts, &snes));
      PetscCall(SNESGetConvergedReason(snes, &sreason));
      PetscCall(SNESGetType(snes, &stype));
    }
    integ->failed   = PETSC_TRUE;
    integ->failed_t = tcur; /* the internal steps before the one that failed were taken */
    /* the last try's solves converged: the error control, not the solver, gave up on the step
       (the time loop then stops as for a failed solve, keeping the last finite state) */
    PetscCall(TSGetTimeStep(d->ts, &h));
    if (reason == TS_DIVERGED_STEP_REJECTED && d->adaptive && sreason >= 0 && !d->refused[0]) {
      integ->failed_what = "the error control gave up";
      PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-ts_type %s: it rejected the step from t = %g more than -ts_max_reject times, down to h = %g%s: not a solver failure; loosen -ts_atol/-ts_rtol or raise -ts_max_reject)", type, (double)tcur, (double)h, d->forms ? ", where the stage solves converged" : ""));
    } else {
      if (sreason < 0) PetscCall(PetscSNPrintf(d->refused, sizeof(d->refused), "-snes_type %s: %s in the step from t = %g", stype, SNESConvergedReasons[sreason], (double)tcur));
      if (d->refused[0]) PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-ts_type %s: %s: %s)", type, TSConvergedReasons[reason], d->refused));
      else PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-ts_type %s: %s)", type, TSConvergedReasons[reason]));
    }
  }
  PetscCall(CopyState(d, X, V, PETSC_FALSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the step the TS proposed last, for checkpoints */
static PetscErrorCode GetHistory_TS(MSimIntegrator integ, PetscInt *n, Vec **history)
{
  TSInteg *d = (TSInteg *)integ->data;

  PetscFunctionBeginUser;
  if (!d->H) PetscCall(VecDuplicate(integ->sys->X0, &d->H));
  PetscCall(VecSet(d->H, d->h_next));
  *n       = 1;
  *history = &d->H;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The types that keep a history inside PETSc's TS: a fixed-step bdf or alpha2, an adaptive
   theta/cn/beuler (their error estimate), or any adaptive multistep or alpha type; an rk tableau
   whose first stage is the step before's last (FSAL: 3bs, 5dp, 5bs, 6vr, 7vr, 8vr), whose
   derivative PETSc keeps for the next step; and the dsp step controller, which filters the last
   steps' error estimates (its own private history) */
static PetscErrorCode HistoryLoaded_TS(MSimIntegrator integ)
{
  TSInteg  *d = (TSInteg *)integ->data;
  TSType    type;
  TSAdapt   adapt;
  PetscBool own, onestep, dsp, fsal = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(VecMax(d->H, NULL, &d->h_next));
  PetscCall(TSGetType(d->ts, &type));
  own     = TypeIn(type, {TSBDF, TSALPHA, TSALPHA2});
  onestep = TypeIn(type, {TSROSW, TSARKIMEX, TSEULER, TSRK, TSSSP, TSBASICSYMPLECTIC});
  if (!strcmp(type, TSRK)) PetscCall(TSRKGetTableau(d->ts, NULL, NULL, NULL, NULL, NULL, NULL, NULL, &fsal));
  PetscCall(TSGetAdapt(d->ts, &adapt));
  PetscCall(PetscObjectTypeCompare((PetscObject)adapt, TSADAPTDSP, &dsp));
  if (fsal) { /* rk 5dp, fixed step, on the damped cloth: 1.1e-16 m apart 10 steps after the restart */
    TSRKType rktype;
    PetscCall(TSRKGetType(d->ts, &rktype));
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: -msim_restart with -ts_type rk -ts_rk_type %s: its first stage reuses the derivative of the step before's last stage (first same as last), which PETSc holds privately, so it is evaluated afresh here and the run can differ from the uninterrupted one in the last bits\n", rktype));
  } else if (own || (d->adaptive && !onestep))
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: -msim_restart with -ts_type %s%s: its TS keeps a history of its own (%s) that PETSc holds privately, so it starts afresh here and the run need not repeat the uninterrupted one bit for bit\n", type, d->adaptive ? " and an adaptive step" : "", own ? "past states or the acceleration" : "the previous step's state for its error estimate"));
  /* apart from the above: the controller's history is lost whatever the type (rk 5dp with dsp on
     the chain: 1.4e-8 m apart, the controller's difference, not the last bits) */
  if (dsp) /* arkimex at atol 1e-6 on the chain: 8.5e-9 m apart 10 intervals after the restart */
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: -msim_restart with -ts_adapt_type dsp: its controller's history (the last steps' error estimates) is PETSc's private state, so it starts afresh here: the TS's internal steps after the restart, and so the states, can differ from the uninterrupted run's within -ts_atol/-ts_rtol (-ts_adapt_type basic repeats it bit for bit)\n"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_TS(MSimIntegrator integ, PetscViewer viewer)
{
  TSInteg *d = (TSInteg *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerASCIIPrintf(viewer, "ts: %" PetscInt_FMT " internal steps, %" PetscInt_FMT " rejected (by the error control, or a nonlinear solve that failed and was retried at a quarter of the step)\n", d->substeps, d->nrejected));
  if (d->forms) PetscCall(MSimTSFormsView(d->forms, viewer));
  if (d->ts) PetscCall(TSView(d->ts, viewer));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_TS(MSimIntegrator integ)
{
  TSInteg *d = (TSInteg *)integ->data;
  PetscFunctionBeginUser;
  /* msim steps with TSStep, and only TSSolve reads -ts_view: honour it at the end of the run */
  if (d->ts && !integ->help_listing) PetscCall(TSViewFromOptions(d->ts, NULL, "-ts_view"));
  PetscCall(TSDestroy(&d->ts));
  PetscCall(MSimTSFormsDestroy(&d->forms));
  PetscCall(MSimDestroy(&d->U, &d->X2, &d->V2, &d->H, &d->is_pos, &d->is_mom));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimIntegratorOps TSOps = {.setfromoptions = SetFromOptions_TS, .setup = Setup_TS, .step = Step_TS, .view = View_TS, .get_history = GetHistory_TS, .history_loaded = HistoryLoaded_TS,
                                        .destroy = Destroy_TS};

PetscErrorCode MSimIntegratorCreate_TS(MSimIntegrator integ)
{
  TSInteg *d;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&d));
  d->max_substeps = 100000;
  integ->data     = d;
  integ->ops      = TSOps;
  PetscFunctionReturn(PETSC_SUCCESS);
}
