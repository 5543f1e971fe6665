/* The state a solver carries from one solve to the next (MSimSolverHistory), asked of the SNES by
   the functions its type composes, not read off its type name: a type without such state composes
   none and carries nothing. */
#include <msim/solvers.h>

typedef PetscErrorCode (*GetFn)(SNES, MSimSolverHistory *);
typedef PetscErrorCode (*SetFn)(SNES, const MSimSolverHistory *, PetscBool *);

/* snes, then its nonlinear preconditioner if it has one (SNESGetNPC would make one) */
static PetscErrorCode Candidates(SNES snes, SNES s[2])
{
  PetscBool has_npc;

  PetscFunctionBeginUser;
  s[0] = snes;
  s[1] = NULL;
  PetscCall(SNESHasNPC(snes, &has_npc));
  if (has_npc) PetscCall(SNESGetNPC(snes, &s[1]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSNESGetHistory(SNES snes, MSimSolverHistory *h)
{
  SNES  s[2];
  GetFn get;

  PetscFunctionBeginUser;
  h->name.clear();
  h->real.clear();
  h->vec.clear();
  if (!snes) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(Candidates(snes, s));
  for (SNES c : s) {
    if (!c || !h->name.empty()) continue;
    PetscCall(PetscObjectQueryFunction((PetscObject)c, "MSimSNESGetHistory_C", &get));
    if (get) PetscCall((*get)(c, h));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSNESSetHistory(SNES snes, const MSimSolverHistory *h, PetscBool *taken)
{
  SNES  s[2];
  SetFn set;

  PetscFunctionBeginUser;
  *taken = PETSC_FALSE;
  if (!snes || h->name.empty()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(Candidates(snes, s));
  for (SNES c : s) {
    if (!c || *taken) continue;
    PetscCall(PetscObjectQueryFunction((PetscObject)c, "MSimSNESSetHistory_C", &set));
    if (set) PetscCall((*set)(c, h, taken));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc 3.18's qn keeps its pairs from one solve to the next in its LMVM Mat (SNESSolve_QN never
   resets it; only set-up does), which has no public way to read or set them */
PetscErrorCode MSimSNESHistoryIsComplete(SNES snes, PetscBool *complete)
{
  SNES      s[2];
  PetscBool qn;

  PetscFunctionBeginUser;
  *complete = PETSC_TRUE;
  if (!snes) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(Candidates(snes, s));
  for (SNES c : s) {
    if (!c) continue;
    PetscCall(PetscObjectTypeCompare((PetscObject)c, SNESQN, &qn));
    if (qn) *complete = PETSC_FALSE;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
