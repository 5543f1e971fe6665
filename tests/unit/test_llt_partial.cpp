/* msimllt's partial refactorization (src/solvers/supernodal_numeric.h): after some entries of PD's
   matrix change (contact weights on the diagonal of a patch of rows, then other rows', then one
   off-diagonal pair), a PC refactored in place solves exactly as a PC that factors the same
   matrix from scratch (bit for bit: same analysis, same sums) and as one refactoring in full with
   -pc_msimllt_partial 0, with a relative residual below 1e-12; the refactorizations are partial
   (the MSimLLTPartial event counts them; on several ranks, each rank's local factor, the dense
   interface Schur complement redone) and serially recompute fewer flops than a full one. Scenes: the cloth with the default
   supernode merging and merged far beyond it (many stored zeros, which the partial factorization
   skips when they fall outside a supernode's structure). */
#include "harness.h"
#include <msim/private/implicitimpl.h>
#include <cstring>

/* the partial refactorizations so far, and the factorizations' flops (each the flops of the
   supernodes it recomputed) */
static PetscErrorCode PartialCount(PetscInt *count, PetscLogDouble *flops = nullptr)
{
  PetscLogEvent      ev;
  PetscEventPerfInfo info;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventGetId("MSimLLTPartial", &ev));
  PetscCall(PetscLogEventGetPerfInfo(0, ev, &info));
  *count = info.count;
  PetscCall(PetscLogEventGetId("MSimLLTFactor", &ev));
  PetscCall(PetscLogEventGetPerfInfo(0, ev, &info));
  if (flops) *flops = info.flops;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* true when x and y hold the same bits on every rank */
static PetscErrorCode SameBits(Vec x, Vec y, PetscBool *same)
{
  const PetscScalar *a, *b;
  PetscInt           n;
  int                eq;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(x, &n));
  PetscCall(VecGetArrayRead(x, &a));
  PetscCall(VecGetArrayRead(y, &b));
  eq = !std::memcmp(a, b, sizeof(PetscScalar) * n);
  PetscCall(VecRestoreArrayRead(x, &a));
  PetscCall(VecRestoreArrayRead(y, &b));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &eq, 1, MPI_INT, MPI_LAND, PETSC_COMM_WORLD));
  *same = eq ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* adds w to A's diagonal on the owned rows i with lo <= (i mod side) / side < hi and the same for
   i / side (a square patch of the side x side cloth), w growing across the patch */
