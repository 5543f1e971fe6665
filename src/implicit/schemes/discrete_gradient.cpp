/* Energy-conserving discrete-gradient scheme (Gonzalez 1996, J. Nonlinear Sci. 6: time integration
   and discrete Hamiltonian systems). With E the spring energy, gradbar E(x_n, x) a discrete gradient
   (gradbar . (x - x_n) = E(x) - E(x_n) exactly, gradbar -> grad E(x_m) as x -> x_n; each term gives
   its own, springs.cpp's discrete_gradient), f_e the constant external force (gravity, the wind's
   c w) and C_p the damping and drag matrix with spring axes at a midpoint predictor,
     x_{n+1} = x_n + h v_m,   M (v_{n+1} - v_n) = h (f_e - gradbar E(x_n, x_{n+1}) - C_p v_m),
   v_m = (v_n + v_{n+1})/2 = (x_{n+1} - x_n)/h. Eliminating v_{n+1} = 2 (x - x_n)/h - v_n:
     r(x) = M (x - y) + h^2/2 gradbar E(x_n, x) + h/2 C_p (x - x_n) = 0,
     y = x_n + h v_n + h^2/2 M^-1 f_e:
   beta = 1/2 for the potentials and gamma = 1/2 from z = x_n for the dissipation, unknown x_{n+1}.
   Energy: dot the momentum equation with v_m; the kinetic energy changes by
   h v_m . (f_e - gradbar - C_p v_m) = -(V_e(x) - V_e(x_n)) - (E(x) - E(x_n)) - h v_m^T C_p v_m for
   the linear potential V_e = -f_e . x, so the total energy is conserved exactly without damping,
   drag or moving handles, and otherwise falls by h v_m^T C_p v_m >= 0 (C_p is PSD): never rises.
   What the solver leaves in r changes it by exactly (2/h) v_m . r per step (r = h/2 times the
   momentum equation's imbalance): energy is conserved to the solver's tolerance. Second order:
   undamped, the scheme is symmetric (swap n and n+1, h -> -h) and consistent; the damping's axes
   below are O(h^2) from the midpoint's, which keeps it so (tests/energy_conserving.py).
   r is not the gradient of any function (gradbar's Jacobian, d gradbar / dx, is not symmetric), so
   the scheme sets no_objective: the problem asks the terms for their discrete gradients and exact
   (nonsymmetric) Jacobians, and the step is Newton with GMRES or LU and a residual-norm line search.
   The dissipation is taken at the midpoint velocity itself, v_m = (x - x_n)/h, handles included:
   spring damping h/2 kd n n^T (A_s x - A_s x_n) with A_s x at b(t + h) and A_s x_n at b(t) (the
   springs' discrete_gradient op), its axes n those of the midpoint predictor p = x_n + h/2 v_n
   with the handles at b(t + h/2), O(h^2) from the midpoint's as second order needs (axes from x_n
   or from p with the handles at b(t + h) made the damped cloth with moving handles first order);
   drag through the drag term hd c/2 |x - p|^2 (hd = h/2) with y taking the rest, h/2 c (p - x_n)
   = h^2/2 c v_n/2, so the two sum to h/2 c (x - x_n). One C_p for the whole step, so the damping
   stays exactly dissipative. The unknown is x_{n+1}, at b(t + h); x_n is seen with b(t), so a
   spring to a handle gets the discrete gradient between its two true states. First iterate
   x_n + h v_n. No history beyond (x_n, v_n): a checkpoint holds all a restart needs.
   Predictor (-msim_implicit_guess extrapolate): x_{n+1} = x_n + h/2 (v_n + v_{n+1}) at a predicted
   v_{n+1} = W = 2 v_n - v_{n-1}: x_n + h v_n + h^2/2 a + O(h^3), as Newmark's; exact under a
   constant acceleration. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

enum { PRED, NWORK }; /* scheme->work: the midpoint predictor p = x_n + h/2 v_n: the damping's axes, the drag's reference */

static PetscErrorCode BeginStep_DG(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  Vec *w = scheme->work;

  PetscFunctionBeginUser;
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecWAXPY(w[PRED], 0.5 * h, V, X));
  /* y = x_n + h v_n + h^2/2 M^-1 f_e - h^2/4 M^-1 c v_n */
  PetscCall(VecWAXPY(imp->Y, h, V, X));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, 0.5 * h * h, imp->Y));
  if (imp->sys->drag > 0) {
    PetscScalar       *y;
    const PetscScalar *v, *m;
    PetscCall(VecGetArray(imp->Y, &y));
    PetscCall(VecGetArrayRead(V, &v));
    PetscCall(VecGetArrayRead(imp->sys->mass, &m));
    for (PetscInt i = 0; i < 3 * imp->sys->nown; i++) y[i] -= 0.25 * h * h * imp->sys->drag * v[i] / m[i];
    PetscCall(VecRestoreArrayRead(imp->sys->mass, &m));
    PetscCall(VecRestoreArrayRead(V, &v));
    PetscCall(VecRestoreArray(imp->Y, &y));
  }
  PetscCall(MSimImplicitSetReference(imp, w[PRED], t + 0.5 * h, t + h));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* X holds x_{n+1}, V still v_n: v_{n+1} = 2 (x_{n+1} - x_n)/h - v_n */
static PetscErrorCode EndStep_DG(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPBYPCZ(V, 2.0 / imp->h, -2.0 / imp->h, -1.0, X, imp->Xn));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* x = x_n + h/2 (v_n + W) */
static PetscErrorCode Predict_DG(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec W, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecCopy(imp->Xn, X));
  PetscCall(VecAXPBYPCZ(X, 0.5 * imp->h, 0.5 * imp->h, 1.0, V, W));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* beta 1/2, gamma 1/2, first iterate x_n + h v_n, no history; the step is a residual (no
   objective), so a barrier, which needs a minimization with a feasible line search, is refused */
extern const MSimImplicitSchemeType MSimImplicitSchemeDiscreteGradient = {0.5, 0.5, 1, NWORK, 0, "a barrier needs a minimization with a feasible line search, and this step is a residual",
                                                                          "its step is a discrete-gradient residual, not the gradient of an energy", BeginStep_DG, EndStep_DG, Predict_DG, PETSC_FALSE};
