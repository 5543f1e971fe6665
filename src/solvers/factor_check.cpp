/* A factorization PC that the operator's matrix type has no package for, and a PC that cannot
   work on msim's matrices at all: refused before any factorization is attempted, with the option
   named. */
#include <msim/solvers.h>
#include <petscksp.h>

/* Preconditioners that cannot work on msim's matrices (AIJ, block size 3, from a DMShell),
   measured with Newton on a 9 x 9 cloth at 1 and 2 ranks: PETSc stopped at the first solve, after
   the run's output had begun, in its own words, which name neither the option nor the way out;
   cp gave a zero step with no error (Newton stopped at its first iterate, the cloth unmoved, the
   run went on). Said in one line at set-up naming -pc_type and the reason. */
static PetscErrorCode CheckPCServed(KSP ksp, PC pc, PCType pctype, Mat A, const char prefix[])
{
  MPI_Comm    comm = PetscObjectComm((PetscObject)ksp);
  PetscBool   is;
  const char *why = NULL;
  PetscInt    nblocks;
  PetscMPIInt size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  if (!strcmp(pctype, PCBDDC) || !strcmp(pctype, PCNN)) {
    PetscCall(PetscObjectTypeCompare((PetscObject)A, MATIS, &is));
    if (!is) why = "it needs a MATIS matrix (subdomain matrices unassembled across ranks), and msim's is AIJ";
  } else if (!strcmp(pctype, PCLSC)) {
    PetscCall(PetscObjectTypeCompare((PetscObject)A, MATSCHURCOMPLEMENT, &is));
    if (!is) why = "it preconditions a Schur complement, a saddle-point system's (a -pc_fieldsplit_type schur block), which msim's matrix is not";
  }
  else if (!strcmp(pctype, PCVPBJACOBI)) {
    const PetscInt *bsizes;
    PetscCall(MatGetVariableBlockSizes(A, &nblocks, &bsizes));
    if (!nblocks) why = "it needs variable block sizes, which msim's matrix does not set (its blocks are 3 x 3: -pc_type pbjacobi)";
  } else if (!strcmp(pctype, PCSHELL)) why = "a shell preconditioner's apply is set by code, and msim sets none";
  else if (!strcmp(pctype, PCPATCH)) why = "it needs a DMPlex discretization, which msim's problem does not have";
  else if (!strcmp(pctype, PCCOMPOSITE)) {
    PetscInt npc;
    PetscCall(PCCompositeGetNumberPC(pc, &npc));
    if (!npc) why = "it needs its preconditioners: -pc_composite_pcs jacobi,sor (for example)";
  } else if (!strcmp(pctype, PCCP)) why = size > 1 ? "it takes a sequential AIJ matrix only" : "its step on msim's Jacobian is zero: Newton stopped at its first iterate with the cloth unmoved";
  else if (!strcmp(pctype, PCTFS) && size == 1) why = "it takes a parallel AIJ matrix only (on one rank msim's is sequential)";
  PetscCheck(!why, comm, PETSC_ERR_SUP, "-%spc_type %s is not supported: %s", prefix, pctype, why);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc would fail only inside the first KSPSetUp, after a run's output has begun and with a message
   that names neither the option nor the way out (ICC or ILU on a matrix spread over several ranks is
   the usual case). The check reads the matrix's type and the PC's choice only: nothing is factored. */
PetscErrorCode MSimCheckFactorAvailable(KSP ksp, Mat A)
{
  PC            pc;
  PCType        pctype;
  MatSolverType stype = NULL;
  MatType       mtype;
  const char   *prefix;
  PetscBool     avail;
  MatFactorType ftype = MAT_FACTOR_NONE;

  PetscFunctionBeginUser;
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCGetType(pc, &pctype));
  if (!pctype) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(KSPGetOptionsPrefix(ksp, &prefix));
  if (!prefix) prefix = "";
  PetscCall(CheckPCServed(ksp, pc, pctype, A, prefix));
  if (!strcmp(pctype, PCLU)) ftype = MAT_FACTOR_LU;
  else if (!strcmp(pctype, PCCHOLESKY)) ftype = MAT_FACTOR_CHOLESKY;
  else if (!strcmp(pctype, PCILU)) ftype = MAT_FACTOR_ILU;
  else if (!strcmp(pctype, PCICC)) ftype = MAT_FACTOR_ICC;
  if (ftype == MAT_FACTOR_NONE) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCFactorGetMatSolverType(pc, &stype));
  PetscCall(MatGetFactorAvailable(A, stype, ftype, &avail));
  PetscCall(MatGetType(A, &mtype));
  PetscCheck(avail || !stype, PetscObjectComm((PetscObject)ksp), PETSC_ERR_SUP, "-%spc_factor_mat_solver_type %s: no %s factorization of a %s matrix in this PETSc", prefix, stype, MatFactorTypes[ftype], mtype);
  PetscCheck(avail, PetscObjectComm((PetscObject)ksp), PETSC_ERR_SUP, "-%spc_type %s: no %s factorization of a %s matrix in this PETSc (on several ranks: -%spc_type bjacobi -%ssub_pc_type %s, or a package named with -%spc_factor_mat_solver_type)", prefix, pctype, MatFactorTypes[ftype], mtype, prefix, prefix, pctype, prefix);
  PetscFunctionReturn(PETSC_SUCCESS);
}
