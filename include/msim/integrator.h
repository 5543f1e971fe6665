/* Integrators layer: a registry of time integrators chosen by -msim_integrator, PETSc style. */
#pragma once
#include <msim/system.h>

#define MSIMEXPLICITEULER   "explicit_euler"
#define MSIMSYMPLECTICEULER "symplectic_euler"
#define MSIMRK4             "rk4"
#define MSIMTS              "ts"
#define MSIMIMPLICITEULER   "implicit_euler"

/* The body and the types' ops are private (msim/private/integratorimpl.h). */
typedef struct _n_MSimIntegrator *MSimIntegrator;

PetscErrorCode MSimIntegratorRegister(const char name[], PetscErrorCode (*create)(MSimIntegrator));
PetscErrorCode MSimIntegratorRegisterAll(void);
PetscErrorCode MSimIntegratorFinalizePackage(void);
PetscErrorCode MSimIntegratorCreate(MSimSystem sys, MSimIntegrator *integ);
PetscErrorCode MSimIntegratorSetType(MSimIntegrator integ, const char type[]);
PetscErrorCode MSimIntegratorSetFromOptions(MSimIntegrator integ);
PetscErrorCode MSimIntegratorSetUp(MSimIntegrator integ);
PetscErrorCode MSimIntegratorStep(MSimIntegrator integ, PetscReal t, Vec X, Vec V);
/* Refuses (one line, collective) the state X at time t that a run starts from, the scene's start
   or a checkpoint's, where the integrator's terms cannot begin a step (self-contact's surface
   through itself, an inverted tet under the inversion barrier); restart: NULL for the scene's
   start, else the checkpoint's in words (MSimCheckpointRestartState). After MSimIntegratorSetUp. */
PetscErrorCode MSimIntegratorCheckStart(MSimIntegrator integ, PetscReal t, Vec X, const char *restart);
PetscErrorCode MSimIntegratorView(MSimIntegrator integ, PetscViewer viewer);
PetscErrorCode MSimIntegratorDestroy(MSimIntegrator *integ);
/* What callers need of the body: */
PetscErrorCode MSimIntegratorGetTimeStep(MSimIntegrator integ, PetscReal *dt);
/* What the last step reports (each may be NULL): whether its solver diverged, its nonlinear and
   linear iterations and its final residual norm */
PetscErrorCode MSimIntegratorGetStepResult(MSimIntegrator integ, PetscBool *failed, PetscInt *nonlinear_its, PetscInt *linear_its, PetscReal *residual);

PETSC_EXTERN PetscErrorCode MSimIntegratorCreate_ExplicitEuler(MSimIntegrator);
PETSC_EXTERN PetscErrorCode MSimIntegratorCreate_SymplecticEuler(MSimIntegrator);
PETSC_EXTERN PetscErrorCode MSimIntegratorCreate_RK4(MSimIntegrator);
PETSC_EXTERN PetscErrorCode MSimIntegratorCreate_TS(MSimIntegrator);
/* the implicit integrators: one per registered time scheme (msim/implicit.h), same name */
PETSC_EXTERN PetscErrorCode MSimIntegratorCreate_Implicit(MSimIntegrator);
PetscErrorCode MSimIntegratorRegisterImplicit(void);

/* The implicit integrators' counters (every scheme; the names are implicit Euler's, the first). */
/* Numeric factorizations of the PD matrix so far (0 when PD was never used). */
PetscErrorCode MSimImplicitEulerGetFactorizations(MSimIntegrator integ, PetscInt *n);
/* Newton on the exact Hessian (-msim_psd 0): directions replaced so far by the PSD-projected
   Hessian's because they did not lower Phi (-msim_psd_fallback). */
PetscErrorCode MSimImplicitEulerGetProjectedFallbacks(MSimIntegrator integ, PetscInt *n);
/* The SNES that solves each step (NULL before the integrator is set up). */
PetscErrorCode MSimImplicitEulerGetSNES(MSimIntegrator integ, SNES *snes);
