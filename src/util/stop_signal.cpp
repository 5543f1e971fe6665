/* SIGINT and SIGTERM during stepping (Ctrl-C; a batch system at its time limit): the handler only
   notes the signal; the run stops after the step in progress, or inside it where its solver
   iterates, and keeps the last whole step's state. The ranks agree on where to stop through
   non-blocking reductions, so the stepping never waits for them (and at one rank there is none):
   - after each step, one started then and completed after the next step;
   - inside a step, at each iteration of its solver (and each internal step of a TS), one started
     there and completed at the next iteration. A step can last longer than the time a signal
     leaves: mpirun forwards Ctrl-C or SIGTERM to its ranks as SIGTERM and kills them 1 s later
     (Open MPI's odls_base_sigkill_timeout), and the 2-rank bunny's steps take about 2 s. So a
     solver that is asked to stop gives the step up at the next agreed iteration (the integrator
     takes it back to its start, MSimStopSignalAgreedInStep), and the time loop writes the
     checkpoint of the step before.
   SIGPIPE (standard output's reader gone: `msim -msim_monitor | head -1`) is ignored from PETSc's
   start on (MSimInitializeEnd: PETSc's handler printed a signal trace and Open MPI's abort
   noise, exit 59) and noted during stepping: the run stops as for SIGTERM, its checkpoint
   written where asked, but quietly (nobody reads its output) with exit status 141, a shell's for
   a writer its pipe's reader left. A user's stop takes precedence over it on any rank: the
   reductions take the maximum of a code ordered SIGPIPE < SIGINT < SIGTERM (the signal numbers,
   13 > 2, put a closed output first, and a Ctrl-C on a run whose reader left went unsaid). */
#include <msim/signals.h>
#include <petsc/private/snesimpl.h> /* snes->ops->converged: the test StopConverged wraps (no public getter) */
#include <csignal>

static volatile sig_atomic_t msim_signal_seen = 0, msim_pipe_closed = 0;
static int                   msim_stopped_by  = 0; /* the signal the ranks stopped for */
static PetscBool             viewers_off      = PETSC_FALSE; /* StopReasonView pushed PetscOptionsGetViewer off */

/* inside the steps (MSimStopSignalPollInStep): the stepping's ranks, the reduction in flight, and
   the signal agreed (0: none yet) */
static struct {
  MPI_Comm    comm   = MPI_COMM_NULL;
  PetscMPIInt size   = 1;
  MPI_Request request = MPI_REQUEST_NULL;
  int         local = 0, global = 0, agreed = 0;
} in_step;

static void MSimNoteSignal(int sig)
{
  msim_signal_seen = sig;
}

static void MSimNotePipe(int)
{
  msim_pipe_closed = 1;
}

static int CodeOf(int sig)
{
  return sig == SIGTERM ? 3 : sig == SIGINT ? 2 : sig == SIGPIPE ? 1 : 0;
}

static int SignalOf(int code)
{
  static const int sig[] = {0, SIGPIPE, SIGINT, SIGTERM};
  return code >= 0 && code <= 3 ? sig[code] : 0;
}

