/* What a SNES type needs, asked of the SNES rather than read off its type name. */
#include <petsc/private/snesimpl.h>
#include <msim/solvers.h>

/* PETSc sets usesksp per type (qn turns it on with -snes_qn_scale_type jacobian); SNESView reads
   it to decide whether to print linear iterations. No public accessor in 3.18. */
PetscErrorCode MSimSNESUsesJacobian(SNES snes, PetscBool *uses)
{
  PetscFunctionBeginUser;
  *uses = snes->usesksp;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc makes the nonlinear preconditioner of -npc_snes_type for any type, and each type decides
   by usesnpc whether its solve calls it (pd and ntr do not). No public accessor in 3.18. */
PetscErrorCode MSimSNESUsesNPC(SNES snes, PetscBool *uses)
{
  PetscFunctionBeginUser;
  *uses = snes->usesnpc;
  PetscFunctionReturn(PETSC_SUCCESS);
}
