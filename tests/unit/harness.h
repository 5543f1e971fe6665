/* Minimal test harness for msim's tests: checks that count failures, a scene/system/integrator
   built from an options string, and a closing line "N passed, N failed". */
#pragma once
#include <msim/run.h>
#include <msim/implicit.h>
#include <msim/spectrum.h>
#include <msim/init.h>
#include <msim/destroy.h>
#include <slepcsys.h>
#include <cmath>
#include <algorithm>
#include <unistd.h>

static int msim_test_passed = 0, msim_test_failed = 0;

#define CHECK(cond, ...) \
  do { \
    if (cond) msim_test_passed++; \
    else { \
      msim_test_failed++; \
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "FAIL %s:%d: ", __FILE__, __LINE__)); \
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, __VA_ARGS__)); \
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "\n")); \
    } \
  } while (0)

#define NOTE(...) PetscCall(PetscPrintf(PETSC_COMM_WORLD, __VA_ARGS__))

typedef struct {
  MSimSystem     sys;
  MSimIntegrator integ;
  Vec            X, V;
  PetscReal      dt;   /* the integrator's step */
  PetscMPIInt    rank; /* in PETSC_COMM_WORLD */
} TestSim;

/* Replace the options database with opts and build everything. */
static inline PetscErrorCode TestSimCreate(const char *opts, TestSim *s)
{
  MSimScene scene;
  Vec       X0, V0;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsClear(NULL));
  PetscCall(PetscOptionsInsertString(NULL, opts));
  PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene));
  PetscCall(MSimSystemCreate(PETSC_COMM_WORLD, scene, &s->sys));
  PetscCall(MSimSceneDestroy(&scene));
  PetscCall(MSimIntegratorCreate(s->sys, &s->integ));
  PetscCall(MSimIntegratorSetFromOptions(s->integ));
  PetscCall(MSimSystemGetInitialState(s->sys, &X0, &V0));
  PetscCall(VecDuplicate(X0, &s->X));
  PetscCall(VecDuplicate(V0, &s->V));
  PetscCall(VecCopy(X0, s->X));
  PetscCall(VecCopy(V0, s->V));
  PetscCall(MSimIntegratorGetTimeStep(s->integ, &s->dt));
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &s->rank));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* v uniform in [lo, hi], from a fresh generator at PETSc's default seed: the same draw every run */
static inline PetscErrorCode SetRandom(Vec v, PetscReal lo, PetscReal hi)
{
  PetscRandom r;

  PetscFunctionBeginUser;
  PetscCall(PetscRandomCreate(PetscObjectComm((PetscObject)v), &r));
  PetscCall(PetscRandomSetInterval(r, lo, hi));
  PetscCall(VecSetRandom(v, r));
  PetscCall(PetscRandomDestroy(&r));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* a PC of msim's sparse Cholesky (msimllt) on A, with an options prefix (NULL: none), set up */
static inline PetscErrorCode TestLLTCreate(Mat A, const char *prefix, PC *pc)
{
  PetscFunctionBeginUser;
  PetscCall(PCCreate(PETSC_COMM_WORLD, pc));
  PetscCall(PCSetOptionsPrefix(*pc, prefix));
  PetscCall(PCSetType(*pc, "msimllt"));
  PetscCall(PCSetOperators(*pc, A, A));
  PetscCall(PCSetUp(*pc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* g . dX, g the problem's residual at X, and (Phi(X + eps dX) - Phi(X - eps dX)) / (2 eps): equal to
   O(eps^2) where g is the gradient of Phi */
static inline PetscErrorCode ObjectiveFDError(MSimImplicit imp, Vec X, Vec dX, PetscReal eps, PetscReal *gd, PetscReal *fd)
{
  Vec       Xe, G;
  PetscReal pp, pm;

  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(X, &Xe));
  PetscCall(VecDuplicate(X, &G));
  PetscCall(VecWAXPY(Xe, eps, dX, X));
  PetscCall(MSimImplicitObjective(imp, Xe, &pp));
  PetscCall(VecWAXPY(Xe, -eps, dX, X));
  PetscCall(MSimImplicitObjective(imp, Xe, &pm));
  PetscCall(MSimImplicitResidual(imp, X, G));
  PetscCall(VecDot(G, dX, gd));
  *fd = (pp - pm) / (2 * eps);
  PetscCall(VecDestroy(&Xe));
  PetscCall(VecDestroy(&G));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* |J dX - (g(X + eps dX) - g(X - eps dX)) / (2 eps)| and |J dX|: J, assembled at X, against central
   differences of the problem's residual along dX (err / nrm is O(eps^2) for an exact Jacobian) */
static inline PetscErrorCode JacobianFDError(MSimImplicit imp, Mat J, Vec X, Vec dX, PetscReal eps, PetscReal *err, PetscReal *nrm)
{
  Vec Xp, Gp, Gm, JdX;

  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(X, &Xp));
  PetscCall(VecDuplicate(X, &Gp));
  PetscCall(VecDuplicate(X, &Gm));
  PetscCall(VecDuplicate(X, &JdX));
  PetscCall(VecWAXPY(Xp, eps, dX, X));
  PetscCall(MSimImplicitResidual(imp, Xp, Gp));
  PetscCall(VecWAXPY(Xp, -eps, dX, X));
  PetscCall(MSimImplicitResidual(imp, Xp, Gm));
  PetscCall(VecAXPY(Gp, -1.0, Gm));
  PetscCall(VecScale(Gp, 1.0 / (2 * eps)));
  PetscCall(MatMult(J, dX, JdX));
  PetscCall(VecNorm(JdX, NORM_2, nrm));
  PetscCall(VecAXPY(Gp, -1.0, JdX));
  PetscCall(VecNorm(Gp, NORM_2, err));
  PetscCall(MSimDestroy(&JdX, &Gm, &Gp, &Xp));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static inline PetscErrorCode TestSimDestroy(TestSim *s)
{
  PetscFunctionBeginUser;
  PetscCall(MSimDestroy(&s->X, &s->V));
  PetscCall(MSimIntegratorDestroy(&s->integ));
  PetscCall(MSimSystemDestroy(&s->sys));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* so that a test's clean-up is one MSimDestroy(...) line (msim/destroy.h) */
static inline PetscErrorCode MSimDestroyOne(TestSim *s)
{
  return TestSimDestroy(s);
}
static inline PetscErrorCode MSimDestroyOne(MSimImplicit *imp)
{
  return MSimImplicitDestroy(imp);
}

/* Run the test body; print the closing line; exit non-zero on any failure. */
#define MSIM_TEST_MAIN(body) \
  int main(int argc, char **argv) \
  { \
    PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL)); \
    PetscCall(MSimInitialize()); \
    PetscCall(body()); \
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%d passed, %d failed\n", msim_test_passed, msim_test_failed)); \
    PetscCall(MSimFinalize()); \
    PetscCall(SlepcFinalize()); \
    return msim_test_failed ? 1 : 0; \
  }
