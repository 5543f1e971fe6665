#include "lower_triangle.h"
#include <algorithm>
#include <cstring>

namespace msim {
/* the lower triangle from a SeqAIJ matrix's arrays (columns ascending: a row's lower entries come
   first): the same entries in the same order as MatGetRow gives them, without a call per row,
   which cost 4.5 M instructions a set-up of the 101 x 101 cloth's PD matrix */
static void LowerFromArrays(PetscInt n, const PetscInt *ia, const PetscInt *ja, const PetscScalar *va, std::vector<int> &aptr, std::vector<int> &acol, std::vector<double> &aval)
{
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
}

PetscErrorCode LowerTriangleRows(Mat A, std::vector<int> &aptr, std::vector<int> &acol, std::vector<double> &aval)
{
  PetscInt           n, ncols;
  const PetscInt    *cols;
  const PetscScalar *vals;

  PetscFunctionBegin;
  {
    PetscBool          aij, done = PETSC_FALSE;
    const PetscInt    *ia, *ja;
    const PetscScalar *va;
    PetscCall(PetscObjectBaseTypeCompare((PetscObject)A, MATSEQAIJ, &aij));
    if (aij) PetscCall(MatGetRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
    if (done) {
      PetscCall(MatSeqAIJGetArrayRead(A, &va));
      LowerFromArrays(n, ia, ja, va, aptr, acol, aval);
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

PetscErrorCode LowerTriangle::Update(Mat A)
{
  PetscBool          aij, done = PETSC_FALSE;
  PetscInt           n;
  const PetscInt    *ia, *ja;
  const PetscScalar *va;

  PetscFunctionBegin;
  PetscCall(PetscObjectBaseTypeCompare((PetscObject)A, MATSEQAIJ, &aij));
  if (aij) PetscCall(MatGetRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
  if (!done) { /* not SeqAIJ: the whole triangle, row by row */
    ia_.clear();
    PetscCall(LowerTriangleRows(A, aptr, acol, aval));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MatSeqAIJGetArrayRead(A, &va));
  const bool same = (PetscInt)ia_.size() == n + 1 && !std::memcmp(ia_.data(), ia, sizeof(PetscInt) * (n + 1)) && !std::memcmp(ja_.data(), ja, sizeof(PetscInt) * ia[n]);
  if (same) { /* the changed values, a block at a time (a few dozen of 200,000 on the drape) */
    const PetscInt nz = ia[n], B = 64;
    for (PetscInt b0 = 0; b0 < nz; b0 += B) {
      const PetscInt b1 = PetscMin(nz, b0 + B);
      if (!std::memcmp(va + b0, va_.data() + b0, sizeof(PetscScalar) * (b1 - b0))) continue;
      for (PetscInt k = b0; k < b1; k++) {
        if (!std::memcmp(va + k, va_.data() + k, sizeof(PetscScalar))) continue;
        va_[k]             = va[k];
        const PetscInt i   = (PetscInt)(std::upper_bound(ia, ia + n + 1, k) - ia) - 1; /* k's row */
        const PetscInt off = k - ia[i];
        if (off < aptr[i + 1] - aptr[i]) aval[aptr[i] + off] = PetscRealPart(va[k]); /* else above the diagonal */
      }
    }
  } else { /* a new pattern (or the first call): everything, and the arrays to compare with next */
    ia_.clear(); /* until the copies below are whole */
    LowerFromArrays(n, ia, ja, va, aptr, acol, aval);
    ja_.assign(ja, ja + ia[n]);
    va_.assign(va, va + ia[n]);
    ia_.assign(ia, ia + n + 1);
  }
  PetscCall(MatSeqAIJRestoreArrayRead(A, &va));
  PetscCall(MatRestoreRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
  PetscFunctionReturn(PETSC_SUCCESS);
}
} // namespace msim
