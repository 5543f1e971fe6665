/* Per-step monitors: a fixed-format line on rank 0 (no timings, so runs can be diffed) and a CSV
   with wall time. Energies: kinetic, potential (springs + gravity), total. */
#include <msim/output.h>

PetscErrorCode MSimMonitorCreate(MPI_Comm comm, MSimMonitor *mon)
{
  PetscFunctionBeginUser;
  mon->ascii       = PETSC_FALSE;
  mon->csv         = NULL;
  mon->csv_path[0] = 0;
  PetscOptionsBegin(comm, NULL, "msim monitors", NULL);
  PetscCall(PetscOptionsBool("-msim_monitor", "Print one line per step: energies, iterations, residual", NULL, mon->ascii, &mon->ascii, NULL));
  PetscCall(PetscOptionsString("-msim_monitor_csv", "Write a CSV per step: step,t,kinetic,potential,total,nonlinear_its,linear_its,residual,phi,wall_s", NULL, mon->csv_path, mon->csv_path, sizeof(mon->csv_path), NULL));
  PetscOptionsEnd();
  PetscCall(PetscTime(&mon->wall0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Opens the CSV (PATH.tmp, renamed when the run ends, so a killed run never leaves a half file);
   collective, so a file that cannot be written is an error on every rank. */
PetscErrorCode MSimMonitorSetUp(MPI_Comm comm, MSimMonitor *mon)
{
  PetscMPIInt rank;
  int         ok = 1;

  PetscFunctionBeginUser;
  if (!mon->csv_path[0]) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    char tmp[PETSC_MAX_PATH_LEN + 8];
    PetscCall(PetscSNPrintf(tmp, sizeof(tmp), "%s.tmp", mon->csv_path));
    mon->csv = fopen(tmp, "w");
    if (mon->csv) fprintf(mon->csv, "step,t,kinetic,potential,total,nonlinear_its,linear_its,residual,phi,wall_s\n");
    ok = mon->csv != NULL;
  }
  PetscCallMPI(MPI_Bcast(&ok, 1, MPI_INT, 0, comm));
  PetscCheck(ok, comm, PETSC_ERR_FILE_OPEN, "-msim_monitor_csv: cannot write %s.tmp", mon->csv_path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMonitorWanted(MSimMonitor *mon, PetscBool *want)
{
  PetscFunctionBeginUser;
  *want = (PetscBool)(mon->ascii || mon->csv_path[0]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMonitorWrite(MPI_Comm comm, MSimMonitor *mon, PetscInt step, PetscReal t, PetscReal kinetic, PetscReal potential, PetscInt nl, PetscInt lin, PetscReal residual, PetscReal phi)
{
  PetscLogDouble now;

  PetscFunctionBeginUser;
  if (mon->ascii) PetscCall(PetscPrintf(comm, "step %6" PetscInt_FMT " t %.6e kinetic %.10e potential %.10e total %.10e nl %" PetscInt_FMT " lin %" PetscInt_FMT " residual %.4e phi %.10e\n", step, (double)t, (double)kinetic, (double)potential, (double)(kinetic + potential), nl, lin, (double)residual, (double)phi));
  if (mon->csv) {
    PetscCall(PetscTime(&now));
    fprintf(mon->csv, "%" PetscInt_FMT ",%.9e,%.12e,%.12e,%.12e,%" PetscInt_FMT ",%" PetscInt_FMT ",%.6e,%.12e,%.6f\n", step, (double)t, (double)kinetic, (double)potential, (double)(kinetic + potential), nl, lin, (double)residual, (double)phi, now - mon->wall0);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMonitorDestroy(MPI_Comm comm, MSimMonitor *mon)
{
  PetscFunctionBeginUser;
  if (mon->csv) {
    char tmp[PETSC_MAX_PATH_LEN + 8];
    PetscCall(PetscSNPrintf(tmp, sizeof(tmp), "%s.tmp", mon->csv_path));
    PetscCheck(fclose(mon->csv) == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "-msim_monitor_csv: write to %s failed", tmp);
    mon->csv = NULL;
    PetscCheck(rename(tmp, mon->csv_path) == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "-msim_monitor_csv: cannot rename %s", tmp);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimViewFinal(MSimSystem sys, PetscReal t, Vec X)
{
  PetscViewer            viewer;
  PetscViewerFormat      format;
  PetscBool              set;
  Vec                    P;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsGetViewer(sys->comm, NULL, NULL, "-msim_view_final", &viewer, &format, &set));
  if (!set) PetscFunctionReturn(PETSC_SUCCESS);
  /* in input order, distributed by the scene's directory blocks: any size, any viewer (ASCII
     prints through rank 0 block by block; binary and HDF5 write in parallel) */
  PetscCall(MSimSystemNaturalPositions(sys, t, X));
  P = sys->natural;
  PetscCall(PetscViewerPushFormat(viewer, format));
  PetscCall(VecView(P, viewer));
  PetscCall(PetscViewerPopFormat(viewer));
  PetscCall(PetscViewerDestroy(&viewer));
  PetscFunctionReturn(PETSC_SUCCESS);
}
