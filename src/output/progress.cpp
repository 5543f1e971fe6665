/* Progress of a long run, unasked: a line on stderr from rank 0 at every tenth of the steps once
   the run has gone on for a third of the interval, and at least every interval (-msim_progress s,
   default 30 s; 0: quiet), so the log of a batch job shows that it is alive and when it will end.
   Only rank 0 looks at the clock: nothing collective. */
#include <msim/output.h>

PetscErrorCode MSimProgressCreate(MPI_Comm comm, PetscInt steps, MSimProgress *p)
{
  PetscFunctionBeginUser;
  p->interval = 30;
  p->steps    = steps;
  p->decile   = 0;
  PetscOptionsBegin(comm, NULL, "msim progress", NULL);
  PetscCall(MSimOptionsReal("-msim_progress", "Progress line on stderr at every 10% of the steps and at least every this many seconds, once the run has taken a third of it (0: none)", NULL, p->interval, &p->interval, NULL));
  PetscOptionsEnd();
  PetscCheck(p->interval >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_progress must be >= 0 s (got %g)", (double)p->interval);
  PetscCallMPI(MPI_Comm_rank(comm, &p->rank));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the clock starts with the first step; first: the steps done before it (a restart's), which the
   rate and the ETA leave out */
PetscErrorCode MSimProgressBegin(MSimProgress *p, PetscInt first)
{
  PetscFunctionBeginUser;
  p->first  = first;
  p->decile = (PetscInt)((10 * (PetscInt64)first) / p->steps);
  PetscCall(PetscTime(&p->start));
  p->last = p->start;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static void Clock(double s, char *buf, size_t len)
{
  const long r = (long)(s + 0.5);
  if (r >= 3600) snprintf(buf, len, "%ldh%02ldm", r / 3600, (r % 3600) / 60);
  else if (r >= 60) snprintf(buf, len, "%ldm%02lds", r / 60, r % 60);
  else snprintf(buf, len, "%.1fs", s);
}

PetscErrorCode MSimProgressUpdate(MSimProgress *p, PetscInt step, PetscReal t)
{
  PetscLogDouble now;

  PetscFunctionBeginUser;
  if (p->rank || p->interval <= 0 || step >= p->steps) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscTime(&now));
  const double   wall   = now - p->start;
  const PetscInt decile = (PetscInt)((10 * (PetscInt64)step) / p->steps);
  const bool     due    = (decile > p->decile && wall >= p->interval / 3) || now - p->last >= p->interval;
  if (!due) PetscFunctionReturn(PETSC_SUCCESS);
  p->decile = decile;
  p->last   = now;
  char elapsed[32], eta[32];
  Clock(wall, elapsed, sizeof(elapsed));
  const double rate = (step - p->first) / wall; /* this run's steps, not a restart's earlier ones */
  Clock(rate > 0 ? (p->steps - step) / rate : 0, eta, sizeof(eta));
  fprintf(stderr, "msim: step %" PetscInt_FMT " of %" PetscInt_FMT " (%.0f%%), t = %g s, wall %s, %.3g steps/s, ETA %s\n", step, p->steps, 100.0 * step / p->steps, (double)t, elapsed, rate, eta);
  fflush(stderr);
  PetscFunctionReturn(PETSC_SUCCESS);
}
