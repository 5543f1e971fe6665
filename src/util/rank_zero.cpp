/* Work that one rank does for all (reading a file, running TetGen), with errors that reach every
   rank: the error is caught on rank 0, its message broadcast, and raised again on the whole
   communicator, so msim's handler prints it once and every rank exits the same way. */
#include <msim/errors.h>
#include <new>

static PetscErrorCode MSimCaptureHandler(MPI_Comm comm, int line, const char *fun, const char *file, PetscErrorCode n, PetscErrorType p, const char *mess, void *ctx)
{
  std::string *first = (std::string *)ctx;
  if (p == PETSC_ERROR_INITIAL && first->empty()) *first = mess && mess[0] ? mess : "error";
  return n;
}

/* Runs fn with errors kept quiet: returns fn's error code and its first message. */
PetscErrorCode MSimCaptureError(const std::function<PetscErrorCode(void)> &fn, std::string &message)
{
  PetscErrorCode ierr;

  PetscFunctionBeginUser;
  message.clear();
  PetscCall(PetscPushErrorHandler(MSimCaptureHandler, &message));
  try {
    ierr = fn();
  } catch (const std::bad_alloc &) {
    ierr    = PETSC_ERR_MEM;
    message = "out of memory";
  }
  PetscCall(PetscPopErrorHandler());
  if (ierr && message.empty()) {
    const char *text = NULL;
    PetscErrorMessage(ierr, &text, NULL);
    message = text ? text : "error";
  }
  PetscFunctionReturn(ierr);
}

PetscErrorCode MSimCallOnRankZero(MPI_Comm comm, const std::function<PetscErrorCode(void)> &fn)
{
  PetscMPIInt rank;
  int         code = 0, len = 0;
  std::string message;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    code = (int)MSimCaptureError(fn, message);
    len  = (int)message.size();
  }
  PetscCallMPI(MPI_Bcast(&code, 1, MPI_INT, 0, comm));
  if (!code) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCallMPI(MPI_Bcast(&len, 1, MPI_INT, 0, comm));
  message.resize(len);
  PetscCallMPI(MPI_Bcast(&message[0], len, MPI_CHAR, 0, comm));
  SETERRQ(comm, (PetscErrorCode)code, "%s", message.c_str());
}

PetscErrorCode MSimCollectiveCheck(MPI_Comm comm, PetscBool ok, const std::string &message)
{
  PetscMPIInt rank, size, first;
  int         len;
  std::string text;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  const PetscMPIInt mine = ok ? size : rank;
  PetscCallMPI(MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm));
  if (first == size) PetscFunctionReturn(PETSC_SUCCESS);
  /* the lowest rank that failed says why, once */
  if (rank == first) text = message;
  len = (int)text.size();
  PetscCallMPI(MPI_Bcast(&len, 1, MPI_INT, first, comm));
  text.resize(len);
  PetscCallMPI(MPI_Bcast(&text[0], len, MPI_CHAR, first, comm));
  SETERRQ(comm, PETSC_ERR_ARG_WRONG, "%s", text.c_str());
}
