/* Classical fourth-order Runge-Kutta on (x, v). Stable iff h omega_max <= 2 sqrt(2) without damping
   (the imaginary-axis extent of its stability region). */
#include <msim/integrator.h>
#include <msim/private/integratorimpl.h>
#include <msim/private/systemimpl.h>
#include <msim/destroy.h>

typedef struct {
  Vec Xs, Vs, F, dX, dV; /* stage state, stage force, accumulated increments */
} RK4;

static PetscErrorCode Setup_RK4(MSimIntegrator integ)
{
  RK4 *rk = (RK4 *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(integ->sys->X0, &rk->Xs));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->Vs));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->F));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->dX));
  PetscCall(VecDuplicate(integ->sys->X0, &rk->dV));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* One stage's pass over the rows, a = F / m: the increments gain w h (k_x, k_v), and the next stage
   state is (x, v) + c h (k_x, k_v); after the last stage the state takes the increments. Stage 0's
   k_x is v itself. Separate arrays (restrict) let the compiler vectorize. */
static void RK4Rows(PetscInt n, int s, PetscReal wh, PetscReal ch, const PetscReal *PETSC_RESTRICT f, const PetscReal *PETSC_RESTRICT minv, PetscReal *PETSC_RESTRICT x, PetscReal *PETSC_RESTRICT v, PetscReal *PETSC_RESTRICT xs, PetscReal *PETSC_RESTRICT vs, PetscReal *PETSC_RESTRICT dx, PetscReal *PETSC_RESTRICT dv)
{
  if (s == 0)
    for (PetscInt i = 0; i < n; i++) {
      const PetscReal a = minv[i] * f[i];
      dx[i]             = wh * v[i];
      dv[i]             = wh * a;
      xs[i]             = x[i] + ch * v[i];
      vs[i]             = v[i] + ch * a;
    }
  else if (s < 3)
    for (PetscInt i = 0; i < n; i++) {
      const PetscReal a = minv[i] * f[i];
      dx[i] += wh * vs[i];
      dv[i] += wh * a;
      xs[i] = x[i] + ch * vs[i]; /* before vs is overwritten */
      vs[i] = v[i] + ch * a;
    }
  else
    for (PetscInt i = 0; i < n; i++) {
      const PetscReal a = minv[i] * f[i];
      x[i] += dx[i] + wh * vs[i];
      v[i] += dv[i] + wh * a;
    }
}

/* Each stage is the force at the stage state, then one pass over the rows (RK4Rows). Written as
   Vec operations (a copy, a product by 1/m, two AXPYs and two WAXPYs a stage) the
   passes took 37% of a cloth's step. Stage 0 is the state itself: no copies. */
static PetscErrorCode Step_RK4(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  RK4            *rk = (RK4 *)integ->data;
  const PetscReal h = integ->dt, c[4] = {0, 0.5, 0.5, 1}, w[4] = {1.0 / 6, 1.0 / 3, 1.0 / 3, 1.0 / 6};
  Vec             massinv;
  PetscInt        n;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGetInverseMass(integ->sys, &massinv));
  PetscCall(VecGetLocalSize(X, &n));
  for (int s = 0; s < 4; s++) {
    const PetscScalar *f, *minv;
    PetscScalar       *x, *v, *xs, *vs, *dx, *dv;
    const PetscReal    wh = w[s] * h, ch = s < 3 ? c[s + 1] * h : 0;

    /* k_x = Vs, k_v = a(Xs, Vs) */
    PetscCall(MSimSystemComputeForce(integ->sys, t + c[s] * h, s ? rk->Xs : X, s ? rk->Vs : V, rk->F));
    PetscCall(VecGetArrayRead(rk->F, &f));
    PetscCall(VecGetArrayRead(massinv, &minv));
    PetscCall(VecGetArray(X, &x));
    PetscCall(VecGetArray(V, &v));
    PetscCall(VecGetArray(rk->Xs, &xs));
    PetscCall(VecGetArray(rk->Vs, &vs));
    PetscCall(VecGetArray(rk->dX, &dx));
    PetscCall(VecGetArray(rk->dV, &dv));
    RK4Rows(n, s, wh, ch, f, minv, x, v, xs, vs, dx, dv);
    PetscCall(VecRestoreArray(rk->dV, &dv));
    PetscCall(VecRestoreArray(rk->dX, &dx));
    PetscCall(VecRestoreArray(rk->Vs, &vs));
    PetscCall(VecRestoreArray(rk->Xs, &xs));
    PetscCall(VecRestoreArray(V, &v));
    PetscCall(VecRestoreArray(X, &x));
    PetscCall(VecRestoreArrayRead(massinv, &minv));
    PetscCall(VecRestoreArrayRead(rk->F, &f));
    PetscCall(PetscLogFlops(9.0 * n));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_RK4(MSimIntegrator integ)
{
  RK4 *rk = (RK4 *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimDestroy(&rk->Xs, &rk->Vs, &rk->F, &rk->dX, &rk->dV));
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
