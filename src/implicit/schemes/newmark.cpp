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
   force evaluation and keeps the recursion consistent with an inexact solve. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

typedef struct {
  Vec A;  /* a_n (valid when scheme->history_valid) */
  Vec P;  /* the predictor p = x_n + h v_n, the dissipation's reference */
  Vec Vn; /* v_n, for the velocity update */
  Vec F, W;
} NewmarkData;

static PetscErrorCode BeginStep_Newmark(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  NewmarkData *d = (NewmarkData *)scheme->data;

  PetscFunctionBeginUser;
  if (!scheme->history_valid) PetscCall(MSimSystemAcceleration(imp->sys, t, X, V, d->A));
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecCopy(V, d->Vn));
  PetscCall(VecWAXPY(d->P, h, V, X));
  /* y = x_n + h v_n + h^2/4 a_n + h^2/4 M^-1 (f_e + f_d(p, v_n)) */
  PetscCall(VecWAXPY(imp->Y, 0.25 * h * h, d->A, d->P));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, 0.25 * h * h, imp->Y));
  PetscCall(MSimImplicitAddDissipativeAcceleration(imp, 0.25 * h * h, t + h, d->P, V, d->F, d->W, imp->Y));
  imp->step.xref = d->P;
  imp->step.tref = t + h;
  imp->step.tx   = t + h;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Guess_Newmark(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPY(X, imp->h, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* a_{n+1} = 4/h^2 (x_{n+1} - x_n - h v_n) - a_n, then v_{n+1} = 2 (x_{n+1} - x_n)/h - v_n */
static PetscErrorCode EndStep_Newmark(MSimImplicitScheme scheme, MSimImplicit imp, Vec X, Vec V)
{
  NewmarkData    *d = (NewmarkData *)scheme->data;
  const PetscReal h = imp->h;

  PetscFunctionBeginUser;
  PetscCall(VecAXPBYPCZ(d->A, 4.0 / (h * h), -4.0 / (h * h), -1.0, X, imp->Xn));
  PetscCall(VecAXPY(d->A, -4.0 / h, d->Vn));
  PetscCall(VecAXPBYPCZ(V, 2.0 / h, -2.0 / h, -1.0, X, imp->Xn));
  scheme->history_valid = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode GetHistory_Newmark(MSimImplicitScheme scheme, PetscInt *n, Vec **history)
{
  NewmarkData *d = (NewmarkData *)scheme->data;

  PetscFunctionBeginUser;
  *n       = 1;
  *history = &d->A;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Newmark(MSimImplicitScheme scheme)
{
  NewmarkData *d = (NewmarkData *)scheme->data;

  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&d->A));
  PetscCall(VecDestroy(&d->P));
  PetscCall(VecDestroy(&d->F));
  PetscCall(VecDestroy(&d->W));
  PetscCall(VecDestroy(&d->Vn));
  PetscCall(PetscFree(scheme->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSchemeCreate_Newmark(MSimImplicitScheme scheme)
{
  NewmarkData *d;
  Vec          X0 = scheme->imp->sys->X0;

  PetscFunctionBeginUser;
  PetscCall(PetscNew(&d));
  PetscCall(VecDuplicate(X0, &d->A));
  PetscCall(VecDuplicate(X0, &d->P));
  PetscCall(VecDuplicate(X0, &d->F));
  PetscCall(VecDuplicate(X0, &d->W));
  PetscCall(VecDuplicate(X0, &d->Vn));
  scheme->data            = d;
  scheme->beta            = 0.25;
  scheme->gamma           = 0.5;
  /* a cloth dropped on a box diverged: nothing damps the recursions' response to the barrier */
  scheme->no_barrier      = "its trapezoidal velocity and acceleration recursions ring on a barrier's stiff response and diverge";
  scheme->ops.begin_step  = BeginStep_Newmark;
  scheme->ops.guess       = Guess_Newmark;
  scheme->ops.end_step    = EndStep_Newmark;
  scheme->ops.get_history = GetHistory_Newmark;
  scheme->ops.destroy     = Destroy_Newmark;
  PetscFunctionReturn(PETSC_SUCCESS);
}
