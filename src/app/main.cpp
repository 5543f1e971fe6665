/* msim: mass-spring simulation on PETSc. Creates the objects from options, runs, destroys. */
#include <msim/init.h>
#include <msim/options.h>
#include <msim/run.h>
#include <msim/spectrum.h>
#include <msim/signals.h>
#include <slepcsys.h>

static const char help[] = "msim: mass-spring simulator on PETSc (cloth, chains, surfaces and tet solids; obstacles and self-contact; explicit, implicit and PETSc TS integrators).\n"
                           "Usage: mpirun -n 2 ./msim -options_file examples/cloth.opts\n";

static PetscErrorCode MSimMain(void)
{
  MSimScene      scene;
  MSimSystem     sys;
  MSimIntegrator integ;
  MSimRunInfo    info = {};
  Vec            X, V, X0, V0;
  PetscBool      spectrum_only, view = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(MSimInitialize());
  PetscCall(MSimCheckOptionsFileRepeats(PETSC_COMM_WORLD));
  PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene));
  PetscCall(MSimSystemCreate(PETSC_COMM_WORLD, scene, &sys));
  PetscCall(MSimSceneDestroy(&scene));
  PetscCall(MSimIntegratorCreate(sys, &integ));
  PetscCall(MSimIntegratorSetFromOptions(integ));
  PetscOptionsBegin(PETSC_COMM_WORLD, NULL, "msim program", NULL);
  PetscCall(PetscOptionsBool("-msim_view", "Print the integrator and its solvers (and PD factorization count) at the end", NULL, view, &view, NULL));
  {
    PetscBool traceback = PETSC_FALSE; /* read by MSimInitialize; listed here for -help */
    PetscCall(PetscOptionsBool("-msim_traceback", "Print PETSc's full error traceback instead of one line", NULL, traceback, &traceback, NULL));
  }
  PetscOptionsEnd();
  PetscCall(MSimSystemGetInitialState(sys, &X0, &V0));
  PetscCall(VecDuplicate(X0, &X));
  PetscCall(VecDuplicate(V0, &V));
  PetscCall(VecCopy(X0, X));
  PetscCall(VecCopy(V0, V));
  PetscCall(MSimSpectrumFromOptions(sys, X, &spectrum_only));
  if (!spectrum_only) {
    PetscErrorCode rerr = MSimRun(sys, integ, X, V, &info);
    if (rerr) {
      /* the error line is out; closing the integrator keeps what its monitors wrote, such as the
         per-iteration history of the step that failed (-msim_monitor_convergence), under the
         name the user gave; the rest is destroyed too, so no object outlives the run */
      PetscCall(VecDestroy(&X));
      PetscCall(VecDestroy(&V));
      PetscCall(MSimIntegratorDestroy(&integ));
      PetscCall(MSimSystemDestroy(&sys));
      /* a divergence may come of a misspelled option (-msim_stifness left the default stiffness):
         named after the error line, as a finished run names it. Only there: an error at set-up
         comes before the options msim would read after it, which are not misspelled */
      if (info.diverged) PetscCall(MSimWarnUnusedOptions(PETSC_COMM_WORLD));
      return rerr;
    }
  }
  if (view) PetscCall(MSimIntegratorView(integ, PETSC_VIEWER_STDOUT_WORLD));
  PetscCall(VecDestroy(&X));
  PetscCall(VecDestroy(&V));
  PetscCall(MSimIntegratorDestroy(&integ));
  PetscCall(MSimSystemDestroy(&sys));
  PetscCall(MSimWarnUnusedOptions(PETSC_COMM_WORLD));
  PetscCall(MSimFinalize());
  PetscFunctionReturn(PETSC_SUCCESS);
}

int main(int argc, char **argv)
{
  PetscErrorCode ierr;

  MSimSetMallocDefaults(argc, argv);
  MSimSetMPIDefaults();
  /* MPI first, so options files can be checked before PETSc reads them (then PETSc leaves
     MPI_Finalize to us) */
  MPI_Init(&argc, &argv);
  if (MSimCheckOptionsFiles(argc, argv)) {
    MPI_Finalize();
    return 1;
  }
  MSimInitializeBegin();
  if (MSimInitializeEnd(SlepcInitialize(&argc, &argv, NULL, help))) return 1;
  ierr = MSimMain();
  /* the error was reported as one line by msim's handler; finalize so MPI exits cleanly */
  ierr = (PetscErrorCode)(SlepcFinalize() || ierr);
  MPI_Finalize();
  return ierr ? (MSimStoppedByClosedOutput() ? 141 : 1) : 0;
}
