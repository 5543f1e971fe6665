/* A factorization PC that the operator's matrix type has no package for: refused before any
   factorization is attempted, with the option named. */
#include <msim/solvers.h>
#include <petscksp.h>

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
  if (!strcmp(pctype, PCLU)) ftype = MAT_FACTOR_LU;
  else if (!strcmp(pctype, PCCHOLESKY)) ftype = MAT_FACTOR_CHOLESKY;
  else if (!strcmp(pctype, PCILU)) ftype = MAT_FACTOR_ILU;
  else if (!strcmp(pctype, PCICC)) ftype = MAT_FACTOR_ICC;
  if (ftype == MAT_FACTOR_NONE) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCFactorGetMatSolverType(pc, &stype));
  PetscCall(MatGetFactorAvailable(A, stype, ftype, &avail));
  PetscCall(MatGetType(A, &mtype));
  PetscCall(KSPGetOptionsPrefix(ksp, &prefix));
  if (!prefix) prefix = "";
  PetscCheck(avail || !stype, PetscObjectComm((PetscObject)ksp), PETSC_ERR_SUP, "-%spc_factor_mat_solver_type %s: no %s factorization of a %s matrix in this PETSc", prefix, stype, MatFactorTypes[ftype], mtype);
  PetscCheck(avail, PetscObjectComm((PetscObject)ksp), PETSC_ERR_SUP, "-%spc_type %s: no %s factorization of a %s matrix in this PETSc (on several ranks: -%spc_type bjacobi -%ssub_pc_type %s, or a package named with -%spc_factor_mat_solver_type)", prefix, pctype, MatFactorTypes[ftype], mtype, prefix, prefix, pctype, prefix);
  PetscFunctionReturn(PETSC_SUCCESS);
}
