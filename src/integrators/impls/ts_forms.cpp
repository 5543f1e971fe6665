/* Implicit forms of the spring system for PETSc's TS, with analytic sparse Jacobians
   (ts_forms.h). */
#include "ts_forms.h"
#include <msim/contact.h>
#include <msim/solvers.h>
#include <msim/volume.h>
#include <msim/private/systemimpl.h>

struct _n_MSimTSForms {
  MSimSystem sys;
  IS         is_pos, is_mom;
  /* first order: the nest [[a I, -I], [K, a M + C]] and the positions' Schur matrix */
  Mat        J, A00, A01, A10, A11, S;
  KSP        schur;   /* prefix ts_schur_: S dx = r_v + (a M + C) r_x */
  Vec        rhs, work; /* position-sized work */
  PetscReal  shift;     /* the a of the last Jacobian */
  PetscBool  unit_mass; /* the velocity rows divided by M: v' - M^-1 f (ARKIMEX's explicit stages need dF/dU' = I) */
  /* second order: shiftA M + shiftV C + K */
  Mat        J2;
  PetscBool  startup_fix; /* alpha or alpha2 whose user parameters are not its start-up's (StartupScale) */
  PetscInt   nfunction, njacobian; /* evaluations, for the view */
};

/* A = mass_coef M + damp_coef C + stiff_coef K at (t, X): C's spring damping along X's axes.
   The one place that maps TS's coefficients onto the system's assembly. */
