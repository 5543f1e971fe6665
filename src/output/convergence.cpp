#include <msim/convergence.h>
#include <msim/output.h>
#include <msim/errors.h>
#include <msim/private/systemimpl.h>
#include <cstdio>
#include <string>

struct _n_MSimConvergenceMonitor {
  MSimSystem          sys;
  MSimConvergenceEval eval;
  void               *eval_ctx;
  char           path[PETSC_MAX_PATH_LEN];
  FILE          *fp;
  PetscBool      opened;
  PetscInt       step, first_step;
  PetscLogDouble start, spent; /* step start, time spent inside the monitor */
};

PetscErrorCode MSimConvergenceMonitorCreate(MSimSystem sys, MSimConvergenceMonitor *mon)
{
  char      path[PETSC_MAX_PATH_LEN] = "";
  PetscBool set;

  PetscFunctionBeginUser;
  *mon = NULL;
  PetscOptionsBegin(sys->comm, NULL, "msim convergence monitor", NULL);
  PetscCall(PetscOptionsString("-msim_monitor_convergence", "CSV per nonlinear iteration: step,iteration,wall_s,phi,gnorm", NULL, path, path, sizeof(path), &set));
  PetscOptionsEnd();
  if (!set || !path[0]) PetscFunctionReturn(PETSC_SUCCESS);
  *mon        = new _n_MSimConvergenceMonitor();
  (*mon)->sys = sys;
  PetscCall(PetscStrncpy((*mon)->path, path, sizeof((*mon)->path)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MSimConvergenceMonitorIterate(SNES snes, PetscInt its, PetscReal fnorm, void *ctx)
{
  MSimConvergenceMonitor mon = (MSimConvergenceMonitor)ctx;
  PetscLogDouble         t0, t1;
  PetscReal              phi, gnorm;
  Vec                    X;

  PetscFunctionBeginUser;
  PetscCall(PetscTime(&t0));
  PetscCall(SNESGetSolution(snes, &X));
  PetscCall((*mon->eval)(mon->eval_ctx, X, &phi, &gnorm));
  PetscBool written = PETSC_TRUE;
  if (mon->sys->rank == 0) {
    /* rows flushed as they are made: a killed run keeps its history up to the last row */
    const int wrote = fprintf(mon->fp, "%" PetscInt_FMT ",%" PetscInt_FMT ",%.6e,%.17e,%.6e\n", mon->step, its, t0 - mon->start - mon->spent, (double)phi, (double)gnorm);
    written         = (PetscBool)(wrote > 0 && fflush(mon->fp) == 0);
  }
  /* a failed write (disk full) is an error on every rank: rank 0's alone left the others in the
     solver's next collectives, waiting for ever */
  PetscCall(MSimCollectiveCheck(mon->sys->comm, written, std::string("-msim_monitor_convergence: write to ") + mon->path + " failed"));
  PetscCall(PetscTime(&t1));
  mon->spent += t1 - t0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimConvergenceMonitorAttach(MSimConvergenceMonitor mon, SNES snes, MSimConvergenceEval eval, void *ctx)
{
  PetscFunctionBeginUser;
  mon->eval     = eval;
  mon->eval_ctx = ctx;
  PetscCall(SNESMonitorSet(snes, MSimConvergenceMonitorIterate, mon, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Opened by rank 0 with every rank told, before the run writes anything (the integrator's
   openfiles) or at the latest before the first step's solve: a file that cannot be written stops
   the run on every rank with one line, not rank 0 alone inside a solve. */
PetscErrorCode MSimConvergenceMonitorOpen(MSimConvergenceMonitor mon, PetscInt first_step)
{
  int ok = 1;

  PetscFunctionBeginUser;
  if (!mon || mon->opened) PetscFunctionReturn(PETSC_SUCCESS);
  if (mon->sys->rank == 0) {
    PetscBool kept = PETSC_FALSE;
    if (first_step > 1) PetscCall(MSimCSVKeepSteps(mon->path, first_step - 1, NULL, &kept, NULL, NULL));
    mon->fp = fopen(mon->path, kept ? "a" : "w");
    ok      = mon->fp && (kept || (fprintf(mon->fp, "step,iteration,wall_s,phi,gnorm\n") > 0 && fflush(mon->fp) == 0));
  }
  PetscCallMPI(MPI_Bcast(&ok, 1, MPI_INT, 0, mon->sys->comm));
  PetscCheck(ok, mon->sys->comm, PETSC_ERR_FILE_OPEN, "-msim_monitor_convergence: cannot write %s", mon->path);
  mon->opened = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimConvergenceMonitorBeginStep(MSimConvergenceMonitor mon, PetscInt step, PetscInt first_step)
{
  PetscFunctionBeginUser;
  mon->step       = step;
  mon->first_step = first_step;
  mon->spent = 0;
  if (!mon->opened) PetscCall(MSimConvergenceMonitorOpen(mon, first_step));
  PetscCall(PetscTime(&mon->start));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimConvergenceMonitorDestroy(MSimConvergenceMonitor *mon)
{
  PetscFunctionBeginUser;
  if (!*mon) PetscFunctionReturn(PETSC_SUCCESS);
  PetscBool closed = PETSC_TRUE;
  if ((*mon)->fp) closed = (PetscBool)(fclose((*mon)->fp) == 0); /* rank 0's */
  (*mon)->fp = NULL;
  PetscCall(MSimCollectiveCheck((*mon)->sys->comm, closed, std::string("-msim_monitor_convergence: write to ") + (*mon)->path + " failed"));
  delete *mon;
  *mon = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
