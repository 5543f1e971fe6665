/* Implicit (backward) Euler in position form: y = x_n + h v_n + h^2 M^-1 f_ext, beta = 1, first
   iterate x_n + h v_n, v_{n+1} = (x_{n+1} - x_n)/h. Dissipative terms measure from x_n (gamma = 1:
   a viscous force -d v costs h d/2 |x - x_n|^2). No history beyond (x_n, v_n). */
#include <msim/implicit.h>
#include <msim/private/implicitimpl.h>

static PetscErrorCode BeginStep_Euler(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecWAXPY(imp->Y, h, V, X));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, h * h, imp->Y));
  imp->step.xref = imp->Xn;
  imp->step.tref = t;
  imp->step.tx   = t + h;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Guess_Euler(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPY(X, imp->h, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode EndStep_Euler(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPBYPCZ(V, 1.0 / imp->h, -1.0 / imp->h, 0.0, X, imp->Xn));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode GetHistory_Euler(MSimImplicitScheme scheme, PetscInt *n, Vec **history)
{
  PetscFunctionBeginUser;
  *n       = 0;
  *history = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSchemeCreate_Euler(MSimImplicitScheme scheme)
{
  PetscFunctionBeginUser;
  scheme->beta            = 1;
  scheme->gamma           = 1;
  scheme->ops.begin_step  = BeginStep_Euler;
  scheme->ops.guess       = Guess_Euler;
  scheme->ops.end_step    = EndStep_Euler;
  scheme->ops.get_history = GetHistory_Euler;
  PetscFunctionReturn(PETSC_SUCCESS);
}