static PetscErrorCode Assemble(MSimSystem sys, PetscReal t, Vec X, PetscReal mass_coef, PetscReal damp_coef, PetscReal stiff_coef, Mat A)
{
  PetscFunctionBeginUser;
  const MSimMatrixCoefficients c = {t, X, mass_coef, damp_coef * sys->drag, stiff_coef, PETSC_FALSE, t, damp_coef != 0 && sys->damping > 0 ? X : NULL, damp_coef};
  PetscCall(MSimSystemAssembleMatrix(sys, &c, A));
  if (stiff_coef != 0) PetscCall(MSimSystemVolumeHessian(sys, t, X, stiff_coef, PETSC_FALSE, A)); /* the tets' volume term, if any */
  if (stiff_coef != 0) PetscCall(MSimContactAddPenaltyJacobian(sys, t, X, stiff_coef, A)); /* the obstacles' penalty, which the TS's force has (msim/contact.h) */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Fv = M a - f(t, x, v), with Ma as work */
static PetscErrorCode AccelerationResidual(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec A, Vec Ma, Vec Fv)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemComputeForce(sys, t, X, V, Fv));
  PetscCall(VecPointwiseMult(Ma, sys->mass, A));
  PetscCall(VecAYPX(Fv, -1.0, Ma));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc's TSALPHA2 (3.18, src/ts/impls/implicit/alpha/alpha2.c, TSAlpha_Restart) starts from an
   acceleration a_0 it estimates from two backward-Euler-like solves of dt = h/2 with parameters
   (alpha_m, alpha_f, gamma, beta) = (1, 1, 1, 1/2), v_k = v_{k-1} + dt a_k, as the one-sided
   difference (-3 v_0 + 4 v_1 - v_2) / dt: that difference is 2 dt a_0 + O(dt^2), and it is not
   divided by 2 dt, so the method starts from 2 a_0. With radius 1 (alpha_m = alpha_f = 1/2,
   gamma = 1/2) the error alternates in sign between steps and cancels in x and v; with a radius
   below 1, gamma = 1/2 + alpha_m - alpha_f > 1/2 and v_1 keeps h (1 - gamma) a_0 of it: an O(h)
   error once, first order overall (free fall at radius 0.5: v_1 = 7/6 h g, x off by h g t / 6).
   During those two solves (recognised by their parameters, unless the user's own are the same)
   the residual is 2 M a - f, whose solution a = M^-1 f / 2 makes the difference 2 dt (a_0 / 2):
   the estimate becomes a_0 + O(h), and the method second order.
   TSALPHA (alpha1.c) starts the first-order form the same way, parameters (1, 1, 1), the same
   difference of U = [x; v] giving 2 U'_0 (free fall at radius 0.5 ended 1.7e-3 m off at h = 0.01):
   its start-up residual is F(t, U, 2 U'), [2 x' - v; 2 M v' - f], and its Jacobian's shift 2 a. */
static PetscErrorCode InStartup(TS ts, PetscBool second_order, PetscBool *startup)
{
  PetscReal am, af, gamma, beta = 0.5;

  PetscFunctionBeginUser;
  if (second_order) PetscCall(TSAlpha2GetParams(ts, &am, &af, &gamma, &beta));
  else PetscCall(TSAlphaGetParams(ts, &am, &af, &gamma));
  *startup = (PetscBool)(am == 1 && af == 1 && gamma == 1 && beta == 0.5);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* 2 in alpha's or alpha2's start-up solves (above), else 1 */
static PetscErrorCode StartupScale(MSimTSForms f, TS ts, PetscReal *scale)
{
  PetscBool startup = PETSC_FALSE;

  PetscFunctionBeginUser;
  *scale = 1;
  if (!f->startup_fix) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(InStartup(ts, (PetscBool)!!f->J2, &startup));
  if (startup) *scale = 2;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode IFunction(TS ts, PetscReal t, Vec U, Vec Udot, Vec F, void *ctx)
{
  MSimTSForms f = (MSimTSForms)ctx;
  Vec         X, V, Xd, Vd, Fx, Fv;
  PetscReal   scale;

  PetscFunctionBeginUser;
  f->nfunction++;
  PetscCall(StartupScale(f, ts, &scale));
  PetscCall(VecGetSubVector(U, f->is_pos, &X));
  PetscCall(VecGetSubVector(U, f->is_mom, &V));
  PetscCall(VecGetSubVector(Udot, f->is_pos, &Xd));
  PetscCall(VecGetSubVector(Udot, f->is_mom, &Vd));
  PetscCall(VecGetSubVector(F, f->is_pos, &Fx));
  PetscCall(VecGetSubVector(F, f->is_mom, &Fv));
  PetscCall(VecWAXPY(Fx, -1.0, V, Xd));
  PetscCall(AccelerationResidual(f->sys, t, X, V, Vd, f->work, Fv));
  if (scale != 1) { /* [2 x' - v; 2 M v' - f] = [x' - v; M v' - f] + [x'; M v'] */
    PetscCall(VecAXPY(Fx, scale - 1, Xd));
    PetscCall(VecAXPY(Fv, scale - 1, f->work)); /* M v', left in work */
  }
  if (f->unit_mass) {
    Vec massinv;
    PetscCall(MSimSystemGetInverseMass(f->sys, &massinv));
    PetscCall(VecPointwiseMult(Fv, Fv, massinv));
  }
  PetscCall(VecRestoreSubVector(F, f->is_mom, &Fv));
  PetscCall(VecRestoreSubVector(F, f->is_pos, &Fx));
  PetscCall(VecRestoreSubVector(Udot, f->is_mom, &Vd));
  PetscCall(VecRestoreSubVector(Udot, f->is_pos, &Xd));
  PetscCall(VecRestoreSubVector(U, f->is_mom, &V));
  PetscCall(VecRestoreSubVector(U, f->is_pos, &X));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode IJacobian(TS ts, PetscReal t, Vec U, Vec Udot, PetscReal a, Mat J, Mat P, void *ctx)
{
  MSimTSForms f = (MSimTSForms)ctx;
  Vec         X;
  PetscBool   shell;
  PetscReal   scale;
  SNES        snes;
  KSP         ksp;
  PC          pc;

  PetscFunctionBeginUser;
  f->njacobian++;
  PetscCall(StartupScale(f, ts, &scale));
  a *= scale; /* dF/dU' scaled with U' */
  f->shift = a;
  PetscCall(VecGetSubVector(U, f->is_pos, &X));
  PetscCall(MatZeroEntries(f->A00));
  PetscCall(MatShift(f->A00, a));
  PetscCall(Assemble(f->sys, t, X, 0.0, 0.0, 1.0, f->A10));
  PetscCall(Assemble(f->sys, t, X, a, 1.0, 0.0, f->A11));
  if (f->unit_mass) {
    Vec massinv;
    PetscCall(MSimSystemGetInverseMass(f->sys, &massinv));
    PetscCall(MatDiagonalScale(f->A10, massinv, NULL));
    PetscCall(MatDiagonalScale(f->A11, massinv, NULL));
  }
  /* the exact PC's matrix only while it is the PC in use */
  PetscCall(TSGetSNES(ts, &snes));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCSHELL, &shell));
  if (shell) PetscCall(Assemble(f->sys, t, X, a * a, a, 1.0, f->S));
  PetscCall(VecRestoreSubVector(U, f->is_pos, &X));
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  if (P != J) {
    PetscCall(MatAssemblyBegin(P, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(P, MAT_FINAL_ASSEMBLY));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The exact inverse of [[a I, -I], [K, a M + C]]: dx from the positions' Schur system, then
   dv = a dx - r_x. */
static PetscErrorCode SchurApply(PC pc, Vec R, Vec Y)
{
  MSimTSForms        f;
  Vec                rx, rv, yx, yv;
  KSPConvergedReason reason;

  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &f));
  PetscCall(VecGetSubVector(R, f->is_pos, &rx));
  PetscCall(VecGetSubVector(R, f->is_mom, &rv));
  PetscCall(VecGetSubVector(Y, f->is_pos, &yx));
  PetscCall(VecGetSubVector(Y, f->is_mom, &yv));
  PetscCall(MatMult(f->A11, rx, f->rhs));
  PetscCall(VecAXPY(f->rhs, 1.0, rv));
  if (f->unit_mass) PetscCall(VecPointwiseMult(f->rhs, f->rhs, f->sys->mass)); /* the rows of M^-1 (...) back to S's */
  PetscCall(KSPSolve(f->schur, f->rhs, yx));
  PetscCall(KSPGetConvergedReason(f->schur, &reason));
  PetscCheck(reason >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_NOT_CONVERGED, "ts: the positions' solve (prefix ts_schur_) failed: %s", KSPConvergedReasons[reason]);
  PetscCall(VecAXPBYPCZ(yv, f->shift, -1.0, 0.0, yx, rx));
  PetscCall(VecRestoreSubVector(Y, f->is_mom, &yv));
  PetscCall(VecRestoreSubVector(Y, f->is_pos, &yx));
  PetscCall(VecRestoreSubVector(R, f->is_mom, &rv));
  PetscCall(VecRestoreSubVector(R, f->is_pos, &rx));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode I2Function(TS ts, PetscReal t, Vec X, Vec V, Vec A, Vec F, void *ctx)
{
  MSimTSForms f = (MSimTSForms)ctx;
  PetscReal   scale;

  PetscFunctionBeginUser;
  f->nfunction++;
  PetscCall(StartupScale(f, ts, &scale));
  PetscCall(AccelerationResidual(f->sys, t, X, V, A, f->work, F));
  if (scale != 1) { /* 2 M a - f = (M a - f) + M a */
    PetscCall(VecPointwiseMult(f->work, f->sys->mass, A));
    PetscCall(VecAXPY(F, scale - 1, f->work));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode I2Jacobian(TS ts, PetscReal t, Vec X, Vec V, Vec A, PetscReal shiftV, PetscReal shiftA, Mat J, Mat P, void *ctx)
{
  MSimTSForms f = (MSimTSForms)ctx;
  PetscReal   scale;

  PetscFunctionBeginUser;
  f->njacobian++;
  PetscCall(StartupScale(f, ts, &scale));
  PetscCall(Assemble(f->sys, t, X, scale * shiftA, shiftV, 1.0, P));
  if (J != P) {
    PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Direct LDL^T (MUMPS) on ksp: exact Newton at any rank count, indefinite K included */
static PetscErrorCode DefaultDirect(KSP ksp)
{
  PC pc;

  PetscFunctionBeginUser;
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCCHOLESKY));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTSFormsCreate(MSimSystem sys, IS is_pos, IS is_mom, MSimTSForms *forms)
{
  PetscFunctionBeginUser;
  PetscCall(PetscNew(forms));
  (*forms)->sys    = sys;
  (*forms)->is_pos = is_pos;
  (*forms)->is_mom = is_mom;
  PetscCall(PetscObjectReference((PetscObject)is_pos));
  PetscCall(PetscObjectReference((PetscObject)is_mom));
  PetscCall(VecDuplicate(sys->X0, &(*forms)->rhs));
  PetscCall(VecDuplicate(sys->X0, &(*forms)->work));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTSFormsSetFirstOrder(MSimTSForms f, TS ts, PetscBool unit_mass)
{
  MSimSystem sys = f->sys;
  Mat        blocks[4];
  IS         is[2] = {f->is_pos, f->is_mom};
  SNES       snes;
  KSP        ksp;
  PC         pc;
  Vec        one;
  PetscBool  alpha, startup = PETSC_FALSE;

  PetscFunctionBeginUser;
  f->unit_mass = unit_mass;
  PetscCall(PetscObjectTypeCompare((PetscObject)ts, TSALPHA, &alpha));
  if (alpha) { /* the user's parameters (after TSSetFromOptions) */
    PetscCall(InStartup(ts, PETSC_FALSE, &startup));
    f->startup_fix = (PetscBool)!startup;
  }
  PetscCall(MatCreateAIJ(sys->comm, 3 * sys->nown, 3 * sys->nown, 3 * sys->nfree, 3 * sys->nfree, 1, NULL, 0, NULL, &f->A00));
  PetscCall(MatCreateAIJ(sys->comm, 3 * sys->nown, 3 * sys->nown, 3 * sys->nfree, 3 * sys->nfree, 1, NULL, 0, NULL, &f->A01));
  PetscCall(VecDuplicate(sys->X0, &one));
  PetscCall(VecSet(one, 1.0));
  PetscCall(MatDiagonalSet(f->A00, one, INSERT_VALUES));
  PetscCall(VecScale(one, -1.0));
  PetscCall(MatDiagonalSet(f->A01, one, INSERT_VALUES));
  PetscCall(VecDestroy(&one));
  PetscCall(MSimSystemCreateMatrix(sys, &f->A10));
  PetscCall(MSimSystemCreateMatrix(sys, &f->A11));
  PetscCall(MSimSystemCreateMatrix(sys, &f->S));
  blocks[0] = f->A00;
  blocks[1] = f->A01;
  blocks[2] = f->A10;
  blocks[3] = f->A11;
  PetscCall(MatCreateNest(sys->comm, 2, is, 2, is, blocks, &f->J));
  PetscCall(TSSetIFunction(ts, NULL, IFunction, f));
  PetscCall(TSSetIJacobian(ts, f->J, f->J, IJacobian, f));
  /* the exact Schur PC, unless the user's -pc_type replaces it */
  PetscCall(TSGetSNES(ts, &snes));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCSHELL));
  PetscCall(PCShellSetContext(pc, f));
  PetscCall(PCShellSetApply(pc, SchurApply));
  PetscCall(PCShellSetName(pc, "msim: exact elimination of the velocities, then (a^2 M + a C + K) dx = r by the KSP of prefix ts_schur_"));
  PetscCall(KSPCreate(sys->comm, &f->schur));
  PetscCall(KSPSetOptionsPrefix(f->schur, "ts_schur_"));
  PetscCall(KSPSetOperators(f->schur, f->S, f->S));
  PetscCall(DefaultDirect(f->schur));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTSFormsSetSecondOrder(MSimTSForms f, TS ts)
{
  SNES snes;
  KSP  ksp;

  PetscBool startup = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(InStartup(ts, PETSC_TRUE, &startup)); /* the user's parameters (after TSSetFromOptions) */
  f->startup_fix = (PetscBool)!startup;
  PetscCall(MSimSystemCreateMatrix(f->sys, &f->J2));
  PetscCall(TSSetI2Function(ts, NULL, I2Function, f));
  PetscCall(TSSetI2Jacobian(ts, f->J2, f->J2, I2Jacobian, f));
  PetscCall(TSGetSNES(ts, &snes));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(DefaultDirect(ksp));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTSFormsSetFromOptions(MSimTSForms f, TS ts)
{
  SNES      snes;
  KSP       ksp;
  PC        pc;
  PCType    pctype;
  PetscBool ntr, factor;

  PetscFunctionBeginUser;
  /* the user's -snes_*, -ksp_*, -pc_* options over the defaults set above */
  PetscCall(TSGetSNES(ts, &snes));
  PetscCall(SNESSetFromOptions(snes));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  /* what would otherwise stop inside PETSc with its own words ("Must call SNESSetObjective()",
     "MatSolverType mumps does not support matrix type nest"), said here with the options */
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESNTR, &ntr));
  PetscCheck(!ntr, PetscObjectComm((PetscObject)ts), PETSC_ERR_ARG_INCOMP, "-snes_type ntr minimizes an objective (the implicit schemes' incremental potential Phi), which -msim_integrator ts has none of (its TS solves F(t, U, U') = 0): use ntr with implicit_euler, bdf2, implicit_midpoint or newmark, or newtonls with ts");
  PetscCall(PCGetType(pc, &pctype));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &factor, PCLU, PCCHOLESKY, PCILU, PCICC, ""));
  PetscCheck(!(f->J && factor), PetscObjectComm((PetscObject)ts), PETSC_ERR_SUP, "-pc_type %s: the Jacobian of -ts_type beuler, theta, cn, bdf, rosw, arkimex and alpha is a nest of the [x; v] blocks, which no factorization takes: leave -pc_type unset (v eliminated exactly, then the positions' solve, MUMPS Cholesky by default, set with -ts_schur_pc_type and -ts_schur_pc_factor_mat_solver_type) or use -pc_type fieldsplit", pctype);
  if (f->schur) {
    PetscCall(KSPSetFromOptions(f->schur));
    PetscCall(MSimCheckFactorAvailable(f->schur, f->S));
  }
  if (f->J2) PetscCall(MSimCheckFactorAvailable(ksp, f->J2));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTSFormsView(MSimTSForms f, PetscViewer viewer)
{
  PetscFunctionBeginUser;
  PetscCall(PetscViewerASCIIPrintf(viewer, "ts: %" PetscInt_FMT " residual and %" PetscInt_FMT " analytic Jacobian evaluations (%s form)\n", f->nfunction, f->njacobian, f->J2 ? "second-order" : "first-order"));
  if (f->schur) {
    PetscCall(PetscViewerASCIIPushTab(viewer));
    PetscCall(KSPView(f->schur, viewer));
    PetscCall(PetscViewerASCIIPopTab(viewer));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimTSFormsDestroy(MSimTSForms *forms)
{
  MSimTSForms f = *forms;

  PetscFunctionBeginUser;
  if (!f) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(ISDestroy(&f->is_pos));
  PetscCall(ISDestroy(&f->is_mom));
  PetscCall(MatDestroy(&f->J));
  PetscCall(MatDestroy(&f->A00));
  PetscCall(MatDestroy(&f->A01));
  PetscCall(MatDestroy(&f->A10));
  PetscCall(MatDestroy(&f->A11));
  PetscCall(MatDestroy(&f->S));
  PetscCall(MatDestroy(&f->J2));
  PetscCall(KSPDestroy(&f->schur));
  PetscCall(VecDestroy(&f->rhs));
  PetscCall(VecDestroy(&f->work));
  PetscCall(PetscFree(*forms));
  PetscFunctionReturn(PETSC_SUCCESS);
}
