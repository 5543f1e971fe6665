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

/* The types msim's problems cannot serve, and a -npc_snes_type the type would not run: said in
   one line at set-up, before any output, where PETSc would stop at the first solve in its own
   words or ignore the option without a word. */
PetscErrorCode MSimSNESCheckServed(SNES snes)
{
  MPI_Comm  comm = PetscObjectComm((PetscObject)snes);
  PetscBool has_npc, unserved, composite;
  SNESType  type, npc_type;
  SNES      s = snes, npc;
  PetscInt  nsub;

  PetscFunctionBeginUser;
  PetscCall(SNESHasNPC(snes, &has_npc));
  /* they need what msim's problem (a DMShell, one Jacobian) does not give: a greedy coloring of
     an AIJ matrix, subdomains, a DMPlex, a solve set by code. aspin makes itself newtonls with nasm
     as its preconditioner, so the preconditioner is asked too */
  for (int level = 0; level < 2; level++) {
    if (level) {
      if (!has_npc) break;
      PetscCall(SNESGetNPC(snes, &s));
    }
    PetscCall(PetscObjectTypeCompareAny((PetscObject)s, &unserved, SNESNGS, SNESNASM, SNESASPIN, SNESPATCH, SNESSHELL, ""));
    PetscCall(SNESGetType(s, &type));
    PetscCheck(!unserved, comm, PETSC_ERR_SUP, "%s %s is not supported: it needs %s, which msim's problem does not provide; -help lists the solvers msim serves", level ? "the nonlinear preconditioner's type (-npc_snes_type, or -snes_type aspin's)" : "-snes_type", type,
               !strcmp(type, SNESNGS) ? "a coloring of an AIJ Jacobian" : !strcmp(type, SNESPATCH) ? "a DMPlex" : !strcmp(type, SNESSHELL) ? "a solve set by code" : "subdomains of a DM");
  }
  PetscCall(SNESGetType(snes, &type));
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESCOMPOSITE, &composite));
  if (composite) {
    PetscCall(SNESCompositeGetNumber(snes, &nsub));
    PetscCheck(nsub > 0, comm, PETSC_ERR_ARG_WRONG, "-snes_type composite needs its solvers: -snes_composite_sneses pd,newtonls (for example)");
  }
  /* PETSc makes -npc_snes_type's solver for any type, and each type decides by usesnpc (no public
     accessor in 3.18) whether its solve calls it: pd, ntr, ksponly and the VI types do not */
  if (has_npc && !snes->usesnpc) {
    PetscCall(SNESGetNPC(snes, &npc));
    PetscCall(SNESGetType(npc, &npc_type));
    SETERRQ(comm, PETSC_ERR_SUP, "-npc_snes_type %s with -snes_type %s is not supported: %s runs no nonlinear preconditioner (newtonls, qn, ncg, nrichardson, anderson and ngmres do)", npc_type, type, type);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
