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
   springs bounded (no drift), where implicit Euler loses it. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

typedef struct {
  Vec P, F, W; /* the predictor p = x_n + h/2 v_n; work vectors */
} MidpointData;

static PetscErrorCode BeginStep_Midpoint(MSimImplicitScheme scheme, MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  MidpointData *d = (MidpointData *)scheme->data;

  PetscFunctionBeginUser;
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecWAXPY(d->P, 0.5 * h, V, X));
  PetscCall(VecCopy(d->P, imp->Y));
  PetscCall(MSimImplicitAddExternalAcceleration(imp, 0.25 * h * h, imp->Y));
  PetscCall(MSimImplicitAddDissipativeAcceleration(imp, 0.25 * h * h, t + 0.5 * h, d->P, V, d->F, d->W, imp->Y));
  imp->step.xref = d->P;
  imp->step.tref = t + 0.5 * h;
  imp->step.tx   = t + 0.5 * h;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Guess_Midpoint(MSimImplicitScheme scheme, MSimImplicit imp, Vec V, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(VecAXPY(X, 0.5 * imp->h, V));
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

static PetscErrorCode GetHistory_Midpoint(MSimImplicitScheme scheme, PetscInt *n, Vec **history)
{
  PetscFunctionBeginUser;
  *n       = 0;
  *history = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Midpoint(MSimImplicitScheme scheme)
{
  MidpointData *d = (MidpointData *)scheme->data;

  PetscFunctionBeginUser;
  PetscCall(VecDestroy(&d->P));
  PetscCall(VecDestroy(&d->F));
  PetscCall(VecDestroy(&d->W));
  PetscCall(PetscFree(scheme->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSchemeCreate_Midpoint(MSimImplicitScheme scheme)
{
  MidpointData *d;
  Vec           X0 = scheme->imp->sys->X0;

  PetscFunctionBeginUser;
  PetscCall(PetscNew(&d));
  PetscCall(VecDuplicate(X0, &d->P));
  PetscCall(VecDuplicate(X0, &d->F));
  PetscCall(VecDuplicate(X0, &d->W));
  scheme->data            = d;
  scheme->beta            = 0.25;
  scheme->gamma           = 0.5;
  /* x_{n+1} = 2 x_m - x_n went inside a box a cloth fell on */
  scheme->no_barrier      = "a barrier keeps the midpoint feasible, not x_{n+1} = 2 x_m - x_n";
  scheme->ops.begin_step  = BeginStep_Midpoint;
  scheme->ops.guess       = Guess_Midpoint;
  scheme->ops.end_step    = EndStep_Midpoint;
  scheme->ops.get_history = GetHistory_Midpoint;
  scheme->ops.destroy     = Destroy_Midpoint;
  PetscFunctionReturn(PETSC_SUCCESS);
}
