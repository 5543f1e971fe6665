/* msim's errors: one line, printed once whatever the rank count (errors.cpp, rank_zero.cpp). */
#pragma once
#include <msim/petsc_compat.h>
#include <functional>
#include <string>

/* The first message of an error, one line ("msim: error: ..."), from rank 0 of the communicator it
   was raised on; -msim_traceback restores PETSc's full trace. */
PetscErrorCode MSimErrorHandler(MPI_Comm, int, const char *, const char *, PetscErrorCode, PetscErrorType, const char *, void *);

/* Runs fn on rank 0 of comm while the others wait; an error raised inside fn becomes one error on
   all ranks of comm with fn's first message, so it prints once (and out-of-memory is an error, not
   a crash). */
PetscErrorCode MSimCallOnRankZero(MPI_Comm comm, const std::function<PetscErrorCode(void)> &fn);
/* Runs fn with its errors kept quiet (not printed): returns fn's error code and its first message,
   for a caller that reports it as part of a line of its own. */
PetscErrorCode MSimCaptureError(const std::function<PetscErrorCode(void)> &fn, std::string &message);
/* Collective: if ok is false on any rank, one error on comm with the message of the lowest such
   rank (printed once). */
PetscErrorCode MSimCollectiveCheck(MPI_Comm comm, PetscBool ok, const std::string &message);
