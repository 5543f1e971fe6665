/* Common includes, version shims, logging handles and the one-line error handler. */
#pragma once
#include <petsc.h>

#if PETSC_VERSION_LT(3, 19, 0)
  #define PETSC_SUCCESS 0
#endif

/* Log events registered once by MSimInitialize(); -log_view reports them. */
extern PetscClassId  MSIM_CLASSID;
extern PetscLogEvent MSIM_Force, MSIM_Energy, MSIM_Step, MSIM_Output, MSIM_Jacobian, MSIM_Residual,
  MSIM_PDLocal, MSIM_PDGlobal, MSIM_PDSetUp, MSIM_Spectrum, MSIM_Setup, MSIM_LLTFactor;
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
/* Options set but never read (a misspelled name does nothing otherwise): one warning line each on
   stderr, unless -options_left asked PETSc to list them. */
PetscErrorCode MSimWarnUnusedOptions(MPI_Comm comm);
PetscErrorCode MSimFinalize(void);

/* Parse "a,b,c" into three reals inside a PetscOptionsBegin block; errors name the option. */
PetscErrorCode MSimOptionsVec3_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], PetscReal v[3], PetscBool *set);
#define MSimOptionsVec3(name, help, v, set) MSimOptionsVec3_Private(PetscOptionsObject, name, help, v, set)

/* Preconditioner set-ups so far in this process (PETSc's log counter of PCSetUp, which logs only
   when it does work): bracketing a factor PC's solves with it counts its factorizations. */
PetscErrorCode MSimFactorizationCount(PetscInt *count);
