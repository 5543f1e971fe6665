#include "lower_triangle.h"

namespace msim {
PetscErrorCode LowerTriangleRows(Mat A, std::vector<int> &aptr, std::vector<int> &acol, std::vector<double> &aval)
{
  PetscInt           n, ncols;
  const PetscInt    *cols;
  const PetscScalar *vals;

  PetscFunctionBegin;
  { /* a SeqAIJ matrix straight from its arrays (columns ascending: a row's lower entries come
       first): the same entries in the same order without a MatGetRow call per row, which cost
       4.5 M instructions a set-up of the 101 x 101 cloth's PD matrix (set up several times a step
       or two by the contact weights, where a low-rank update is otherwise cheap) */
    PetscBool          aij, done = PETSC_FALSE;
    const PetscInt    *ia, *ja;
    const PetscScalar *va;
    PetscCall(PetscObjectBaseTypeCompare((PetscObject)A, MATSEQAIJ, &aij));
    if (aij) PetscCall(MatGetRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
    if (done) {
      PetscCall(MatSeqAIJGetArrayRead(A, &va));
      aptr.resize(n + 1);
      aptr[0] = 0;
      for (PetscInt i = 0; i < n; i++) {
        PetscInt k = ia[i];
        while (k < ia[i + 1] && ja[k] <= i) k++;
        aptr[i + 1] = aptr[i] + (int)(k - ia[i]);
      }
      acol.resize(aptr[n]);
      aval.resize(aptr[n]);
      for (PetscInt i = 0; i < n; i++)
        for (int e = aptr[i], k = (int)ia[i]; e < aptr[i + 1]; e++, k++) {
          acol[e] = (int)ja[k];
          aval[e] = PetscRealPart(va[k]);
        }
      PetscCall(MatSeqAIJRestoreArrayRead(A, &va));
      PetscCall(MatRestoreRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
  }
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
