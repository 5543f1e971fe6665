#include <msim/sys.h>

PetscErrorCode MSimOptionsVec3_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], PetscReal v[3], PetscBool *set)
{
  PetscInt  n = 3;
  PetscBool flg;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsRealArray(name, help, NULL, v, &n, &flg));
  PetscCheck(!flg || n == 3, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "%s needs three comma-separated numbers x,y,z (got %" PetscInt_FMT ")", name, n);
  if (set) *set = flg;
  PetscFunctionReturn(PETSC_SUCCESS);
}