/* this rank's code: a user's stop (SIGINT, SIGTERM) before a closed output */
static int LocalCode(void)
{
  return msim_signal_seen ? CodeOf((int)msim_signal_seen) : msim_pipe_closed ? CodeOf(SIGPIPE) : 0;
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
  in_step.comm    = comm;
  in_step.size    = s->size;
  in_step.request = MPI_REQUEST_NULL;
  in_step.agreed  = 0;
  act.sa_handler = MSimNoteSignal;
  sigemptyset(&act.sa_mask);
  PetscCheck(sigaction(SIGINT, &act, &s->old_int) == 0 && sigaction(SIGTERM, &act, &s->old_term) == 0, comm, PETSC_ERR_SYS, "cannot install the SIGINT/SIGTERM handlers");
  act.sa_handler = MSimNotePipe; /* the write then fails with EPIPE, and the step goes on */
  PetscCheck(sigaction(SIGPIPE, &act, &s->old_pipe) == 0, comm, PETSC_ERR_SYS, "cannot install the SIGPIPE handler");
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* one round of agreement over comm: the code the reduction started at the last round gives (0 while
   none), and a new round started with this rank's code where it gave none; at one rank, this rank's */
static PetscErrorCode Agree(MPI_Comm comm, PetscMPIInt size, MPI_Request *request, int *local, int *global, int *code)
{
  PetscFunctionBeginUser;
  *code = 0;
  if (size == 1) *code = LocalCode();
  else {
    if (*request != MPI_REQUEST_NULL) {
      PetscCallMPI(MPI_Wait(request, MPI_STATUS_IGNORE));
      *code = *global;
    }
    if (!*code) {
      *local = LocalCode();
      PetscCallMPI(MPI_Iallreduce(local, global, 1, MPI_INT, MPI_MAX, comm, request));
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimStopSignalPoll(MSimStopSignal *s, int *signal_seen)
{
  int code;

  PetscFunctionBeginUser;
  if (in_step.agreed) code = CodeOf(in_step.agreed); /* agreed inside the step: every rank knows */
  else PetscCall(Agree(s->comm, s->size, &s->request, &s->local, &s->global, &code));
  *signal_seen    = SignalOf(code);
  msim_stopped_by = *signal_seen;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimStopSignalPollInStep(int *signal_seen)
{
  PetscFunctionBeginUser;
  if (!in_step.agreed && in_step.comm != MPI_COMM_NULL) {
    int code;
    PetscCall(Agree(in_step.comm, in_step.size, &in_step.request, &in_step.local, &in_step.global, &code));
    in_step.agreed = SignalOf(code);
  }
  *signal_seen = in_step.agreed;
  PetscFunctionReturn(PETSC_SUCCESS);
}

int MSimStopSignalAgreedInStep(void)
{
  return in_step.agreed;
}

PetscErrorCode MSimStopSignalEnd(MSimStopSignal *s)
{
  PetscFunctionBeginUser;
  if (!s->active) PetscFunctionReturn(PETSC_SUCCESS);
  if (s->request != MPI_REQUEST_NULL) PetscCallMPI(MPI_Wait(&s->request, MPI_STATUS_IGNORE));
  if (in_step.request != MPI_REQUEST_NULL) PetscCallMPI(MPI_Wait(&in_step.request, MPI_STATUS_IGNORE));
  if (viewers_off) PetscCall(PetscOptionsPopGetViewerOff());
  viewers_off    = PETSC_FALSE;
  in_step.comm   = MPI_COMM_NULL;
  in_step.agreed = 0;
  sigaction(SIGINT, &s->old_int, NULL);
  sigaction(SIGTERM, &s->old_term, NULL);
  sigaction(SIGPIPE, &s->old_pipe, NULL);
  s->active = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The SNES's hook: a monitor polls at each iteration (every SNES type calls its monitors once an
   iteration, on every rank alike, pd and ntr included, and -snes_monitor_cancel, read before,
   does not remove it) and sets the reason; the wrapped convergence test, which PETSc's types call
   after the monitors and which would overwrite it, sets it again. */
typedef struct {
  PetscErrorCode (*converged)(SNES, PetscInt, PetscReal, PetscReal, PetscReal, SNESConvergedReason *, void *);
  void *cctx;
  PetscErrorCode (*cdestroy)(void *);
} StopTest;

static PetscErrorCode StopMonitor(SNES snes, PetscInt, PetscReal, void *)
{
  int sig = 0;

  PetscFunctionBeginUser;
  PetscCall(MSimStopSignalPollInStep(&sig));
  if (sig) {
    PetscCall(SNESSetConvergedReason(snes, MSIM_SNES_STOPPED));
    snes->errorifnotconverged = PETSC_FALSE; /* -snes_error_if_not_converged: the stop is no failure (its error lost the checkpoint) */
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode StopConverged(SNES snes, PetscInt it, PetscReal xnorm, PetscReal snorm, PetscReal fnorm, SNESConvergedReason *reason, void *ctx)
{
  StopTest *st = (StopTest *)ctx;

  PetscFunctionBeginUser;
  if (st->converged) PetscCall((*st->converged)(snes, it, xnorm, snorm, fnorm, reason, st->cctx));
  if (in_step.agreed) *reason = MSIM_SNES_STOPPED;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -snes_converged_reason for a stopped solve: PETSc 3.18 has no reason of its own for it, and its
   viewer said "Nonlinear solve did not converge due to DIVERGED_FUNCTION_DOMAIN" right before
   msim's "stopped by SIGTERM" line, a failure that was none. PETSc calls the views set with
   SNESConvergedReasonViewSet first, then its own where the option asks: this one says "Nonlinear
   solve stopped by SIGTERM" where the option's viewer goes (nothing for a closed standard output),
   then turns PetscOptionsGetViewer off, so that PETSc's finds no viewer, until MSimStopSignalEnd.
   That also leaves out the stopped solve's other end-of-solve views (-snes_view), and any view
   asked for between the stop and the run's end; the run then only saves its checkpoint. */
static PetscErrorCode StopReasonView(SNES snes, void *)
{
  PetscViewer       viewer;
  PetscViewerFormat format;
  PetscBool         set, ascii;
  const char       *prefix;

  PetscFunctionBeginUser;
  if (!in_step.agreed || snes->reason != MSIM_SNES_STOPPED || viewers_off) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESGetOptionsPrefix(snes, &prefix));
  PetscCall(PetscOptionsGetViewer(PetscObjectComm((PetscObject)snes), ((PetscObject)snes)->options, prefix, "-snes_converged_reason", &viewer, &format, &set));
  if (set) {
    PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
    if (ascii && in_step.agreed != SIGPIPE) {
      PetscCall(PetscViewerASCIIAddTab(viewer, ((PetscObject)snes)->tablevel));
      PetscCall(PetscViewerASCIIPrintf(viewer, "Nonlinear %s%ssolve stopped by %s iterations %" PetscInt_FMT "\n", prefix ? prefix : "", prefix ? " " : "", in_step.agreed == SIGINT ? "SIGINT" : "SIGTERM", snes->iter));
      PetscCall(PetscViewerASCIISubtractTab(viewer, ((PetscObject)snes)->tablevel));
    }
    PetscCall(PetscViewerDestroy(&viewer));
  }
  PetscCall(PetscOptionsPushGetViewerOff(PETSC_TRUE));
  viewers_off = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode StopTestDestroy(void *ctx)
{
  StopTest *st = (StopTest *)ctx;

  PetscFunctionBeginUser;
  if (st->cdestroy) PetscCall((*st->cdestroy)(st->cctx));
  PetscCall(PetscFree(st));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimStopSignalSetSNES(SNES snes)
{
  StopTest *st;

  PetscFunctionBeginUser;
  PetscCall(PetscNew(&st));
  /* the test set so far, its context and destroy taken over (SNESSetConvergenceTest would
     destroy that context) */
  st->converged                = snes->ops->converged;
  st->cctx                     = snes->cnvP;
  st->cdestroy                 = snes->ops->convergeddestroy;
  snes->ops->convergeddestroy  = NULL;
  PetscCall(SNESSetConvergenceTest(snes, StopConverged, st, StopTestDestroy));
  PetscCall(SNESMonitorSet(snes, StopMonitor, NULL, NULL));
  PetscCall(SNESConvergedReasonViewSet(snes, StopReasonView, NULL, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}
