/* Integrators layer: a registry of time integrators chosen by -msim_integrator, PETSc style. */
#pragma once
#include <msim/system.h>

#define MSIMEXPLICITEULER   "explicit_euler"
#define MSIMSYMPLECTICEULER "symplectic_euler"
#define MSIMRK4             "rk4"
#define MSIMTS              "ts"
#define MSIMIMPLICITEULER   "implicit_euler"

typedef struct _n_MSimIntegrator *MSimIntegrator;
typedef struct {
  PetscErrorCode (*setfromoptions)(MSimIntegrator);
  PetscErrorCode (*setup)(MSimIntegrator);
  PetscErrorCode (*step)(MSimIntegrator, PetscReal t, Vec X, Vec V); /* advance (X, V) from t to t + dt */
  PetscErrorCode (*view)(MSimIntegrator, PetscViewer);
  PetscErrorCode (*openfiles)(MSimIntegrator); /* optional: its monitor files, opened before the run writes anything */
  /* optional: the vectors besides x and v that the next step reads (BDF2's x_{n-1}, v_{n-1}), which
     a checkpoint writes; history_loaded: a restart filled them, the next step uses them */
  PetscErrorCode (*get_history)(MSimIntegrator, PetscInt *n, Vec **history);
  PetscErrorCode (*history_loaded)(MSimIntegrator);
  PetscErrorCode (*destroy)(MSimIntegrator);
} MSimIntegratorOps;

struct _n_MSimIntegrator {
  MPI_Comm          comm;
  char              type[64];
  MSimSystem        sys;
  PetscReal         dt;
  PetscInt          steps;
  PetscInt          step, first_step; /* the step being taken (1 ... steps, counted by MSimIntegratorStep); this run's first (after a restart, not 1) */
  MSimIntegratorOps ops;
  void             *data;
  PetscBool         setupcalled;
  /* stability of an explicit method without damping: stable iff dt * omega_max <= stability_limit
     (0: no step is stable; PETSC_INFINITY: unconditionally stable) */
  PetscReal         stability_limit;
  /* what the last step reports to monitors */
  PetscInt          nonlinear_its, linear_its;
  PetscReal         residual;
  PetscReal         phi;      /* implicit: Phi at the step's result, when want_phi (else 0) */
  PetscBool         want_phi; /* set by the time loop when a monitor prints Phi */
  PetscBool         failed; /* the step's solver diverged: the run stops as diverged */
  char              failure[96]; /* why, in the solver's words (" (-snes_type qn: DIVERGED_LINE_SEARCH)") */
  /* steps whose solver stopped at its iteration cap short of the tolerance it was given (a
     fixed iteration count, asked for with zero tolerances or -snes_pd_fixed, is not counted),
     and that tolerance in words, for the warning at the end of the run */
  PetscInt          unconverged_steps;
  char              tolerance[160];
  /* Newton on the exact Hessian factored by MUMPS (LDL^T): steps that converged where that factor
     had negative pivots, i.e. to a saddle point of Phi, not a minimum, and the most negative
     eigenvalues seen there (the inertia comes free with the factorization) */
  PetscInt          saddle_steps, saddle_negative;
  PetscBool         help_listing; /* a throwaway instance made only so -help lists its options */
};

PetscErrorCode MSimIntegratorRegister(const char name[], PetscErrorCode (*create)(MSimIntegrator));
PetscErrorCode MSimIntegratorRegisterAll(void);
PetscErrorCode MSimIntegratorFinalizePackage(void);
PetscErrorCode MSimIntegratorCreate(MSimSystem sys, MSimIntegrator *integ);
PetscErrorCode MSimIntegratorSetType(MSimIntegrator integ, const char type[]);
PetscErrorCode MSimIntegratorSetFromOptions(MSimIntegrator integ);
PetscErrorCode MSimIntegratorSetUp(MSimIntegrator integ);
PetscErrorCode MSimIntegratorStep(MSimIntegrator integ, PetscReal t, Vec X, Vec V);
PetscErrorCode MSimIntegratorView(MSimIntegrator integ, PetscViewer viewer);
PetscErrorCode MSimIntegratorDestroy(MSimIntegrator *integ);

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
