/* SIGINT and SIGTERM during stepping (Ctrl-C; a batch system at its time limit): the handler only
   notes the signal; the time loop stops after the step in progress. The ranks agree on the step
   to stop at through a non-blocking reduction started after each step and completed after the
   next, so the stepping never waits for it (and at one rank there is none).
   SIGPIPE (standard output's reader gone: `msim -msim_monitor | head -1`) is ignored from PETSc's
   start on (MSimInitializeEnd: PETSc's handler printed a signal trace and Open MPI's abort
   noise, exit 59) and noted during stepping: the run stops after the step as for SIGTERM, its
   checkpoint written where asked, but quietly (nobody reads its output) with exit status 141,
   a shell's for a writer its pipe's reader left. */
#include <msim/signals.h>
#include <csignal>

static volatile sig_atomic_t msim_signal_seen = 0, msim_pipe_closed = 0;
static int                   msim_stopped_by  = 0; /* the signal the ranks stopped for */

static void MSimNoteSignal(int sig)
{
  msim_signal_seen = sig;
}

static void MSimNotePipe(int)
{
  msim_pipe_closed = 1;
}

int MSimStoppedByClosedOutput(void)
{
  return msim_stopped_by == SIGPIPE;
}

PetscErrorCode MSimStopSignalBegin(MPI_Comm comm, MSimStopSignal *s)
{
  struct sigaction act = {};

  PetscFunctionBeginUser;
  s->comm     = comm;
  s->request  = MPI_REQUEST_NULL;
  s->local    = 0;
  s->global   = 0;
  s->active   = PETSC_TRUE;
  msim_signal_seen = 0;
  msim_pipe_closed = 0;
  PetscCallMPI(MPI_Comm_size(comm, &s->size));
  act.sa_handler = MSimNoteSignal;
  sigemptyset(&act.sa_mask);
  PetscCheck(sigaction(SIGINT, &act, &s->old_int) == 0 && sigaction(SIGTERM, &act, &s->old_term) == 0, comm, PETSC_ERR_SYS, "cannot install the SIGINT/SIGTERM handlers");
  act.sa_handler = MSimNotePipe; /* the write then fails with EPIPE, and the step goes on */
  PetscCheck(sigaction(SIGPIPE, &act, &s->old_pipe) == 0, comm, PETSC_ERR_SYS, "cannot install the SIGPIPE handler");
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimStopSignalPoll(MSimStopSignal *s, int *signal_seen)
{
  /* SIGINT or SIGTERM first: the user's stop, said in its line */
  const int local = msim_signal_seen ? (int)msim_signal_seen : msim_pipe_closed ? SIGPIPE : 0;

  PetscFunctionBeginUser;
  *signal_seen = 0;
  if (s->size == 1) *signal_seen = local;
  else {
    if (s->request != MPI_REQUEST_NULL) {
      PetscCallMPI(MPI_Wait(&s->request, MPI_STATUS_IGNORE));
      *signal_seen = s->global;
    }
    if (!*signal_seen) {
      s->local = local;
      PetscCallMPI(MPI_Iallreduce(&s->local, &s->global, 1, MPI_INT, MPI_MAX, s->comm, &s->request));
    }
  }
  msim_stopped_by = *signal_seen;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimStopSignalEnd(MSimStopSignal *s)
{
  PetscFunctionBeginUser;
  if (!s->active) PetscFunctionReturn(PETSC_SUCCESS);
  if (s->request != MPI_REQUEST_NULL) PetscCallMPI(MPI_Wait(&s->request, MPI_STATUS_IGNORE));
  sigaction(SIGINT, &s->old_int, NULL);
  sigaction(SIGTERM, &s->old_term, NULL);
  sigaction(SIGPIPE, &s->old_pipe, NULL);
  s->active = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimStopSignalPending(MPI_Comm comm, int *signal_seen)
{
  int local = (int)msim_signal_seen;

  PetscFunctionBeginUser;
  PetscCall(MPIU_Allreduce(&local, signal_seen, 1, MPI_INT, MPI_MAX, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}
