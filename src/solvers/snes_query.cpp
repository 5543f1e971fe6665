/* What a SNES type needs, asked of the SNES rather than read off its type name. */
#include <petsc/private/snesimpl.h>
#include <msim/solvers.h>
#include <vector>

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
  MPI_Comm           comm = PetscObjectComm((PetscObject)snes);
  PetscBool          has_npc, unserved, composite;
  SNESType           type, npc_type;
  SNES               npc;
  PetscInt           nsub = 0;
  std::vector<SNES>  solvers = {snes};
  std::vector<const char *> what = {"-snes_type"};

  PetscFunctionBeginUser;
  PetscCall(SNESGetType(snes, &type));
  PetscCall(SNESHasNPC(snes, &has_npc));
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESCOMPOSITE, &composite));
  if (composite) {
    PetscCall(SNESCompositeGetNumber(snes, &nsub));
    PetscCheck(nsub > 0, comm, PETSC_ERR_ARG_WRONG, "-snes_type composite needs its solvers: -snes_composite_sneses pd,newtonls (for example)");
    for (PetscInt k = 0; k < nsub; k++) {
      solvers.push_back(NULL);
      PetscCall(SNESCompositeGetSNES(snes, k, &solvers.back()));
      what.push_back("-snes_composite_sneses's");
    }
  }
  /* aspin makes itself newtonls with nasm as its preconditioner, so the preconditioner is asked
     too */
  if (has_npc) {
    solvers.push_back(NULL);
    PetscCall(SNESGetNPC(snes, &solvers.back()));
    what.push_back("the nonlinear preconditioner's type (-npc_snes_type, or -snes_type aspin's)");
  }
  /* they need what msim's problem (a DMShell, one Jacobian) does not give: a greedy coloring of
     an AIJ matrix, subdomains, a DMPlex, a solve set by code */
  for (size_t k = 0; k < solvers.size(); k++) {
    SNESType t;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)solvers[k], &unserved, SNESNGS, SNESNASM, SNESASPIN, SNESPATCH, SNESSHELL, ""));
    PetscCall(SNESGetType(solvers[k], &t));
    PetscCheck(!unserved, comm, PETSC_ERR_SUP, "%s %s is not supported: it needs %s, which msim's problem does not provide (msim serves newtonls, ntr, pd, qn, anderson, ngmres, ncg, nrichardson, ms, fas, composite, ksponly and the VI types)", what[k], t,
               !strcmp(t, SNESNGS) ? "a coloring of an AIJ Jacobian" : !strcmp(t, SNESPATCH) ? "a DMPlex" : !strcmp(t, SNESSHELL) ? "a solve set by code" : "subdomains of a DM");
  }
  /* newtonls preconditioned on the left solves for x - npc(x) = 0, whose Jacobian msim does not
     assemble: with the springs' Hessian its linear solves failed at the first step */
  if (has_npc) {
    PCSide    side;
    PetscBool newtonls;
    PetscCall(SNESGetNPCSide(snes, &side));
    PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESNEWTONLS, &newtonls));
    PetscCheck(!(newtonls && side == PC_LEFT), comm, PETSC_ERR_SUP, "-snes_npc_side left with -snes_type newtonls is not supported: it solves x - npc(x) = 0, whose Jacobian msim does not assemble; use the right side (the default)");
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
