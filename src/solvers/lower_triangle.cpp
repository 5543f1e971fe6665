#include "lower_triangle.h"

namespace msim {
PetscErrorCode LowerTriangleRows(Mat A, std::vector<int> &aptr, std::vector<int> &acol, std::vector<double> &aval)
{
  PetscInt           n, ncols;
  const PetscInt    *cols;
  const PetscScalar *vals;

  PetscFunctionBegin;
  PetscCall(MatGetLocalSize(A, &n, NULL));
  aptr.assign(1, 0);
  acol.clear();
  aval.clear();
  for (PetscInt i = 0; i < n; i++) {
    PetscCall(MatGetRow(A, i, &ncols, &cols, &vals));
    for (PetscInt k = 0; k < ncols; k++)
      if (cols[k] <= i) {
        acol.push_back((int)cols[k]);
        aval.push_back(PetscRealPart(vals[k]));
      }
    aptr.push_back((int)acol.size());
    PetscCall(MatRestoreRow(A, i, &ncols, &cols, &vals));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
} // namespace msim
