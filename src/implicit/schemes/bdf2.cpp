/* BDF2 in position form. With a = M^-1 f(x, v), f = f_s(x) - C v + f_e (springs, the damping and
   drag matrix C, the constant gravity and wind), the scheme
     x_{n+1} - 4/3 x_n + 1/3 x_{n-1} = 2/3 h v_{n+1},   v_{n+1} - 4/3 v_n + 1/3 v_{n-1} = 2/3 h a_{n+1}
   gives, with xh = 4/3 x_n - 1/3 x_{n-1} and vh = 4/3 v_n - 1/3 v_{n-1},
     v_{n+1} = 3 (x - xh) / (2 h),   x - xh = 2/3 h vh + 4/9 h^2 a(x, v_{n+1}),
   i.e. M (x - y) = 4/9 h^2 (f_s(x) - C v_{n+1}) with y = xh + 2/3 h vh + 4/9 h^2 M^-1 f_e: the
   minimization of Phi with beta = 4/9, and C v_{n+1} costs 4/9 h^2 C 3 (x - xh)/(2 h) = 2/3 h C (x - xh):
   dissipation weight gamma = 2/3 from z = xh. The dissipation term measures from the predictor
   p = x_n + h v_n instead (spring damping's axes O(h^2) from x_{n+1}'s; handles at b(t + h) like
   x's), and y takes the rest, 4/9 h^2 M^-1 f_d(p, u) with u = 3 (p - xh)/(2 h) (dissipation.cpp).
   First iterate p.
   Start-up (the first step, or a restart without this scheme's history): one step of
     x_1 = x_0 + h v_0 + h^2/2 a_e + 4/9 h^2 (a_1 - a_e),   v_1 = v_0 + h a_1,
   with a_1 the acceleration of the solve and a_e = M^-1 f_e the constant external one. It is the
   BDF2 solve above with the past state x_{-1} = x_0 - h v_0, v_{-1} = v_0 (then xh = x_0 + h/3 v_0,
   vh = v_0, y = x_0 + h v_0 + 4/9 h^2 a_e, u = v_0) and h^2/18 a_e more in y: the same beta and
   gamma, hence PD's factor; the velocity update is v_1 = v_0 + 9 (x_1 - x_0 - h v_0 - h^2/18 a_e)
   / (4 h) in place of 3 (x_1 - xh) / (2 h). The h^2/18 a_e makes the start exact under a constant
   acceleration a_e (free fall), which BDF2 then keeps exact: without it x_1 was h^2/18 a_e short,
   and the position relation x_{n+1} = 4/3 x_n - 1/3 x_{n-1} + 2/3 h v_{n+1} (v_n exact) carries
   an error e_n on a mode no force restores (a free body's translation) as e_{n+1} = 4/3 e_n -
   1/3 e_{n-1}, to 3/2 e_1 = -h^2/12 a_e for good (a falling cloth 8.2e-5 m behind at h = 0.01,
   its monitored energy up by M g^2 h^2/12 = 8.0e-4 J). a_e is constant: the step's response to
   the state, and so its stability below, are unchanged (an a_0 = M^-1 f(x_0, v_0) in its place
   would bring back the Taylor past state's growth). Its local errors are O(h^2) in x_1
   (-h^2/18 (a_0 - a_e)) and in v_1 (h^2/2 a'_0), made once: a zero-stable
   two-step method started from values with O(h^2) errors stays second order (the usual BDF2
   start by one implicit Euler step, with BDF2's beta). It needs no force at (x_0, v_0) and is
   stable on modes the step does not resolve: on an undamped linear mode of frequency w, with
   theta = h w, (w x_1, v_1) = [[1, theta], [-theta, 1 - 5/9 theta^2]] (w x_0, v_0) / (1 + 4/9 theta^2),
   whose norm is below 5/4 for every theta (BDF2 then damps such modes). The Taylor past state
   used before, x_{-1} = x_0 - h v_0 + h^2/2 a_0, v_{-1} = v_0 - h a_0 with a_0 = M^-1 f(x_0, v_0),
   is second order too but multiplies such a mode by about theta/4: tests/order.py's chain with its
   vertices displaced by 1 cm, undamped, ended step 1 with 2.3 x its energy at h w_max = 5.8 and
   was stopped as diverged at 17 (runs/speed_accuracy/bdf2_startup.py; now 0.21 and 0.029 x); the
   external acceleration alone in its
   place left v_1 an O(h) error (v_{-1} off by h (a_0 - a_e)) and first order.
   History for an exact restart: x_{n-1}, v_{n-1}.
   Predictor (-msim_implicit_guess extrapolate): the position relation x_{n+1} = xh + 2/3 h v_{n+1}
   at a predicted v_{n+1} = W (start-up: x_1 = x_0 + h v_0 + h^2/18 a_e + 4/9 h (v_1 - v_0), from
   its velocity update). With W = 2 v_n - v_{n-1} = v_n + h a + O(h^2), and along a smooth discrete solution
   xh = x_n + h/3 v_n - h^2/6 a + O(h^3), it is x_n + h v_n + h^2/2 a + O(h^3), the solution's own
   expansion (xh + 2/3 h vh + 4/9 h^2 a with vh = v_n + h/3 a). Under a constant acceleration the
   velocities are exactly linear in n from the start-up on (v_1 = v_0 + h a), so W is v_{n+1}
   and the first iterate is the step's solution. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

/* scheme->work: x_{n-1}, v_{n-1} (the history, valid when scheme->history_valid); xh and v_n, kept
   for the velocity update; the predictor p = x_n + h v_n (the dissipation's reference) and
   u = 3 (p - xh)/(2 h); two work vectors. The start-up step is the one taken while
   scheme->history_valid is false (EndStep sets it), with its own velocity update. */
