/* stop_signal.cpp: SIGINT/SIGTERM (and SIGPIPE, standard output closed) noted during stepping;
   every rank stops at the same point: after the same step, or inside the same step (its solver's
   same iteration), the step then taken back to its start. */
#pragma once
#include <msim/petsc_compat.h>
#include <csignal>

typedef struct {
  MPI_Comm         comm;
  PetscMPIInt      size;
  MPI_Request      request;
  int              local, global;
  PetscBool        active;
  struct sigaction old_int, old_term, old_pipe;
} MSimStopSignal;
PetscErrorCode MSimStopSignalBegin(MPI_Comm comm, MSimStopSignal *s);
/* after each step: *signal_seen is SIGINT, SIGTERM or SIGPIPE when every rank is to stop now (collective) */
PetscErrorCode MSimStopSignalPoll(MSimStopSignal *s, int *signal_seen);
PetscErrorCode MSimStopSignalEnd(MSimStopSignal *s); /* handlers restored; safe to call twice */
/* inside a step, at each iteration of its solver or each internal step of a TS (collective over
   the stepping's ranks, non-blocking): *signal_seen is the signal the ranks agreed to stop for
   inside this step, 0 while none. Outside MSimStopSignalBegin/End: always 0, no communication. */
PetscErrorCode MSimStopSignalPollInStep(int *signal_seen);
/* the signal agreed inside the step (sticky until MSimStopSignalEnd), 0 if none; no communication */
int MSimStopSignalAgreedInStep(void);
/* the SNES's solves stop at the iteration where the ranks agree to stop (MSimStopSignalPollInStep
   at each iteration, from a monitor), with the reason MSIM_SNES_STOPPED; msim's own SNES types
   (pd) read a reason a monitor set. Call after SNESSetFromOptions and after any convergence test
   of msim's own is set: the test set then is wrapped. */
PetscErrorCode MSimStopSignalSetSNES(SNES snes);
#define MSIM_SNES_STOPPED SNES_DIVERGED_FUNCTION_DOMAIN /* no reason of its own in PETSc 3.18 */
/* the last poll stopped the run for SIGPIPE: standard output's reader left (the run ends quietly, exit status 141) */
int MSimStoppedByClosedOutput(void);
