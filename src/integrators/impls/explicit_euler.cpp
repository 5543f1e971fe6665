/* Forward (explicit) Euler: x' = x + h v, v' = v + h a(x, v), both from the old state. Without
   damping it amplifies every mode by sqrt(1 + h^2 omega^2) per step: no step is stable. */
#include <msim/integrator.h>

typedef struct {
  Vec A;
} ExplicitEuler;

static PetscErrorCode Setup_ExplicitEuler(MSimIntegrator integ)
{
  ExplicitEuler *ee = (ExplicitEuler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(integ->sys->X0, &ee->A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_ExplicitEuler(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  ExplicitEuler *ee = (ExplicitEuler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemAcceleration(integ->sys, t, X, V, ee->A));
  PetscCall(VecAXPY(X, integ->dt, V));
  PetscCall(VecAXPY(V, integ->dt, ee->A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_ExplicitEuler(MSimIntegrator integ)
{
  ExplicitEuler *ee = (ExplicitEuler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&ee->A));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCreate_ExplicitEuler(MSimIntegrator integ)
{
  ExplicitEuler *ee;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&ee));
  integ->data            = ee;
  integ->stability_limit = 0.0;
  integ->ops.setup       = Setup_ExplicitEuler;
  integ->ops.step        = Step_ExplicitEuler;
  integ->ops.destroy     = Destroy_ExplicitEuler;
  PetscFunctionReturn(PETSC_SUCCESS);
}
