/* msimllt's low-rank diagonal update (src/solvers/llt_update.h): where the matrix differs from the
   last factored one (the base) only on a few diagonal entries, the PC keeps the base's factor and
   corrects each solve by Woodbury's identity. On a 2-D Laplacian plus a small mass (SPD, condition
   number ~ 8 / mass), with diagonal entries raised (contact weights, up to 1e4 times the diagonal)
   and lowered (weights taken away, and below the base): every solve path (PCApply, PCMatApply in
   groups of four columns and a fifth, PCMSimLLTSolveInterleaved with three lanes) agrees with a
   PC factoring the same matrix from scratch to TOL relative (Woodbury's solve and the factor's
   each carry roundoff of order the condition number times eps: 1e-12 leaves a factor 10 over it
   here); an update is taken while at most -pc_msimllt_update_max_rank (here 16) entries changed,
   a refactorization for more, for an off-diagonal change or a new nonzero (a new pattern), whose
   solve is then the fresh one bit for bit. PCMSimLLTSetBaseDiagonal with PCMSimLLTGetBaseDiagonal's base reproduces an updated
   PC's solves bit for bit (what a restart needs). On several ranks the PC refactors as before (no
   update, no base diagonal). */
#include "harness.h"
#include <msim/solvers.h>
#include <cstring>
#include <vector>

#define SIDE 60
#define MASS 1e-2
#define TOL 1e-12

static PetscErrorCode EventCount(const char *name, PetscInt *count)
{
  PetscLogEvent      ev;
  PetscEventPerfInfo info;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventGetId(name, &ev));
  PetscCall(PetscLogEventGetPerfInfo(0, ev, &info));
  *count = info.count;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the 5-point Laplacian of a SIDE x SIDE grid plus MASS on the diagonal */
