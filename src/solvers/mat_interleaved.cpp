/* y = (A kron I3) x - b for a scalar AIJ matrix A and Vecs that hold x, y and z interleaved: the
   gradient A x - rhs of PD + L-BFGS (pd_lbfgs.cpp). PETSc's MAIJ does the product with about 16
   instructions per stored entry (valgrind, 101 x 101 cloth: a third of a global step's sweep);
   on one rank this loop takes one 4-wide load and one FMA per entry, and subtracts b in the same
   pass. Several ranks use the MAIJ. */
#include <msim/solvers.h>
#include <petscmat.h>
#if defined(__AVX2__) && defined(__FMA__)
  #include <immintrin.h>
#endif

static PetscErrorCode MultSeq(Mat A, Vec x, Vec b, Vec y);

PetscErrorCode MSimMatMultInterleaved3(Mat A, Mat *maij, Vec x, Vec b, Vec y)
{
  static PetscLogEvent event = 0;
  PetscBool            seq;

  PetscFunctionBeginUser;
  if (!event) PetscCall(PetscLogEventRegister("MSimPDApply", MAT_CLASSID, &event));
  PetscCall(PetscLogEventBegin(event, A, x, y, 0));
  PetscCall(PetscObjectTypeCompare((PetscObject)A, MATSEQAIJ, &seq));
  if (seq) PetscCall(MultSeq(A, x, b, y));
  else {
    if (!*maij) PetscCall(MatCreateMAIJ(A, 3, maij));
    PetscCall(MatMult(*maij, x, y));
    if (b) PetscCall(VecAXPY(y, -1.0, b));
  }
  PetscCall(PetscLogEventEnd(event, A, x, y, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MultSeq(Mat A, Vec x, Vec b, Vec y)
{
  PetscFunctionBeginUser;
  const PetscInt    *ia, *ja;
  const PetscScalar *a, *px, *pb = NULL;
  PetscScalar       *py;
  PetscInt           n;
  PetscBool          done;
  PetscCall(MatGetRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
  PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_SUP, "PD matrix: no row structure");
  PetscCall(MatSeqAIJGetArrayRead(A, &a));
  PetscCall(VecGetArrayRead(x, &px));
  PetscCall(VecGetArrayWrite(y, &py));
  if (b) PetscCall(VecGetArrayRead(b, &pb));
  for (PetscInt i = 0; i < n; i++) {
    PetscScalar    s0 = 0, s1 = 0, s2 = 0;
    PetscInt       k = ia[i], end = ia[i + 1];
#if defined(__AVX2__) && defined(__FMA__)
    /* x_c, y_c, z_c and the next entry in one load, except for the last vertex's column (the
       columns are sorted: it can only be a row's last entry) */
    const PetscInt vend = (end > k && ja[end - 1] == n - 1) ? end - 1 : end;
    __m256d        acc0 = _mm256_setzero_pd(), acc1 = _mm256_setzero_pd();
    for (; k + 1 < vend; k += 2) {
      acc0 = _mm256_fmadd_pd(_mm256_broadcast_sd(a + k), _mm256_loadu_pd(px + 3 * ja[k]), acc0);
      acc1 = _mm256_fmadd_pd(_mm256_broadcast_sd(a + k + 1), _mm256_loadu_pd(px + 3 * ja[k + 1]), acc1);
    }
    if (k < vend) {
      acc0 = _mm256_fmadd_pd(_mm256_broadcast_sd(a + k), _mm256_loadu_pd(px + 3 * ja[k]), acc0);
      k++;
    }
    alignas(32) double t[4];
    _mm256_store_pd(t, _mm256_add_pd(acc0, acc1));
    s0 = t[0], s1 = t[1], s2 = t[2];
#endif
    for (; k < end; k++) {
      const PetscInt c = 3 * ja[k];
      s0 += a[k] * px[c];
      s1 += a[k] * px[c + 1];
      s2 += a[k] * px[c + 2];
    }
    if (pb) s0 -= pb[3 * i], s1 -= pb[3 * i + 1], s2 -= pb[3 * i + 2];
    py[3 * i] = s0, py[3 * i + 1] = s1, py[3 * i + 2] = s2;
  }
  if (b) PetscCall(VecRestoreArrayRead(b, &pb));
  PetscCall(VecRestoreArrayWrite(y, &py));
  PetscCall(VecRestoreArrayRead(x, &px));
  PetscCall(MatSeqAIJRestoreArrayRead(A, &a));
  PetscCall(PetscLogFlops(6.0 * ia[n]));
  PetscCall(MatRestoreRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
  PetscFunctionReturn(PETSC_SUCCESS);
}