enum { X_PREV, V_PREV, X_HAT, V_N, PRED, U_PRED, WORK_F, WORK_W, NWORK };

static PetscErrorCode BeginStep_BDF2(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  Vec *w = scheme->work;

  PetscFunctionBeginUser;
  if (!scheme->history_valid) { /* start-up: the past state x_{-1} = x_0 - h v_0, v_{-1} = v_0 */
    PetscCall(VecWAXPY(w[X_PREV], -h, V, X));
    PetscCall(VecCopy(V, w[V_PREV]));
  }
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecCopy(V, w[V_N]));
  PetscCall(VecAXPBYPCZ(w[X_HAT], 4.0 / 3.0, -1.0 / 3.0, 0.0, X, w[X_PREV]));
  /* y = xh + 2/3 h (4/3 v_n - 1/3 v_{n-1}) + 4/9 h^2 M^-1 f_e */
  PetscCall(VecCopy(w[X_HAT], imp->Y));
  PetscCall(VecAXPBYPCZ(imp->Y, 8.0 / 9.0 * h, -2.0 / 9.0 * h, 1.0, V, w[V_PREV]));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, (scheme->history_valid ? 4.0 / 9.0 : 0.5) * h * h, imp->Y)); /* start-up: h^2/18 a_e more */
  PetscCall(VecWAXPY(w[PRED], h, V, X));
  if (imp->sys->damping > 0 || imp->sys->drag > 0) {
    PetscCall(VecAXPBYPCZ(w[U_PRED], 1.5 / h, -1.5 / h, 0.0, w[PRED], w[X_HAT]));
    PetscCall(MSimImplicitAddDissipativeAcceleration(imp, 4.0 / 9.0 * h * h, t + h, w[PRED], w[U_PRED], w[WORK_F], w[WORK_W], imp->Y));
  }
  PetscCall(MSimImplicitSetReference(imp, w[PRED], t + h, t + h));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* v_{n+1} = 3 (x_{n+1} - xh) / (2 h) (start-up: v_0 + h a_1); (x_n, v_n) become the history */
static PetscErrorCode EndStep_BDF2(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  Vec *w = scheme->work;

  PetscFunctionBeginUser;
  if (!scheme->history_valid) { /* start-up: v_0 + 9 (x_1 - x_0 - h v_0 - h^2/18 a_e) / (4 h) */
    PetscCall(VecAXPBYPCZ(V, 2.25 / imp->h, -2.25 / imp->h, 0.0, X, imp->Xn));
    PetscCall(VecAXPY(V, -1.25, w[V_N]));
    PetscCall(MSimImplicitAddExternalAcceleration(imp, -imp->h / 8, V));
  } else PetscCall(VecAXPBYPCZ(V, 1.5 / imp->h, -1.5 / imp->h, 0.0, X, w[X_HAT]));
  PetscCall(VecCopy(imp->Xn, w[X_PREV]));
  PetscCall(VecCopy(w[V_N], w[V_PREV]));
  scheme->history_valid = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* x = xh + 2/3 h W (start-up: x_0 + 5/9 h v_0 + 4/9 h W + h^2/18 a_e) */
static PetscErrorCode Predict_BDF2(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec W, Vec X)
{
  Vec *w = scheme->work;

  PetscFunctionBeginUser;
  if (!scheme->history_valid) {
    PetscCall(VecCopy(imp->Xn, X));
    PetscCall(VecAXPBYPCZ(X, 5.0 / 9.0 * imp->h, 4.0 / 9.0 * imp->h, 1.0, V, W));
    PetscCall(MSimImplicitAddExternalAcceleration(imp, imp->h * imp->h / 18, X));
  } else PetscCall(VecWAXPY(X, 2.0 / 3.0 * imp->h, W, w[X_HAT]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* beta 4/9, gamma 2/3, first iterate x_n + h v_n; restarts need x_{n-1}, v_{n-1} */
extern const MSimImplicitSchemeType MSimImplicitSchemeBDF2 = {4.0 / 9.0, 2.0 / 3.0, 1, NWORK, 2, NULL, NULL, BeginStep_BDF2, EndStep_BDF2, Predict_BDF2, PETSC_TRUE};
