/* Implicit midpoint. With a = M^-1 f(x, v), f = f_s(x) - C v + f_e, the scheme
     x_{n+1} = x_n + h v_m,   v_{n+1} = v_n + h a(x_m, v_m),   x_m = (x_n + x_{n+1})/2, v_m = (v_n + v_{n+1})/2
   is solved for the midpoint x_m: v_m = (x_{n+1} - x_n)/h = 2 (x_m - x_n)/h and v_m = v_n + h/2 a, so
     x_m - x_n = h/2 v_n + h^2/4 a(x_m, v_m),
   i.e. M (x_m - y) = h^2/4 (f_s(x_m) - C v_m) with y = x_n + h/2 v_n + h^2/4 M^-1 f_e: Phi with
   beta = 1/4, and C v_m costs h^2/4 C 2 (x_m - x_n)/h = h/2 C (x_m - x_n): gamma = 1/2 from z = x_n.
   The dissipation term measures from the predictor p = x_n + h/2 v_n instead (spring damping's
   axes O(h^2) from x_m's), and y takes the rest, h^2/4 M^-1 f_d(p, u) with u = (p - z)/(h/2) = v_n
   (dissipation.cpp). The unknown is a state at t + h/2, so it and p see the handles at
   b(t + h/2) (tx = tref). Then x_{n+1} = 2 x_m - x_n and v_{n+1} = 2 v_m - v_n =
   4 (x_m - x_n)/h - v_n. First iterate x_n + h/2 v_n. No history beyond (x_n, v_n). Symplectic:
   without damping, drag and moving handles it keeps quadratic invariants and the energy of the
   springs bounded (no drift), where implicit Euler loses it.
   Predictor (-msim_implicit_guess extrapolate): the unknown's relation x_m = x_n + h/2 v_m =
   x_n + h/4 (v_n + v_{n+1}) at a predicted v_{n+1} = W: with W = 2 v_n - v_{n-1} (v_n + h a
   to O(h^2)) it is x_n + h/2 v_n + h^2/4 a + O(h^3), the solution's own expansion; exact under a
   constant acceleration. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

enum { PRED, WORK_F, WORK_W, NWORK }; /* scheme->work: the predictor p = x_n + h/2 v_n; work vectors */

static PetscErrorCode BeginStep_Midpoint(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  Vec *w = scheme->work;

  PetscFunctionBeginUser;
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecWAXPY(w[PRED], 0.5 * h, V, X));
  PetscCall(VecCopy(w[PRED], imp->Y));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, 0.25 * h * h, imp->Y));
  PetscCall(MSimImplicitAddDissipativeAcceleration(imp, 0.25 * h * h, t + 0.5 * h, w[PRED], V, w[WORK_F], w[WORK_W], imp->Y));
  PetscCall(MSimImplicitSetReference(imp, w[PRED], t + 0.5 * h, t + 0.5 * h));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* X holds x_m: v_{n+1} = 4 (x_m - x_n)/h - v_n, x_{n+1} = 2 x_m - x_n */
static PetscErrorCode EndStep_Midpoint(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPBYPCZ(V, 4.0 / imp->h, -4.0 / imp->h, -1.0, X, imp->Xn));
  PetscCall(VecAXPBY(X, -1.0, 2.0, imp->Xn));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* x_m = x_n + h/4 (v_n + W) */
static PetscErrorCode Predict_Midpoint(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec W, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecCopy(imp->Xn, X));
  PetscCall(VecAXPBYPCZ(X, 0.25 * imp->h, 0.25 * imp->h, 1.0, V, W));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* beta 1/4, gamma 1/2, first iterate x_n + h/2 v_n, no history; a barrier is refused (x_{n+1} =
   2 x_m - x_n went inside a box a cloth fell on) */
extern const MSimImplicitSchemeType MSimImplicitSchemeMidpoint = {0.25, 0.5, 0.5, NWORK, 0, "a barrier keeps the midpoint feasible, not x_{n+1} = 2 x_m - x_n", NULL, BeginStep_Midpoint, EndStep_Midpoint, Predict_Midpoint, PETSC_FALSE};
