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

/* Registers log events, the integrator and scene types and msim's SNES type "pd".
   Installs an error handler that prints the first error message as one line on rank 0. */
PetscErrorCode MSimInitialize(void);
PetscErrorCode MSimFinalize(void);

/* Parse "a,b,c" into three reals inside a PetscOptionsBegin block; errors name the option. */
PetscErrorCode MSimOptionsVec3_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], PetscReal v[3], PetscBool *set);
#define MSimOptionsVec3(name, help, v, set) MSimOptionsVec3_Private(PetscOptionsObject, name, help, v, set)

/* Preconditioner set-ups so far in this process (PETSc's log counter of PCSetUp, which logs only
   when it does work): bracketing a factor PC's solves with it counts its factorizations. */
PetscErrorCode MSimFactorizationCount(PetscInt *count);
