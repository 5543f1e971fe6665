/* Classical fourth-order Runge-Kutta on (x, v). Stable iff h omega_max <= 2 sqrt(2) without damping
   (the imaginary-axis extent of its stability region). */
#include <msim/integrator.h>

typedef struct {
  Vec Xs, Vs, A, dX, dV; /* stage state, stage acceleration, accumulated increments */
} RK4;

static PetscErrorCode Setup_RK4(MSimIntegrator integ)
{
  RK4 *rk = (RK4 *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(integ->sys->X0, &rk->Xs));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->Vs));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->A));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->dX));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->dV));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_RK4(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  RK4            *rk = (RK4 *)integ->data;
  const PetscReal h = integ->dt, c[4] = {0, 0.5, 0.5, 1}, w[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};

  PetscFunctionBeginUser;
  PetscCall(VecZeroEntries(rk->dX));
  PetscCall(VecZeroEntries(rk->dV));
  PetscCall(VecCopy(X, rk->Xs));
  PetscCall(VecCopy(V, rk->Vs));
  for (int s = 0; s < 4; s++) {
    /* stage s: k_x = Vs, k_v = a(Xs, Vs) */
    PetscCall(MSimSystemAcceleration(integ->sys, t + c[s] * h, rk->Xs, rk->Vs, rk->A));
    PetscCall(VecAXPY(rk->dX, w[s] * h, rk->Vs));
    PetscCall(VecAXPY(rk->dV, w[s] * h, rk->A));
    if (s < 3) {
      /* next stage state: X + c[s+1] h k_x, V + c[s+1] h k_v (Xs is rebuilt before Vs is overwritten) */
      PetscCall(VecWAXPY(rk->Xs, c[s + 1] * h, rk->Vs, X));
      PetscCall(VecWAXPY(rk->Vs, c[s + 1] * h, rk->A, V));
    }
  }
  PetscCall(VecAXPY(X, 1.0, rk->dX));
  PetscCall(VecAXPY(V, 1.0, rk->dV));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_RK4(MSimIntegrator integ)
{
  RK4 *rk = (RK4 *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&rk->Xs));
  PetscCall(VecDestroy(&rk->Vs));
  PetscCall(VecDestroy(&rk->A));
  PetscCall(VecDestroy(&rk->dX));
  PetscCall(VecDestroy(&rk->dV));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCreate_RK4(MSimIntegrator integ)
{
  RK4 *rk;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&rk));
  integ->data            = rk;
  integ->stability_limit = 2.0 * PETSC_SQRT2;
  integ->ops.setup       = Setup_RK4;
  integ->ops.step        = Step_RK4;
  integ->ops.destroy     = Destroy_RK4;
  PetscFunctionReturn(PETSC_SUCCESS);
}
