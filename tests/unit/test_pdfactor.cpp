/* The PD factorization: msim's msimllt (serial supernodal Cholesky; on several ranks local factors
   plus the dense interface Schur complement) solves (M + h^2 L) x = b for the x, y and z columns
   as MUMPS's Cholesky does, to 1e-10 relative, through each of its entry points (the interleaved
   fast path PD uses, PCApply on one column, PCMatApply on several), on cloths and a chain, at any
   rank count (ctest runs it at 1, 2 and 3), with the supernodes as they come, merged by the
   default rule, and merged far beyond it (the solves then carry many explicit zeros). */
#include "harness.h"
/* the test compares the PD factorization itself: it sets the problem's step before PDSetUp and
   reads the PD matrix and KSP the implicit problem keeps, which no function exposes */
#include <msim/private/implicitimpl.h>

static PetscErrorCode CompareWithMUMPS(const char *scene, PetscInt64 *entries, PetscInt *supernodes)
{
  TestSim      s;
  MSimImplicit imp;
  KSP          ref;
  PC           pc, llt;
  Vec          b, x, xref, bs, xs;
  Mat          B, X;
  PetscReal    nrm, d;
  PetscRandom  rnd;

  PetscFunctionBeginUser;
  PetscCall(TestSimCreate(scene, &s));
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  imp->h = 1.0 / 30;
  PetscCall(MSimImplicitPDSetUp(imp));
  PetscCall(KSPGetPC(imp->pdksp, &llt));
  PetscCall(PCMSimLLTGetFactorSize(llt, entries, supernodes));
  PetscCall(KSPCreate(PETSC_COMM_WORLD, &ref));
  PetscCall(KSPSetOperators(ref, imp->A, imp->A));
  PetscCall(KSPSetType(ref, KSPPREONLY));
  PetscCall(KSPGetPC(ref, &pc));
  PetscCall(PCSetType(pc, PCCHOLESKY));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscCall(VecDuplicate(s.X, &b));
  PetscCall(VecDuplicate(s.X, &x));
  PetscCall(VecDuplicate(s.X, &xref));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(VecSetRandom(b, rnd));
  PetscCall(MatCreateVecs(imp->A, &xs, &bs));
  for (PetscInt c = 0; c < 3; c++) { /* the reference, column by column */
    PetscCall(VecStrideGather(b, c, bs, INSERT_VALUES));
    PetscCall(KSPSolve(ref, bs, xs));
    PetscCall(VecStrideScatter(xs, c, xref, INSERT_VALUES));
  }
  PetscCall(VecNorm(xref, NORM_2, &nrm));
  /* the interleaved path of the PD global step */
  PetscCall(MSimImplicitPDSolve(imp, b, NULL, x));
  PetscCall(VecAXPY(x, -1.0, xref));
  PetscCall(VecNorm(x, NORM_2, &d));
  NOTE("%s: msimllt (x, y, z together) vs MUMPS: relative difference %.2e\n", scene, (double)(d / nrm));
  CHECK(d <= 1e-10 * nrm, "%s: msimllt differs from MUMPS by %g relative", scene, (double)(d / nrm));
  /* PCApply, one column */
  PetscCall(VecStrideGather(b, 1, bs, INSERT_VALUES));
  PetscCall(PCApply(llt, bs, xs));
  PetscCall(VecStrideGather(xref, 1, bs, INSERT_VALUES));
  PetscCall(VecAXPY(xs, -1.0, bs));
  PetscCall(VecNorm(xs, NORM_2, &d));
  PetscCall(VecNorm(bs, NORM_2, &nrm));
  CHECK(d <= 1e-10 * nrm, "%s: msimllt PCApply differs from MUMPS by %g relative", scene, (double)(d / nrm));
  /* PCMatApply, five columns (a group of four and one) */
  {
    PetscInt           nloc, N;
    const PetscScalar *xr;
    PetscScalar       *bb;
    PetscCall(VecGetLocalSize(bs, &nloc));
    PetscCall(VecGetSize(bs, &N));
    PetscCall(MatCreateDense(PETSC_COMM_WORLD, nloc, PETSC_DECIDE, N, 5, NULL, &B));
    PetscCall(MatCreateDense(PETSC_COMM_WORLD, nloc, PETSC_DECIDE, N, 5, NULL, &X));
    PetscCall(MatDenseGetArrayWrite(B, &bb));
    for (PetscInt q = 0; q < 5; q++) {
      PetscCall(VecStrideGather(b, q % 3, bs, INSERT_VALUES));
      PetscCall(VecGetArrayRead(bs, &xr));
      for (PetscInt i = 0; i < nloc; i++) bb[q * nloc + i] = xr[i];
      PetscCall(VecRestoreArrayRead(bs, &xr));
    }
    PetscCall(MatDenseRestoreArrayWrite(B, &bb));
    PetscCall(PCMatApply(llt, B, X));
    for (PetscInt q = 0; q < 5; q++) {
      Vec col;
      PetscCall(MatDenseGetColumnVecRead(X, q, &col));
      PetscCall(VecStrideGather(xref, q % 3, bs, INSERT_VALUES));
      PetscCall(VecWAXPY(xs, -1.0, bs, col));
      PetscCall(MatDenseRestoreColumnVecRead(X, q, &col));
      PetscCall(VecNorm(xs, NORM_2, &d));
      PetscCall(VecNorm(bs, NORM_2, &nrm));
      CHECK(d <= 1e-10 * nrm, "%s: msimllt PCMatApply column %" PetscInt_FMT " differs from MUMPS by %g relative", scene, q, (double)(d / nrm));
    }
    PetscCall(MSimDestroy(&B, &X));
  }
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(MSimDestroy(&b, &x, &xref, &bs, &xs, &ref, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestPDFactor(void)
{
  const char *scenes[] = {"-msim_cloth_n 31 -msim_integrator implicit_euler", "-msim_cloth_n 24 -msim_fix edge -msim_damping 0.5 -msim_drag 0.01 -msim_integrator implicit_euler",
                          "-msim_scene chain -msim_chain_n 40 -msim_fix corners -msim_integrator implicit_euler"};
  /* supernodes as they come, the default merging, and merging far beyond it */
  const char *merging[] = {" -pd_pc_msimllt_relax 0", "", " -pd_pc_msimllt_relax 3 -pd_pc_msimllt_max_width 64"};
  char        opts[512];

  PetscFunctionBeginUser;
  for (int sc = 0; sc < 3; sc++) {
    PetscInt64 entries[3];
    PetscInt   supernodes[3];
    for (int m = 0; m < 3; m++) {
      PetscCall(PetscSNPrintf(opts, sizeof(opts), "%s%s", scenes[sc], merging[m]));
      PetscCall(CompareWithMUMPS(opts, &entries[m], &supernodes[m]));
    }
    NOTE("%s: rank 0's factor: %" PetscInt64_FMT " / %" PetscInt64_FMT " / %" PetscInt64_FMT " entries in %" PetscInt_FMT " / %" PetscInt_FMT " / %" PetscInt_FMT " supernodes (unmerged / default / far)\n", scenes[sc], entries[0], entries[1], entries[2], supernodes[0], supernodes[1], supernodes[2]);
    /* a cloth's factor has narrow supernodes to merge; a chain's has columns of one or two
       entries, where only merging far beyond the default pays for its zeros */
    if (sc < 2) CHECK(supernodes[2] < supernodes[1] && supernodes[1] < supernodes[0], "%s: merging did not reduce the supernodes (%" PetscInt_FMT ", %" PetscInt_FMT ", %" PetscInt_FMT ")", scenes[sc], supernodes[0], supernodes[1], supernodes[2]);
    CHECK(entries[0] <= entries[1] && entries[1] <= (PetscInt64)(1.3 * entries[0]) + 1, "%s: the default merging stored %" PetscInt64_FMT " entries, beyond 1.3 x %" PetscInt64_FMT, scenes[sc], entries[1], entries[0]);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestPDFactor)
