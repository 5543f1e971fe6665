/* stop_signal.cpp: SIGINT/SIGTERM (and SIGPIPE, standard output closed) noted during stepping;
   every rank stops after the same step. */
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
/* inside a step that can run long (an integrator's own inner steps): *signal_seen is the signal any
   rank of comm noted so far, 0 if none (collective, blocking) */
PetscErrorCode MSimStopSignalPending(MPI_Comm comm, int *signal_seen);
/* the last poll stopped the run for SIGPIPE: standard output's reader left (the run ends quietly, exit status 141) */
int MSimStoppedByClosedOutput(void);
