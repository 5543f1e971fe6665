/* Common includes, version shims, logging handles and the one-line error handler. */
#pragma once
#include <petsc.h>

#if PETSC_VERSION_LT(3, 19, 0)
  #define PETSC_SUCCESS 0
#endif

/* Log events registered once by MSimInitialize(); -log_view reports them. */
extern PetscClassId  MSIM_CLASSID;
extern PetscLogEvent MSIM_Force, MSIM_Energy, MSIM_Step, MSIM_Output, MSIM_Jacobian, MSIM_Residual,
  MSIM_PDLocal, MSIM_PDGlobal, MSIM_PDSetUp, MSIM_Spectrum, MSIM_Setup, MSIM_LLTFactor, MSIM_LLTSweep;
/* rank 0's mesh work: parsing a file, validating it, finding its unique edges, TetGen */
extern PetscLogEvent MSIM_MeshRead, MSIM_MeshCheck, MSIM_MeshEdges, MSIM_TetGen;
/* -log_view stages: reading a file (rank 0), partitioning, moving the scene between ranks,
   refining, building the system and the solvers, time stepping */
extern PetscLogStage MSIM_StageRead, MSIM_StagePartition, MSIM_StageDistribute, MSIM_StageRefine, MSIM_StageSetup, MSIM_StageStep;

/* Registers log events, the integrator and scene types and msim's SNES type "pd".
   Installs an error handler that prints the first error message as one line on rank 0. */
PetscErrorCode MSimInitialize(void);
/* errors.cpp. The first message of an error, one line ("msim: error: ..."), from rank 0 of the
   communicator it was raised on; -msim_traceback restores PETSc's full trace. */
PetscErrorCode MSimErrorHandler(MPI_Comm, int, const char *, const char *, PetscErrorCode, PetscErrorType, const char *, void *);
/* Around SlepcInitialize, whose errors (an options file that does not open or parse) come before
   the handler: Begin keeps PETSc's trace to itself; End(ierr) prints its message as one line and
   finalizes MPI where ierr is set, returning the exit code (0 or 1). */
void MSimInitializeBegin(void);
/* mpi_defaults.cpp: MPI transport settings msim prefers, set before MPI_Init where the user has not
   set them (Open MPI's eager limit for shared memory, which the ghost exchange's messages exceed) */
void MSimSetMPIDefaults(void);
/* malloc_defaults.cpp: glibc malloc tunables msim prefers (huge pages, no trimming), applied by
   running itself once more with GLIBC_TUNABLES where the user has not set it; call first in main */
void MSimSetMallocDefaults(int argc, char **argv);
int  MSimInitializeEnd(PetscErrorCode ierr);
/* After MPI_Init, before PETSc: 1 (with one line on stderr) if an -options_file does not open */
int MSimCheckOptionsFiles(int argc, char **argv);
/* Options set but never read (a misspelled name does nothing otherwise): one warning line each on
   stderr, unless -options_left asked PETSc to list them. */
PetscErrorCode MSimWarnUnusedOptions(MPI_Comm comm);
PetscErrorCode MSimFinalize(void);

/* msim's numeric options, inside a PetscOptionsBegin block: PETSc's, after a check that every
   item is a finite number (an integer within PetscInt for integer options); errors name the
   option, once (options.cpp). Arguments as PETSc's PetscOptionsReal etc. */
PetscErrorCode MSimOptionsReal_Private(PetscOptionItems *, const char[], const char[], const char[], PetscReal, PetscReal *, PetscBool *);
PetscErrorCode MSimOptionsInt_Private(PetscOptionItems *, const char[], const char[], const char[], PetscInt, PetscInt *, PetscBool *);
PetscErrorCode MSimOptionsRealArray_Private(PetscOptionItems *, const char[], const char[], const char[], PetscReal[], PetscInt *, PetscBool *);
PetscErrorCode MSimOptionsIntArray_Private(PetscOptionItems *, const char[], const char[], const char[], PetscInt[], PetscInt *, PetscBool *);
#define MSimOptionsReal(a, b, c, d, e, f)      MSimOptionsReal_Private(PetscOptionsObject, a, b, c, d, e, f)
#define MSimOptionsInt(a, b, c, d, e, f)       MSimOptionsInt_Private(PetscOptionsObject, a, b, c, d, e, f)
#define MSimOptionsRealArray(a, b, c, d, e, f) MSimOptionsRealArray_Private(PetscOptionsObject, a, b, c, d, e, f)
#define MSimOptionsIntArray(a, b, c, d, e, f)  MSimOptionsIntArray_Private(PetscOptionsObject, a, b, c, d, e, f)
/* Parse "a,b,c" into three reals inside a PetscOptionsBegin block; errors name the option. */
PetscErrorCode MSimOptionsVec3_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], PetscReal v[3], PetscBool *set);
#define MSimOptionsVec3(name, help, v, set) MSimOptionsVec3_Private(PetscOptionsObject, name, help, v, set)

/* crash_guard.cpp: runs fn; a crash signal inside it (SIGSEGV, SIGABRT, SIGFPE, SIGBUS, SIGILL)
   returns here as that signal's number (0: fn returned). For third-party calls on bad input. */
#include <functional>
int MSimCallGuarded(const std::function<void(void)> &fn);

/* stop_signal.cpp: SIGINT/SIGTERM noted during stepping; every rank stops after the same step */
#include <csignal>
typedef struct {
  MPI_Comm         comm;
  PetscMPIInt      size;
  MPI_Request      request;
  int              local, global;
  PetscBool        active;
  struct sigaction old_int, old_term;
} MSimStopSignal;
PetscErrorCode MSimStopSignalBegin(MPI_Comm comm, MSimStopSignal *s);
/* after each step: *signal_seen is SIGINT or SIGTERM when every rank is to stop now (collective) */
PetscErrorCode MSimStopSignalPoll(MSimStopSignal *s, int *signal_seen);
PetscErrorCode MSimStopSignalEnd(MSimStopSignal *s); /* handlers restored; safe to call twice */

/* Preconditioner set-ups so far in this process (PETSc's log counter of PCSetUp, which logs only
   when it does work): bracketing a factor PC's solves with it counts its factorizations. */
PetscErrorCode MSimFactorizationCount(PetscInt *count);
