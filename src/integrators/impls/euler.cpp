/* The two first-order explicit integrators, which differ only in the order of their updates:
   - explicit_euler: x' = x + h v, v' = v + h a(x, v), both from the old state. Without damping it
     amplifies every mode by sqrt(1 + h^2 omega^2) per step: no step is stable.
   - symplectic_euler: v' = v + h a(x, v), x' = x + h v'. Stable iff h omega_max < 2 without
     damping; its energy error stays bounded (no drift). */
#include <msim/integrator.h>

typedef struct {
  Vec A; /* acceleration work vector */
} Euler;

static PetscErrorCode Setup_Euler(MSimIntegrator integ)
{
  Euler *e = (Euler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(integ->sys->X0, &e->A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_ExplicitEuler(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  Euler *e = (Euler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemAcceleration(integ->sys, t, X, V, e->A));
  PetscCall(VecAXPY(X, integ->dt, V));
  PetscCall(VecAXPY(V, integ->dt, e->A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_SymplecticEuler(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  Euler *e = (Euler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemAcceleration(integ->sys, t, X, V, e->A));
  PetscCall(VecAXPY(V, integ->dt, e->A));
  PetscCall(VecAXPY(X, integ->dt, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Euler(MSimIntegrator integ)
{
  Euler *e = (Euler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&e->A));
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
