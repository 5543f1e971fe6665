/* Package initialization: the one place that includes every layer, so that each registers its
   types here (scenes, partitioners, integrators, solvers) and none of util, scene or springs
   needs to know the others. Also the process settings made with it: log events, one BLAS thread,
   the one-line error handler (errors.cpp). */
#include <msim/init.h>
#include <msim/log.h>
#include <msim/errors.h>
#include <msim/scene.h>
#include <msim/partition.h>
#include <msim/integrator.h>
#include <msim/solvers.h>
#include <dlfcn.h>
#include <cstdlib>

/* OpenBLAS's threads fight the MPI ranks for the cores and make PETSc's small BLAS-1 calls slow
   (a 30k-entry VecAXPY took 1.5 ms with two threads on two cores): one thread per rank unless
   the user set OPENBLAS_NUM_THREADS. */
static void MSimSingleThreadedBLAS(void)
{
  if (getenv("OPENBLAS_NUM_THREADS")) return;
  void (*set)(int) = (void (*)(int))dlsym(RTLD_DEFAULT, "openblas_set_num_threads");
  if (set) set(1);
}

static PetscBool msim_handler_pushed = PETSC_FALSE; /* msim's one-line error handler is on the stack */

PetscErrorCode MSimInitialize(void)
{
  PetscBool trace = PETSC_FALSE;

  PetscFunctionBeginUser;
  MSimSingleThreadedBLAS();
  /* a direct look-up, not an options block: it chooses the error handler, which must be in place
     before any object exists and before any options block runs, so that their errors are one line
     too; it is listed for -help by main's "msim program" block */
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-msim_traceback", &trace, NULL));
  if (!trace) PetscCall(PetscPushErrorHandler(MSimErrorHandler, NULL));
  msim_handler_pushed = (PetscBool)!trace;
  PetscCall(MSimLogRegister());
  PetscCall(MSimSceneRegisterAll());
  PetscCall(MSimPartitionerRegisterAll());
  PetscCall(MSimIntegratorRegisterAll());
  PetscCall(MSimSolversRegisterAll());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimFinalize(void)
{
  PetscFunctionBeginUser;
  /* popped so that -malloc_dump finds nothing of msim's left */
  if (msim_handler_pushed) PetscCall(PetscPopErrorHandler());
  msim_handler_pushed = PETSC_FALSE;
  PetscCall(MSimSceneFinalizePackage());
  PetscCall(MSimPartitionerFinalizePackage());
  PetscCall(MSimIntegratorFinalizePackage());
  PetscFunctionReturn(PETSC_SUCCESS);
}