static PetscErrorCode AddPatchWeights(Mat A, PetscInt side, PetscReal lo, PetscReal hi, PetscReal w)
{
  PetscInt r0, r1;

  PetscFunctionBeginUser;
  PetscCall(MatGetOwnershipRange(A, &r0, &r1));
  for (PetscInt i = r0; i < r1; i++) {
    const PetscReal u = (PetscReal)(i % side) / side, v = (PetscReal)(i / side) / side;
    if (u >= lo && u < hi && v >= lo && v < hi) PetscCall(MatSetValue(A, i, i, w * (1 + 10 * (u - lo)), ADD_VALUES));
  }
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Compare(const char *what, Mat A, PC partial, PC full, Vec b, PetscMPIInt size, PetscInt expect_partial)
{
  PC        fresh;
  Mat       Ac;
  Vec       x1, x2, x3, r;
  PetscReal nb, nr, na, nx;
  PetscBool same12, same13;
  PetscInt  c0, c1;
  PetscLogDouble f0, f1, f2;

  PetscFunctionBeginUser;
  PetscCall(PartialCount(&c0, &f0));
  PetscCall(PCSetUp(partial));
  PetscCall(PartialCount(&c1, &f1));
  PetscCall(PCSetUp(full));
  PetscCall(PartialCount(&c1, &f2));
  PetscCall(MatDuplicate(A, MAT_COPY_VALUES, &Ac));
  PetscCall(TestLLTCreate(Ac, "fresh_", &fresh));
  for (Vec *v : {&x1, &x2, &x3, &r}) PetscCall(VecDuplicate(b, v));
  PetscCall(PCApply(partial, b, x1));
  PetscCall(PCApply(fresh, b, x2));
  PetscCall(PCApply(full, b, x3));
  PetscCall(SameBits(x1, x2, &same12));
  PetscCall(SameBits(x1, x3, &same13));
  PetscCall(MatMult(A, x1, r));
  PetscCall(VecAXPY(r, -1.0, b));
  PetscCall(VecNorm(r, NORM_2, &nr));
  PetscCall(VecNorm(b, NORM_2, &nb));
  PetscCall(VecNorm(x1, NORM_2, &nx));
  PetscCall(MatNorm(A, NORM_FROBENIUS, &na));
  NOTE("%s: refactored %.3g Mflop in place against %.3g in full\n", what, (f1 - f0) * 1e-6, (f2 - f1) * 1e-6);
  if (size == 1 && expect_partial > 0) CHECK(f1 - f0 < f2 - f1, "%s: the partial refactorization took %g flops, the full %g", what, f1 - f0, f2 - f1);
  NOTE("%s: relative residual %.2e, backward error |r| / (|A| |x| + |b|) %.2e; partial refactorizations %" PetscInt_FMT "; bitwise equal to a fresh factorization: %s, to a full refactorization: %s\n", what, (double)(nr / nb), (double)(nr / (na * nx + nb)), c1 - c0, same12 ? "yes" : "no", same13 ? "yes" : "no");
  CHECK(nr <= 1e-11 * nb, "%s: relative residual %g", what, (double)(nr / nb));
  CHECK(nr <= 1e-14 * (na * nx + nb), "%s: backward error %g", what, (double)(nr / (na * nx + nb)));
  CHECK(same12, "%s: the refactored PC's solve differs from a fresh factorization's", what);
  CHECK(same13, "%s: the refactored PC's solve differs from -pc_msimllt_partial 0's", what);
  if (expect_partial >= 0) CHECK(c1 - c0 == expect_partial, "%s: %" PetscInt_FMT " partial refactorizations, expected %" PetscInt_FMT, what, c1 - c0, expect_partial);
  PetscCall(PCDestroy(&fresh));
  PetscCall(MSimDestroy(&x1, &x2, &x3, &r, &Ac));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestScene(const char *opts, PetscInt side)
{
  TestSim      s;
  MSimImplicit imp;
  Mat          A, Af;
  PC           pp, pf;
  Vec          b;
  PetscMPIInt  size;
  PetscReal    a00;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(PetscOptionsSetValue(NULL, "-full_pc_msimllt_partial", "0"));
  /* refactorizations, not the low-rank update that fewer changed diagonal entries would take
     (test_llt_update tests that) */
  PetscCall(PetscOptionsSetValue(NULL, "-pc_msimllt_update", "0"));
  PetscCall(PetscOptionsSetValue(NULL, "-full_pc_msimllt_update", "0"));
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  imp->h = 1.0 / 30;
  PetscCall(MSimImplicitPDSetUp(imp));
  PetscCall(MatDuplicate(imp->A, MAT_COPY_VALUES, &A));
  PetscCall(MatDuplicate(imp->A, MAT_COPY_VALUES, &Af));
  PetscCall(TestLLTCreate(A, NULL, &pp));
  PetscCall(TestLLTCreate(Af, "full_", &pf));
  PetscCall(MatCreateVecs(A, &b, NULL));
  PetscCall(SetRandom(b, -1, 1));
  {
    PetscInt r0;
    PetscCall(MatGetOwnershipRange(A, &r0, NULL));
    a00 = 0;
    if (r0 == 0) PetscCall(MatGetValue(A, 0, 0, &a00));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &a00, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  }
  /* 1. contact weights, from a tenth to ten thousand times the diagonal, on a central patch */
  for (Mat M : {A, Af}) PetscCall(AddPatchWeights(M, side, 0.35, 0.65, 0.1 * a00));
  for (Mat M : {A, Af}) PetscCall(AddPatchWeights(M, side, 0.45, 0.55, 1e4 * a00));
  PetscCall(Compare("weights on a central patch", A, pp, pf, b, size, 1));
  /* 2. a patch's weights taken away, another's added */
  for (Mat M : {A, Af}) PetscCall(AddPatchWeights(M, side, 0.45, 0.55, -1e4 * a00));
  for (Mat M : {A, Af}) PetscCall(AddPatchWeights(M, side, 0.0, 0.2, 5 * a00));
  PetscCall(Compare("weights moved", A, pp, pf, b, size, 1));
  /* 3. nothing changed (if PETSc sets up again, a partial refactorization of no supernode) */
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY)); /* a new state, the same values */
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscCall(Compare("same values", A, pp, pf, b, size, -1));
  /* 4. an off-diagonal pair (a spring's stiffness), in the pattern */
  {
    PetscInt r0, r1, ncols;
    const PetscInt    *cols;
    const PetscScalar *vals;
    PetscInt           i = side * (side / 3) + side / 3, j = -1;
    PetscScalar        v = 0;
    PetscCall(MatGetOwnershipRange(A, &r0, &r1));
    if (i >= r0 && i < r1) {
      PetscCall(MatGetRow(A, i, &ncols, &cols, &vals));
      for (PetscInt k = 0; k < ncols; k++)
        if (cols[k] != i && cols[k] >= r0 && cols[k] < r1) {
          j = cols[k];
          v = vals[k];
          break;
        }
      PetscCall(MatRestoreRow(A, i, &ncols, &cols, &vals));
    }
    for (Mat M : {A, Af}) {
      if (j >= 0) {
        PetscCall(MatSetValue(M, i, j, 0.5 * v, ADD_VALUES));
        PetscCall(MatSetValue(M, j, i, 0.5 * v, ADD_VALUES));
        PetscCall(MatSetValue(M, i, i, -0.5 * v, ADD_VALUES)); /* stays diagonally dominant */
        PetscCall(MatSetValue(M, j, j, -0.5 * v, ADD_VALUES));
      }
      PetscCall(MatAssemblyBegin(M, MAT_FINAL_ASSEMBLY));
      PetscCall(MatAssemblyEnd(M, MAT_FINAL_ASSEMBLY));
    }
  }
  PetscCall(Compare("an off-diagonal pair", A, pp, pf, b, size, 1));
  PetscCall(PCDestroy(&pp));
  PetscCall(PCDestroy(&pf));
  PetscCall(MSimDestroy(&b, &A, &Af, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestLLTPartial(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestScene("-msim_cloth_n 41 -msim_fix none -msim_integrator implicit_euler", 41));
  PetscCall(TestScene("-msim_cloth_n 41 -msim_fix none -msim_integrator implicit_euler -pc_msimllt_relax 3 -pc_msimllt_max_width 64 -fresh_pc_msimllt_relax 3 -fresh_pc_msimllt_max_width 64 -full_pc_msimllt_relax 3 -full_pc_msimllt_max_width 64", 41));
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestLLTPartial)