static PetscErrorCode Laplacian(Mat *A)
{
  PetscInt r0, r1;

  PetscFunctionBeginUser;
  PetscCall(MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, SIDE * SIDE, SIDE * SIDE, 5, NULL, 4, NULL, A));
  PetscCall(MatGetOwnershipRange(*A, &r0, &r1));
  for (PetscInt i = r0; i < r1; i++) {
    const PetscInt x = i % SIDE, y = i / SIDE;
    PetscCall(MatSetValue(*A, i, i, 4 + MASS, INSERT_VALUES));
    if (x > 0) PetscCall(MatSetValue(*A, i, i - 1, -1, INSERT_VALUES));
    if (x + 1 < SIDE) PetscCall(MatSetValue(*A, i, i + 1, -1, INSERT_VALUES));
    if (y > 0) PetscCall(MatSetValue(*A, i, i - SIDE, -1, INSERT_VALUES));
    if (y + 1 < SIDE) PetscCall(MatSetValue(*A, i, i + SIDE, -1, INSERT_VALUES));
  }
  PetscCall(MatAssemblyBegin(*A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A's diagonal at rows i := base value + w (base: the Laplacian's 4 + MASS), on the owning rank */
static PetscErrorCode SetDiagonal(Mat A, const std::vector<std::pair<PetscInt, PetscReal>> &rows)
{
  PetscInt r0, r1;

  PetscFunctionBeginUser;
  PetscCall(MatGetOwnershipRange(A, &r0, &r1));
  for (auto &p : rows)
    if (p.first >= r0 && p.first < r1) PetscCall(MatSetValue(A, p.first, p.first, 4 + MASS + p.second, INSERT_VALUES));
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A's symmetric pair (i, j) and (j, i) := a, on the owning ranks */
static PetscErrorCode SetPair(Mat A, PetscInt i, PetscInt j, PetscReal a)
{
  PetscInt r0, r1;

  PetscFunctionBeginUser;
  PetscCall(MatGetOwnershipRange(A, &r0, &r1));
  if (i >= r0 && i < r1) PetscCall(MatSetValue(A, i, j, a, INSERT_VALUES));
  if (j >= r0 && j < r1) PetscCall(MatSetValue(A, j, i, a, INSERT_VALUES));
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* max |x - y| / max |y| over every rank, and whether the bits agree */
static PetscErrorCode Difference(PetscInt n, const PetscScalar *x, const PetscScalar *y, PetscReal *rel, PetscBool *same)
{
  PetscReal d[2] = {0, 0};
  int       eq;

  PetscFunctionBeginUser;
  for (PetscInt i = 0; i < n; i++) {
    d[0] = PetscMax(d[0], PetscAbsScalar(x[i] - y[i]));
    d[1] = PetscMax(d[1], PetscAbsScalar(y[i]));
  }
  eq = !std::memcmp(x, y, sizeof(PetscScalar) * n);
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, d, 2, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &eq, 1, MPI_INT, MPI_LAND, PETSC_COMM_WORLD));
  *rel  = d[0] / d[1];
  *same = eq ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Difference of two Vecs' local arrays */
static PetscErrorCode VecDifference(Vec x, Vec y, PetscReal *rel, PetscBool *same)
{
  const PetscScalar *p, *q;
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(x, &n));
  PetscCall(VecGetArrayRead(x, &p));
  PetscCall(VecGetArrayRead(y, &q));
  PetscCall(Difference(n, p, q, rel, same));
  PetscCall(VecRestoreArrayRead(x, &p));
  PetscCall(VecRestoreArrayRead(y, &q));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* pc's solves of A (set up again first) against a fresh factorization's, by every path; expect
   (serially) that many updates built, and a refactorization (then bit for bit) if refactor */
static PetscErrorCode Compare(const char *what, Mat A, PC pc, PetscInt expect_update, PetscBool refactor)
{
  PC          fresh;
  Mat         Ac, B, X1, X2;
  Vec         b, x1, x2;
  PetscInt    u0, u1, n, N;
  PetscReal   rel, worst = 0;
  PetscBool   same, all_same = PETSC_TRUE;
  PetscMPIInt size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(EventCount("MSimLLTUpdate", &u0));
  PetscCall(PCSetUp(pc));
  PetscCall(EventCount("MSimLLTUpdate", &u1));
  PetscCall(MatDuplicate(A, MAT_COPY_VALUES, &Ac));
  PetscCall(TestLLTCreate(Ac, "fresh_", &fresh));
  PetscCall(MatCreateVecs(A, &b, &x1));
  PetscCall(VecDuplicate(x1, &x2));
  PetscCall(VecGetLocalSize(b, &n));
  PetscCall(VecGetSize(b, &N));
  PetscCall(SetRandom(b, -1, 1));
  /* PCApply */
  PetscCall(PCApply(pc, b, x1));
  PetscCall(PCApply(fresh, b, x2));
  PetscCall(VecDifference(x1, x2, &rel, &same));
  worst    = PetscMax(worst, rel);
  all_same = (PetscBool)(all_same && same);
  /* PCMatApply: five columns (a group of four, then one) */
  PetscCall(MatCreateDense(PETSC_COMM_WORLD, n, PETSC_DECIDE, N, 5, NULL, &B));
  PetscCall(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &X1));
  PetscCall(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &X2));
  {
    PetscScalar *p;
    PetscCall(MatDenseGetArrayWrite(B, &p));
    for (PetscInt i = 0; i < 5 * n; i++) p[i] = PetscSinReal(1.0 + 0.37 * i);
    PetscCall(MatDenseRestoreArrayWrite(B, &p));
  }
  PetscCall(PCMatApply(pc, B, X1));
  PetscCall(PCMatApply(fresh, B, X2));
  {
    const PetscScalar *p, *q;
    PetscCall(MatDenseGetArrayRead(X1, &p));
    PetscCall(MatDenseGetArrayRead(X2, &q));
    PetscCall(Difference(5 * n, p, q, &rel, &same));
    PetscCall(MatDenseRestoreArrayRead(X1, &p));
    PetscCall(MatDenseRestoreArrayRead(X2, &q));
    worst    = PetscMax(worst, rel);
    all_same = (PetscBool)(all_same && same);
  }
  /* three interleaved lanes */
  {
    std::vector<PetscScalar> bi(3 * n), y1(3 * n), y2(3 * n);
    for (PetscInt i = 0; i < 3 * n; i++) bi[i] = PetscCosReal(0.5 + 0.11 * i);
    PetscCall(PCMSimLLTSolveInterleaved(pc, 3, bi.data(), y1.data()));
    PetscCall(PCMSimLLTSolveInterleaved(fresh, 3, bi.data(), y2.data()));
    PetscCall(Difference(3 * n, y1.data(), y2.data(), &rel, &same));
    worst    = PetscMax(worst, rel);
    all_same = (PetscBool)(all_same && same);
  }
  NOTE("%s: %" PetscInt_FMT " update(s) built; solves against a fresh factorization's: max relative difference %.2e, bit for bit: %s\n", what, u1 - u0, (double)worst, all_same ? "yes" : "no");
  CHECK(worst <= TOL, "%s: the solves differ from a fresh factorization's by %g relative", what, (double)worst);
  const PetscInt want = size > 1 ? 0 : expect_update;
  CHECK(u1 - u0 == want, "%s: %" PetscInt_FMT " updates built, expected %" PetscInt_FMT, what, u1 - u0, want);
  if (refactor || size > 1) CHECK(all_same, "%s: refactored, yet the solves are not a fresh factorization's bits", what);
  PetscCall(PCDestroy(&fresh));
  PetscCall(MSimDestroy(&b, &x1, &x2, &Ac, &B, &X1, &X2));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestLLTUpdate(void)
{
  Mat         A;
  PC          pc;
  PetscMPIInt size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(PetscOptionsClear(NULL));
  PetscCall(PetscOptionsInsertString(NULL, "-pc_msimllt_update_max_rank 16"));
  PetscCall(Laplacian(&A));
  PetscCall(TestLLTCreate(A, NULL, &pc));
  /* rows spread over the grid (and over both ranks' halves) */
  auto row = [](PetscInt k) { return (PetscInt)((37 * k + 11) % (SIDE * SIDE)); };
  std::vector<std::pair<PetscInt, PetscReal>> w;
  /* 1. six contact weights, 0.1 to 1e4 times the diagonal: an update of rank 6 */
  for (PetscInt k = 0; k < 6; k++) w.emplace_back(row(k), 4 * PetscPowReal(10.0, k - 1));
  PetscCall(SetDiagonal(A, w));
  PetscCall(Compare("6 weights added", A, pc, 1, PETSC_FALSE));
  /* 2. three of them taken away again (back to the base: no longer changed), four rows lowered
        below the base by half the mass (negative changes): rank 3 + 4 = 7 */
  std::vector<std::pair<PetscInt, PetscReal>> v;
  for (PetscInt k = 0; k < 3; k++) v.emplace_back(row(k), 0);
  for (PetscInt k = 10; k < 14; k++) v.emplace_back(row(k), -0.5 * MASS);
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("3 weights removed, 4 rows lowered", A, pc, 1, PETSC_FALSE));
  /* 3. set up again on the same values: nothing built */
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscCall(Compare("the same values", A, pc, 0, PETSC_FALSE));
  /* 4. forty rows weighted: more than 16 changed, a (partial) refactorization, the new base */
  v.clear();
  for (PetscInt k = 20; k < 60; k++) v.emplace_back(row(k), 40.0 * (1 + k % 7));
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("40 weights added", A, pc, 0, PETSC_TRUE));
  /* 5. five of those weights taken away (negative changes of 40 to 280 against the new base) */
  v.clear();
  for (PetscInt k = 20; k < 25; k++) v.emplace_back(row(k), 0);
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("5 weights removed", A, pc, 1, PETSC_FALSE));
  /* 6. a restart: a PC given the base's diagonal solves as the updated one, bit for bit */
  {
    Vec       d;
    PetscBool has;
    Mat       Ar;
    PC        pr;
    PetscCall(MatCreateVecs(A, &d, NULL));
    PetscCall(PCMSimLLTGetBaseDiagonal(pc, d, &has));
    CHECK(has == (size == 1), "the base diagonal: has %d on %d ranks", (int)has, (int)size);
    PetscCall(MatDuplicate(A, MAT_COPY_VALUES, &Ar));
    PetscCall(PCCreate(PETSC_COMM_WORLD, &pr));
    PetscCall(PCSetType(pr, "msimllt"));
    PetscCall(PCSetOperators(pr, Ar, Ar));
    if (has) PetscCall(PCMSimLLTSetBaseDiagonal(pr, d));
    PetscCall(PCSetUp(pr));
    Vec       b, x1, x2;
    PetscReal rel;
    PetscBool same;
    PetscCall(MatCreateVecs(A, &b, &x1));
    PetscCall(VecDuplicate(x1, &x2));
    PetscCall(SetRandom(b, -1, 1));
    PetscCall(PCApply(pc, b, x1));
    PetscCall(PCApply(pr, b, x2));
    PetscCall(VecDifference(x1, x2, &rel, &same));
    NOTE("restart from the base diagonal: relative difference %.2e, bit for bit: %s\n", (double)rel, same ? "yes" : "no");
    CHECK(same, "a PC given the base diagonal solves differently (relative %g)", (double)rel);
    PetscCall(PCDestroy(&pr));
    PetscCall(MSimDestroy(&b, &x1, &x2, &d, &Ar));
  }
  /* 7. an off-diagonal pair changed: a refactorization */
  PetscCall(SetPair(A, SIDE * (SIDE / 2) + SIDE / 3, SIDE * (SIDE / 2) + SIDE / 3 + 1, -0.5));
  PetscCall(Compare("an off-diagonal pair", A, pc, 0, PETSC_TRUE));
  /* 8. a weight of 1e6 x the diagonal added (an update), then refactored into the base by 40
        more rows, then removed: C = 1/d + (B^-1)_jj would cancel (about eps |d| / a_jj lost),
        so the removal refactors (whose solves match a fresh factorization's bits) */
  v.clear();
  v.emplace_back(row(70), 4e6);
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("a weight of 1e6 x the diagonal added", A, pc, 1, PETSC_FALSE));
  v.clear();
  for (PetscInt k = 80; k < 120; k++) v.emplace_back(row(k), 40.0);
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("40 more weights (the large one now in the base)", A, pc, 0, PETSC_TRUE));
  v.clear();
  v.emplace_back(row(70), 0);
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("the weight of 1e6 x the diagonal removed", A, pc, 0, PETSC_TRUE));
  /* 9. a new nonzero pair (A's pattern changed, which the PC's kept lower triangle must see, not
        only its changed values): a new analysis and factorization; then a weight on the new
        pattern, an update again */
  PetscCall(MatSetOption(A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE));
  PetscCall(SetPair(A, SIDE * (SIDE / 4) + 5, SIDE * (SIDE / 4) + 7, -0.25));
  PetscCall(Compare("a new nonzero pair", A, pc, 0, PETSC_TRUE));
  v.clear();
  v.emplace_back(row(140), 40.0);
  PetscCall(SetDiagonal(A, v));
  PetscCall(Compare("a weight on the new pattern", A, pc, 1, PETSC_FALSE));
  /* 10. one diagonal made negative (A indefinite) by a diagonal change alone: not an update (C's
        inertia differs from D's), the factorization's error as without updates */
  {
    PetscErrorCode ierr;
    v.clear();
    v.emplace_back(row(130), -3.0 - 4 - MASS); /* SetDiagonal adds 4 + MASS: the diagonal is -3 */
    PetscCall(SetDiagonal(A, v));
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = PCSetUp(pc);
    PetscCall(PetscPopErrorHandler());
    CHECK(ierr == PETSC_ERR_MAT_CH_ZRPVT, "an indefinite matrix reached by a diagonal change: PCSetUp returned %d, not the non-positive pivot error", (int)ierr);
    NOTE("an indefinite matrix reached by a diagonal change: PCSetUp's error %d (PETSC_ERR_MAT_CH_ZRPVT %d)\n", (int)ierr, (int)PETSC_ERR_MAT_CH_ZRPVT);
  }
  PetscCall(PCDestroy(&pc));
  PetscCall(MatDestroy(&A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestLLTUpdate)
