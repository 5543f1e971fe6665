/* Symplectic (semi-implicit) Euler: v' = v + h a(x, v), x' = x + h v'. Stable iff h omega_max < 2
   without damping; its energy error stays bounded (no drift). */
#include <msim/integrator.h>

typedef struct {
  Vec A;
} SymplecticEuler;

static PetscErrorCode Setup_SymplecticEuler(MSimIntegrator integ)
{
  SymplecticEuler *se = (SymplecticEuler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(integ->sys->X0, &se->A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_SymplecticEuler(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  SymplecticEuler *se = (SymplecticEuler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemAcceleration(integ->sys, t, X, V, se->A));
  PetscCall(VecAXPY(V, integ->dt, se->A));
  PetscCall(VecAXPY(X, integ->dt, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_SymplecticEuler(MSimIntegrator integ)
{
  SymplecticEuler *se = (SymplecticEuler *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&se->A));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCreate_SymplecticEuler(MSimIntegrator integ)
{
  SymplecticEuler *se;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&se));
  integ->data            = se;
  integ->stability_limit = 2.0;
  integ->ops.setup       = Setup_SymplecticEuler;
  integ->ops.step        = Step_SymplecticEuler;
  integ->ops.destroy     = Destroy_SymplecticEuler;
  PetscFunctionReturn(PETSC_SUCCESS);
}
