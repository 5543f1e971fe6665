/* Implicit (backward) Euler in position form: y = x_n + h v_n + h^2 M^-1 f_ext, beta = 1, first
   iterate x_n + h v_n, v_{n+1} = (x_{n+1} - x_n)/h. Dissipative terms measure from x_n (gamma = 1:
   a viscous force -d v costs h d/2 |x - x_n|^2). No history beyond (x_n, v_n).
   Predictor (-msim_implicit_guess extrapolate): the position relation x_{n+1} = x_n + h v_{n+1}
   at a predicted v_{n+1} = W. With W = 2 v_n - v_{n-1} = v_n + h a_n (the scheme's own
   v_n - v_{n-1} = h a_n) the first iterate is x_n + h v_n + h^2 a_n, and the solution is
   x_n + h v_n + h^2 a_{n+1}: an O(h^3) error where x_n + h v_n leaves h^2 a_{n+1}; exact under a
   constant acceleration. */
#include <msim/implicit.h>
#include <msim/private/implicitimpl.h>

static PetscErrorCode BeginStep_Euler(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecWAXPY(imp->Y, h, V, X));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, h * h, imp->Y));
  PetscCall(MSimImplicitSetReference(imp, imp->Xn, t, t + h));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode EndStep_Euler(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPBYPCZ(V, 1.0 / imp->h, -1.0 / imp->h, 0.0, X, imp->Xn));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* x = x_n + h W */
static PetscErrorCode Predict_Euler(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec W, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecWAXPY(X, imp->h, W, imp->Xn));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* beta 1, gamma 1, first iterate x_n + h v_n, no vectors kept */
extern const MSimImplicitSchemeType MSimImplicitSchemeEuler = {1, 1, 1, 0, 0, NULL, NULL, BeginStep_Euler, EndStep_Euler, Predict_Euler, PETSC_FALSE};
