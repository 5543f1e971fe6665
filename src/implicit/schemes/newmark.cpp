/* Newmark's average-acceleration (trapezoidal) rule, beta_N = 1/4, gamma_N = 1/2. With
   a = M^-1 f(x, v), f = f_s(x) - C v + f_e,
     x_{n+1} = x_n + h v_n + h^2/4 (a_n + a_{n+1}),   v_{n+1} = v_n + h/2 (a_n + a_{n+1}),
   a_{n+1} = a(x_{n+1}, v_{n+1}). The two give v_{n+1} = 2 (x_{n+1} - x_n)/h - v_n = (x - z)/(h/2) with
   z = x_n + h/2 v_n, and
     M (x - y) = h^2/4 (f_s(x) - C v_{n+1}),   y = x_n + h v_n + h^2/4 a_n + h^2/4 M^-1 f_e:
   Phi with beta = 1/4, and C v_{n+1} costs h^2/4 C 2 (x - z)/h = h/2 C (x - z): gamma = 1/2 from z.
   The dissipation term measures from the predictor p = x_n + h v_n instead (spring damping's axes
   O(h^2) from x_{n+1}'s; handles at b(t + h) like x's), and y takes the rest, h^2/4 M^-1 f_d(p, u)
   with u = (p - z)/(h/2) = v_n (dissipation.cpp). First iterate p. The start-of-step acceleration a_n is
   the history: at the start (or a restart without it) a_0 = M^-1 f(x_0, v_0), one force
   evaluation; after each step a_{n+1} = 4/h^2 (x_{n+1} - x_n - h v_n) - a_n, the scheme's own
   relation (equal to M^-1 f(x_{n+1}, v_{n+1}) where the step is solved exactly), which costs no
   force evaluation and keeps the recursion consistent with an inexact solve.
   Predictor (-msim_implicit_guess extrapolate): the position relation x_{n+1} = x_n + h/2 (v_n +
   v_{n+1}) (from v_{n+1} = 2 (x_{n+1} - x_n)/h - v_n) at a predicted v_{n+1} = W: with
   W = 2 v_n - v_{n-1} it is x_n + h v_n + h/2 (v_n - v_{n-1}) = x_n + h v_n + h^2/2 a + O(h^3),
   the solution's own expansion (x_n + h v_n + h^2/4 (a_n + a_{n+1})); exact under a constant
   acceleration. (a_n, the recursion's, would serve as well where the solve is exact; an
   unconverged solve leaves its error in a_n with a factor -1 per step, which v_n - v_{n-1}
   averages.) */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

/* scheme->work: a_n (the history, valid when scheme->history_valid); the predictor p = x_n + h v_n,
   the dissipation's reference; v_n, for the velocity update; two work vectors */
enum { ACC, PRED, V_N, WORK_F, WORK_W, NWORK };

static PetscErrorCode BeginStep_Newmark(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  Vec *w = scheme->work;

  PetscFunctionBeginUser;
  if (!scheme->history_valid) PetscCall(MSimSystemAcceleration(imp->sys, t, X, V, w[ACC]));
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecCopy(V, w[V_N]));
  PetscCall(VecWAXPY(w[PRED], h, V, X));
  /* y = x_n + h v_n + h^2/4 a_n + h^2/4 M^-1 (f_e + f_d(p, v_n)) */
  PetscCall(VecWAXPY(imp->Y, 0.25 * h * h, w[ACC], w[PRED]));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, 0.25 * h * h, imp->Y));
  PetscCall(MSimImplicitAddDissipativeAcceleration(imp, 0.25 * h * h, t + h, w[PRED], V, w[WORK_F], w[WORK_W], imp->Y));
  PetscCall(MSimImplicitSetReference(imp, w[PRED], t + h, t + h));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* a_{n+1} = 4/h^2 (x_{n+1} - x_n - h v_n) - a_n, then v_{n+1} = 2 (x_{n+1} - x_n)/h - v_n */
static PetscErrorCode EndStep_Newmark(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  Vec            *w = scheme->work;
  const PetscReal h = imp->h;

  PetscFunctionBeginUser;
  PetscCall(VecAXPBYPCZ(w[ACC], 4.0 / (h * h), -4.0 / (h * h), -1.0, X, imp->Xn));
  PetscCall(VecAXPY(w[ACC], -4.0 / h, w[V_N]));
  PetscCall(VecAXPBYPCZ(V, 2.0 / h, -2.0 / h, -1.0, X, imp->Xn));
  scheme->history_valid = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* x = x_n + h/2 (v_n + W) */
static PetscErrorCode Predict_Newmark(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec W, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecCopy(imp->Xn, X));
  PetscCall(VecAXPBYPCZ(X, 0.5 * imp->h, 0.5 * imp->h, 1.0, V, W));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* beta 1/4, gamma 1/2, first iterate x_n + h v_n; restarts need a_n; a barrier is refused (a cloth
   dropped on a box diverged: nothing damps the recursions' response to the barrier) */
extern const MSimImplicitSchemeType MSimImplicitSchemeNewmark = {0.25, 0.5, 1, NWORK, 1, "its trapezoidal velocity and acceleration recursions ring on a barrier's stiff response and diverge", NULL, BeginStep_Newmark, EndStep_Newmark, Predict_Newmark, PETSC_FALSE};
