/* The two first-order explicit integrators, which differ only in the order of their updates:
   - explicit_euler: x' = x + h v, v' = v + h a(x, v), both from the old state. Without damping it
     amplifies every mode by sqrt(1 + h^2 omega^2) per step: no step is stable.
   - symplectic_euler: v' = v + h a(x, v), x' = x + h v'. Stable iff h omega_max < 2 without
     damping; its energy error stays bounded (no drift). */
#include <msim/integrator.h>
#include <msim/private/integratorimpl.h>
#include <msim/private/systemimpl.h>

typedef struct {
  Vec F; /* force work vector */
} Euler;

static PetscErrorCode Setup_Euler(MSimIntegrator integ)
{
  Euler *e = (Euler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(integ->sys->X0, &e->F));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The force, then both updates in one pass over the rows (three Vec operations, a = F / m and two
   AXPYs, took a third of a cloth's step: PETSc's pointwise division tests each divisor and does
   not vectorize). symplectic: x moves with the new velocity, else with the old. */
static PetscErrorCode Step_Euler(MSimIntegrator integ, PetscReal t, Vec X, Vec V, PetscBool symplectic)
{
  Euler             *e = (Euler *)integ->data;
  const PetscReal    h = integ->dt;
  const PetscScalar *f, *minv;
  PetscScalar       *x, *v;
  PetscInt           n;
  Vec                massinv;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGetInverseMass(integ->sys, &massinv));
  PetscCall(MSimSystemComputeForce(integ->sys, t, X, V, e->F));
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArrayRead(e->F, &f));
  PetscCall(VecGetArrayRead(massinv, &minv));
  PetscCall(VecGetArray(X, &x));
  PetscCall(VecGetArray(V, &v));
  if (symplectic)
    for (PetscInt i = 0; i < n; i++) {
      v[i] += h * minv[i] * f[i];
      x[i] += h * v[i];
    }
  else
    for (PetscInt i = 0; i < n; i++) {
      x[i] += h * v[i];
      v[i] += h * minv[i] * f[i];
    }
  PetscCall(VecRestoreArray(V, &v));
  PetscCall(VecRestoreArray(X, &x));
  PetscCall(VecRestoreArrayRead(massinv, &minv));
  PetscCall(VecRestoreArrayRead(e->F, &f));
  PetscCall(PetscLogFlops(5.0 * n));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_ExplicitEuler(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(Step_Euler(integ, t, X, V, PETSC_FALSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_SymplecticEuler(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(Step_Euler(integ, t, X, V, PETSC_TRUE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Euler(MSimIntegrator integ)
{
  Euler *e = (Euler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&e->F));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MSimIntegratorCreate_Euler(MSimIntegrator integ, PetscErrorCode (*step)(MSimIntegrator, PetscReal, Vec, Vec), PetscReal stability_limit)
{
  Euler *e;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&e));
  integ->data            = e;
  integ->stability_limit = stability_limit;
  integ->ops.setup       = Setup_Euler;
  integ->ops.step        = step;
  integ->ops.destroy     = Destroy_Euler;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCreate_ExplicitEuler(MSimIntegrator integ)
{
  PetscFunctionBeginUser;
  PetscCall(MSimIntegratorCreate_Euler(integ, Step_ExplicitEuler, 0.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCreate_SymplecticEuler(MSimIntegrator integ)
{
  PetscFunctionBeginUser;
  PetscCall(MSimIntegratorCreate_Euler(integ, Step_SymplecticEuler, 2.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
