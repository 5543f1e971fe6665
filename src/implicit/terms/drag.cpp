/* Air drag -c v as a dissipation potential: hd c/2 |x - xref|^2 (implicit Euler: h c/2 |x - x_n|^2).
   The wind's part c w is a constant force, folded into the scheme's y. A diagonal quadratic, so
   the problem carries it in its inertia pass: no pass of its own, and nothing when c = 0. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

static PetscErrorCode Diagonal_Drag(MSimImplicitTerm term, PetscReal *w, Vec *c)
{
  MSimImplicit imp = term->imp;

  PetscFunctionBeginUser;
  *w = imp->step.hd * imp->sys->drag;
  *c = imp->step.xref ? imp->step.xref : imp->Xn;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitTermCreate_Drag(MSimImplicitTerm term)
{
  PetscFunctionBeginUser;
  term->ops.diagonal = Diagonal_Drag;
  PetscFunctionReturn(PETSC_SUCCESS);
}
