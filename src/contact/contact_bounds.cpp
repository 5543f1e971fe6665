/* Axis-aligned obstacles as variable bounds of PETSc's VI solvers (msim/contact_bounds.h). Why a
   box gets one face per vertex and step: the outside of a solid box is a union of half-spaces, not
   a box of bounds; the face region a vertex is in at x_n names the one half-space it keeps to for
   the step, which keeps it outside the box (a vertex near an edge cannot slide round the corner
   within one step: conservative, never inside). */
#include <msim/contact_bounds.h>
#include <msim/contact.h>
#include <msim/contact_force.h>
#include <msim/options.h>
#include <msim/private/systemimpl.h>
#include <msim/private/contactimpl.h>
#include <msim/destroy.h>
#include <petscsnes.h>
#include <vector>

struct _n_MSimContactBounds {
  MSimSystem                sys;
  SNES                      snes;
  std::vector<MSimObstacle> obs; /* taken from the contact object: the barrier no longer sees them */
  Vec                       XL, XU, R;
};

static const char reaction_key[] = "MSimContactReaction";

PetscErrorCode MSimContactBoundsGetReaction(MSimSystem sys, Vec *R)
{
  PetscFunctionBeginUser;
  PetscCall(PetscObjectQuery((PetscObject)sys->X0, reaction_key, (PetscObject *)R));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* k with n = +-e_k (the other two components exactly 0), or -1 */
static int AxisOf(const PetscReal n[3])
{
  int axis = -1, zeros = 0;
  for (int c = 0; c < 3; c++) {
    if (n[c] == 0) zeros++;
    else axis = c;
  }
  return zeros == 2 ? axis : -1;
}

PetscErrorCode MSimContactBoundsCreate(MSimSystem sys, SNES snes, MSimContactBounds *b)
{
  MSimContact ct;
  PetscBool   want = PETSC_FALSE, vi, ssls;

  PetscFunctionBeginUser;
  *b = NULL;
  PetscOptionsBegin(sys->comm, NULL, "msim contact as variable bounds", NULL);
  PetscCall(PetscOptionsBool("-msim_contact_bounds", "Implicit integrators: axis-aligned planes and boxes as variable bounds of SNES's VI solver (vinewtonrsls; also with -snes_type vinewtonrsls/vinewtonssls) instead of the barrier: zero gap at contact", NULL, want, &want, NULL));
  PetscOptionsEnd();
  PetscCall(PetscObjectTypeCompareAny((PetscObject)snes, &vi, SNESVINEWTONRSLS, SNESVINEWTONSSLS, ""));
  if (!want && !vi) { /* the obstacles stay with the barrier: its margin at the start */
    PetscCall(MSimContactCheckBarrierStart(sys));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MSimContactGet(sys, &ct));
  if (!ct) { /* nothing to bound: a VI type then solves unconstrained; the option asked for bounds */
    PetscBool has;
    PetscCall(MSimContactHasObstacles(sys, &has)); /* bounds an earlier call took */
    PetscCheck(!want || has, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_contact_bounds has no obstacle to take as bounds: give axis-aligned planes (-msim_contact_plane) or boxes (-msim_contact_box)");
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  for (size_t k = 0; k < ct->obs.size(); k++) {
    const MSimObstacle &o = ct->obs[k];
    const char *what = o.kind == MSIM_OBSTACLE_SPHERE ? "a sphere" : o.kind == MSIM_OBSTACLE_MESH ? "a mesh" : o.kind == MSIM_OBSTACLE_PLANE && AxisOf(o.p) < 0 ? "a plane whose normal is not along an axis" : NULL;
    PetscCheck(!what, sys->comm, PETSC_ERR_SUP, "%s takes axis-aligned planes and boxes only as variable bounds: obstacle %d is %s (use the barrier: no -msim_contact_bounds, a -snes_type that is not a VI)", want ? "-msim_contact_bounds" : "-snes_type vinewtonrsls/vinewtonssls", (int)k, what);
    PetscCheck(o.v[0] == 0 && o.v[1] == 0 && o.v[2] == 0, sys->comm, PETSC_ERR_SUP, "%s takes static obstacles only as variable bounds: obstacle %d moves (-msim_contact_velocity)", want ? "-msim_contact_bounds" : "-snes_type vinewtonrsls/vinewtonssls", (int)k);
  }
  /* IPC's friction takes each vertex's normal force from the barrier, which the bounds replace: the
     obstacles' friction term finds them gone and adds nothing. -msim_friction also sets the
     friction between surfaces in self-contact, a barrier of its own that the bounds leave alone:
     with it the run goes on, and says once what it leaves out; without it the coefficient would
     act nowhere, so it is refused, as the penalty refuses it */
  if (ct->mu > 0) {
    const char *how = want ? "-msim_contact_bounds" : "-snes_type vinewtonrsls/vinewtonssls";
    PetscCheck(sys->self_contact.on, sys->comm, PETSC_ERR_SUP, "-msim_friction with obstacles as variable bounds (%s) is not supported: friction with an obstacle takes its normal force from the barrier, which the bounds replace; use the barrier (no -msim_contact_bounds, a -snes_type that is not a VI), or add -msim_self_contact for friction between surfaces", how);
    PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: -msim_friction acts between surfaces in self-contact only: the obstacles, variable bounds here (%s), have no friction, which takes its normal force from the barrier\n", how));
  }
  *b         = new _n_MSimContactBounds();
  (*b)->sys  = sys;
  (*b)->snes = snes;
  ct->bounds.swap(ct->obs); /* the barrier, its friction and its line-search limit no longer see them */
  (*b)->obs = ct->bounds;
  /* The line search: l2 unless the user names one. msim's energy search (the shell type, msim's
     default) does not project onto the bounds; PETSc's do. Not bt, PETSc's choice for its VI types:
     it backtracks on Phi (msim's objective), whose roundoff (eps |Phi|, 5e-16 J on an 11 x 11 cloth)
     hides the decrease |g| |dx| once |g| nears msim's absolute tolerance, so the projected Newton,
     linear on a PSD-projected Hessian, stalled there (DIVERGED_LINE_SEARCH at |g| = 1.50e-10
     against 1.41e-10, step 36 of a cloth draped on a table, runs/contact/README.md); l2's secant
     steps go on, and l2 is msim's search where there is no Phi. A VI type, set here or by
     -snes_type, resets the line search to bt after its options were read, so they are read again
     here: a user's -snes_linesearch_type still wins. */
  if (!vi) { /* msim's default solver gives way to the VI; a type the user named is not overridden silently */
    const char *prefix, *type;
    PetscBool   named;
    PetscCall(SNESGetOptionsPrefix(snes, &prefix));
    PetscCall(PetscOptionsHasName(NULL, prefix, "-snes_type", &named));
    PetscCall(SNESGetType(snes, &type));
    PetscCheck(!named, sys->comm, PETSC_ERR_ARG_INCOMP, "-msim_contact_bounds takes SNES's VI solvers (vinewtonrsls, the default there, or vinewtonssls), not -snes_type %s; or keep -snes_type %s and use the barrier (no -msim_contact_bounds)", type, type);
    PetscCall(SNESSetType(snes, SNESVINEWTONRSLS));
  }
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESVINEWTONSSLS, &ssls));
  {
    SNESLineSearch ls;
    PetscBool      shell;
    PetscCall(SNESGetLineSearch(snes, &ls));
    PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHL2));
    PetscCall(SNESLineSearchSetFromOptions(ls));
    PetscCall(PetscObjectTypeCompare((PetscObject)ls, SNESLINESEARCHSHELL, &shell));
    PetscCheck(!(ssls && shell), sys->comm, PETSC_ERR_SUP, "-snes_type vinewtonssls with obstacles as bounds takes PETSc's line searches (l2, bt, basic), not -snes_linesearch_type shell: msim's search is on Phi, which a semismooth direction need not lower (src/integrators/impls/implicit.cpp)");
  }
  PetscCall(VecDuplicate(sys->X0, &(*b)->XL));
  PetscCall(VecDuplicate(sys->X0, &(*b)->XU));
  PetscCall(VecDuplicate(sys->X0, &(*b)->R));
  PetscCall(VecSet((*b)->XL, PETSC_NINFINITY));
  PetscCall(VecSet((*b)->XU, PETSC_INFINITY));
  PetscCall(VecZeroEntries((*b)->R));
  PetscCall(SNESVISetVariableBounds(snes, (*b)->XL, (*b)->XU));
  PetscCall(PetscObjectCompose((PetscObject)sys->X0, reaction_key, (PetscObject)(*b)->R));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactBoundsBeginStep(MSimContactBounds b, Vec Xn)
{
  MSimSystem         sys = b->sys;
  const PetscScalar *x;
  PetscScalar       *lo, *hi;

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayRead(Xn, &x));
  PetscCall(VecGetArray(b->XL, &lo));
  PetscCall(VecGetArray(b->XU, &hi));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) lo[i] = PETSC_NINFINITY, hi[i] = PETSC_INFINITY;
  for (PetscInt v = 0; v < sys->nown; v++)
    for (const MSimObstacle &o : b->obs) {
      const PetscReal *p = o.p, *xv = x + 3 * v;
      if (o.kind == MSIM_OBSTACLE_PLANE) { /* n = s e_k: s x_k >= d */
        const int k = AxisOf(p);
        if (p[k] > 0) lo[3 * v + k] = PetscMax(PetscRealPart(lo[3 * v + k]), p[3] / p[k]);
        else hi[3 * v + k] = PetscMin(PetscRealPart(hi[3 * v + k]), p[3] / p[k]);
        continue;
      }
      /* box: the face whose half-space the vertex is farthest into (>= 0: it is outside or on it) */
      int       axis = 0, upper = 0;
      PetscReal best = PETSC_NINFINITY;
      for (int c = 0; c < 3; c++) {
        const PetscReal below = p[2 * c] - xv[c], above = xv[c] - p[2 * c + 1];
        if (below > best) best = below, axis = c, upper = 0;
        if (above > best) best = above, axis = c, upper = 1;
      }
      if (upper) lo[3 * v + axis] = PetscMax(PetscRealPart(lo[3 * v + axis]), p[2 * axis + 1]);
      else hi[3 * v + axis] = PetscMin(PetscRealPart(hi[3 * v + axis]), p[2 * axis]);
    }
  PetscCall(VecRestoreArray(b->XU, &hi));
  PetscCall(VecRestoreArray(b->XL, &lo));
  PetscCall(VecRestoreArrayRead(Xn, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactBoundsProject(MSimContactBounds b, Vec X, PetscBool *moved)
{
  const PetscScalar *lo, *hi;
  PetscScalar       *x;
  PetscBool          any = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(VecGetArray(X, &x));
  PetscCall(VecGetArrayRead(b->XL, &lo));
  PetscCall(VecGetArrayRead(b->XU, &hi));
  for (PetscInt i = 0; i < 3 * b->sys->nown; i++) {
    const PetscReal xi = PetscRealPart(x[i]), c = PetscMin(PetscRealPart(hi[i]), PetscMax(PetscRealPart(lo[i]), xi));
    if (c != xi) x[i] = c, any = PETSC_TRUE;
  }
  PetscCall(VecRestoreArrayRead(b->XU, &hi));
  PetscCall(VecRestoreArrayRead(b->XL, &lo));
  PetscCall(VecRestoreArray(X, &x));
  PetscCall(MPIU_Allreduce(&any, moved, 1, MPIU_BOOL, MPI_LOR, b->sys->comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactBoundsEndStep(MSimContactBounds b, Vec X, Vec F, PetscReal h2, PetscReal *residual)
{
  const PetscScalar *x, *f, *lo, *hi;
  PetscScalar       *r;
  PetscReal          free2 = 0;

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(F, &f));
  PetscCall(VecGetArrayRead(b->XL, &lo));
  PetscCall(VecGetArrayRead(b->XU, &hi));
  PetscCall(VecGetArray(b->R, &r));
  for (PetscInt i = 0; i < 3 * b->sys->nown; i++) {
    const PetscReal xi = PetscRealPart(x[i]), fi = PetscRealPart(f[i]), l = PetscRealPart(lo[i]), u = PetscRealPart(hi[i]);
    /* The VI's natural residual x - P_[l,u](x - g), zero exactly at a solution: g where the
       component is free, its gap x - l (x - u) where g pushes it against its bound by more than
       that gap, and then the bound carries g: its reaction. vinewtonrsls lands active components
       on the bound exactly (gap 0); vinewtonssls, which solves the Fischer-Burmeister equation
       phi = 0, only to its tolerance, which leaves gaps of 1e-11 m under loads of 8e-3: an
       "exactly at the bound" test took those for free components and reported |g| = 7.8e-3 for
       steps that had converged (the table drop, steps 13-15). */
    const PetscBool below = (PetscBool)(xi - fi < l), above = (PetscBool)(xi - fi > u);
    const PetscReal res   = below ? xi - l : above ? xi - u : fi;
    r[i] = below || above ? fi / h2 : 0;
    free2 += res * res;
  }
  PetscCall(VecRestoreArray(b->R, &r));
  PetscCall(VecRestoreArrayRead(b->XU, &hi));
  PetscCall(VecRestoreArrayRead(b->XL, &lo));
  PetscCall(VecRestoreArrayRead(F, &f));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &free2, 1, MPIU_REAL, MPIU_SUM, b->sys->comm));
  *residual = PetscSqrtReal(free2);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactBoundsDestroy(MSimContactBounds *b)
{
  PetscFunctionBeginUser;
  if (!*b) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimDestroy(&(*b)->XL, &(*b)->XU, &(*b)->R));
  delete *b;
  *b = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
