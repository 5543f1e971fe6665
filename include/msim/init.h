/* Start-up and shut-down of a program that uses msim: process settings before MPI, the checks and
   one-line errors around SlepcInitialize, and the registration of everything msim has
   (register.cpp). */
#pragma once
#include <msim/petsc_compat.h>

/* malloc_defaults.cpp: glibc malloc tunables msim prefers (huge pages, no trimming), applied by
   running itself once more with GLIBC_TUNABLES where the user has not set it; call first in main */
void MSimSetMallocDefaults(int argc, char **argv);
/* mpi_defaults.cpp: MPI transport settings msim prefers, set before MPI_Init where the user has not
   set them (Open MPI's eager limit for shared memory, which the ghost exchange's messages exceed) */
void MSimSetMPIDefaults(void);
/* After MPI_Init, before PETSc: 1 (with one line on stderr) if an -options_file does not open */
int MSimCheckOptionsFiles(int argc, char **argv);
/* Around SlepcInitialize, whose errors (an options file that does not open or parse) come before
   the handler: Begin keeps PETSc's trace to itself; End(ierr) prints its message as one line and
   finalizes MPI where ierr is set, returning the exit code (0 or 1). */
void MSimInitializeBegin(void);
int  MSimInitializeEnd(PetscErrorCode ierr);

/* Registers log events, the scene, partitioner and integrator types and msim's solver types.
   Installs the error handler that prints the first error message as one line on rank 0. */
PetscErrorCode MSimInitialize(void);
PetscErrorCode MSimFinalize(void);
