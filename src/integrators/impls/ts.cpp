/* Hands each step to a PETSc TS on U = [x; v] (each rank: its 3 nown positions, then velocities).
   -ts_type rk -ts_rk_type 4 -ts_adapt_type none is RK4; -ts_type basicsymplectic
   -ts_basicsymplectic_type 1 is symplectic Euler through the "position"/"momentum" splits. */
#include <msim/integrator.h>

typedef struct {
  TS  ts;
  Vec U, A;
  IS  is_pos, is_mom;
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

static PetscErrorCode Setup_TS(MSimIntegrator integ)
{
  TSInteg   *d   = (TSInteg *)integ->data;
  MSimSystem sys = integ->sys;

  PetscFunctionBeginUser;
  PetscCall(VecCreateMPI(integ->comm, 6 * sys->nown, 6 * sys->nfree, &d->U));
  PetscCall(ISCreateStride(integ->comm, 3 * sys->nown, 6 * sys->rstart, 1, &d->is_pos));
  PetscCall(ISCreateStride(integ->comm, 3 * sys->nown, 6 * sys->rstart + 3 * sys->nown, 1, &d->is_mom));
  PetscCall(TSCreate(integ->comm, &d->ts));
  PetscCall(TSSetProblemType(d->ts, TS_NONLINEAR));
  PetscCall(TSSetType(d->ts, TSRK));
  PetscCall(TSRKSetType(d->ts, TSRK4));
  PetscCall(TSSetRHSFunction(d->ts, NULL, RHS_Full, integ));
  PetscCall(TSRHSSplitSetIS(d->ts, "position", d->is_pos));
  PetscCall(TSRHSSplitSetIS(d->ts, "momentum", d->is_mom));
  PetscCall(TSRHSSplitSetRHSFunction(d->ts, "position", NULL, RHS_Position, integ));
  PetscCall(TSRHSSplitSetRHSFunction(d->ts, "momentum", NULL, RHS_Momentum, integ));
  PetscCall(TSSetTimeStep(d->ts, integ->dt));
  PetscCall(TSSetMaxSteps(d->ts, PETSC_MAX_INT - 1)); /* msim drives the steps one TSStep at a time; PETSC_MAX_INT reads as unset */
  PetscCall(TSSetMaxTime(d->ts, PETSC_MAX_REAL));
  PetscCall(TSSetSolution(d->ts, d->U));
  PetscCall(TSSetFromOptions(d->ts));
  {
    TSType    type;
    PetscBool symp;
    PetscCall(TSGetType(d->ts, &type));
    PetscCall(PetscStrcmp(type, TSBASICSYMPLECTIC, &symp));
    PetscBool rk, euler;
    PetscCall(PetscStrcmp(type, TSRK, &rk));
    PetscCall(PetscStrcmp(type, TSEULER, &euler));
    /* stability limits for the guard, where the type has a known one */
    if (symp) integ->stability_limit = 2.0;
    if (euler) integ->stability_limit = 0.0;
    if (rk) {
      TSRKType rktype;
      PetscCall(TSRKGetType(d->ts, &rktype));
      if (!strcmp(rktype, TSRK4)) integ->stability_limit = 2.0 * PETSC_SQRT2;
    }
    PetscCheck(!symp || (sys->damping == 0 && sys->drag == 0), integ->comm, PETSC_ERR_ARG_INCOMP, "-ts_type basicsymplectic needs forces independent of velocity: set -msim_damping 0 -msim_drag 0");
  }
  PetscCall(TSSetUp(d->ts));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_TS(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  TSInteg *d = (TSInteg *)integ->data;
  Vec      Ux, Uv;

  PetscFunctionBeginUser;
  PetscCall(VecGetSubVector(d->U, d->is_pos, &Ux));
  PetscCall(VecCopy(X, Ux));
  PetscCall(VecRestoreSubVector(d->U, d->is_pos, &Ux));
  PetscCall(VecGetSubVector(d->U, d->is_mom, &Uv));
  PetscCall(VecCopy(V, Uv));
  PetscCall(VecRestoreSubVector(d->U, d->is_mom, &Uv));
  PetscCall(TSSetTime(d->ts, t));
  PetscCall(TSSetTimeStep(d->ts, integ->dt));
  PetscCall(TSStep(d->ts));
  {
    PetscReal tn;
    PetscCall(TSGetTime(d->ts, &tn));
    PetscCheck(PetscAbsReal(tn - (t + integ->dt)) <= 1e-12 * PetscMax(1.0, PetscAbsReal(tn)), integ->comm, PETSC_ERR_ARG_INCOMP, "the TS changed the step (t %g, expected %g): use a fixed-step TS, e.g. -ts_adapt_type none", (double)tn, (double)(t + integ->dt));
  }
  PetscCall(VecGetSubVector(d->U, d->is_pos, &Ux));
  PetscCall(VecCopy(Ux, X));
  PetscCall(VecRestoreSubVector(d->U, d->is_pos, &Ux));
  PetscCall(VecGetSubVector(d->U, d->is_mom, &Uv));
  PetscCall(VecCopy(Uv, V));
  PetscCall(VecRestoreSubVector(d->U, d->is_mom, &Uv));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_TS(MSimIntegrator integ, PetscViewer viewer)
{
  TSInteg *d = (TSInteg *)integ->data;
  PetscFunctionBeginUser;
  if (d->ts) PetscCall(TSView(d->ts, viewer));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_TS(MSimIntegrator integ)
{
  TSInteg *d = (TSInteg *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(TSDestroy(&d->ts));
  PetscCall(VecDestroy(&d->U));
  PetscCall(ISDestroy(&d->is_pos));
  PetscCall(ISDestroy(&d->is_mom));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCreate_TS(MSimIntegrator integ)
{
  TSInteg *d;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&d));
  integ->data        = d;
  integ->ops.setup   = Setup_TS;
  integ->ops.step    = Step_TS;
  integ->ops.view    = View_TS;
  integ->ops.destroy = Destroy_TS;
  PetscFunctionReturn(PETSC_SUCCESS);
}
