/* The integrator's body, for its implementations (src/integrators/, src/output/ that reports a
   step, src/integrators/impls/): PETSc's include/petsc/private pattern. Users and the app see the
   handle and the functions of msim/integrator.h only. */
#pragma once
#include <msim/integrator.h>

/* the highest degree of an explicit method's stability polynomial the guard takes (its stages) */
#define MSIM_STABILITY_MAX_DEGREE 64

/* An integrator type's ops: each NULL unless its type sets it (one static table per type, with
   designated initializers, copied into integ->ops by its create function). */
typedef struct {
  PetscErrorCode (*setfromoptions)(MSimIntegrator) = NULL;
  PetscErrorCode (*setup)(MSimIntegrator) = NULL;
  PetscErrorCode (*step)(MSimIntegrator, PetscReal t, Vec X, Vec V) = NULL; /* advance (X, V) from t to t + dt */
  PetscErrorCode (*view)(MSimIntegrator, PetscViewer) = NULL;
  PetscErrorCode (*openfiles)(MSimIntegrator) = NULL; /* optional: its monitor files, opened before the run writes anything */
  /* optional: the vectors besides x and v that the next step reads (BDF2's x_{n-1}, v_{n-1}), which
     a checkpoint writes; history_loaded: a restart filled them, the next step uses them */
  PetscErrorCode (*get_history)(MSimIntegrator, PetscInt *n, Vec **history) = NULL;
  PetscErrorCode (*history_loaded)(MSimIntegrator) = NULL;
  /* optional: refuses the state (X at t) the run starts from where the integrator cannot step
     from it (MSimIntegratorCheckStart) */
  PetscErrorCode (*check_start)(MSimIntegrator, PetscReal t, Vec X, const char *restart) = NULL;
  PetscErrorCode (*destroy)(MSimIntegrator) = NULL;
} MSimIntegratorOps;

struct _n_MSimIntegrator {
  MPI_Comm          comm;
  char              type[64];
  MSimSystem        sys;
  PetscReal         dt;
  PetscReal         restart_dt; /* a restart: the checkpoint's -msim_dt, set before history_loaded */
  PetscInt          steps;
  PetscInt          step, first_step; /* the step being taken (1 ... steps, counted by MSimIntegratorStep); this run's first (after a restart, not 1) */
  MSimIntegratorOps ops;
  void             *data;
  PetscBool         setupcalled;
  /* stability of an explicit method without damping: stable iff dt * omega_max <= stability_limit
     (0: no step is stable; PETSC_INFINITY: unconditionally stable) */
  PetscReal         stability_limit;
  /* an explicit Runge-Kutta method's stability polynomial R(z) = sum_k stability_poly[k] z^k
     (stability_degree 0: not given), from which the guard's limit with drag is found where
     stability_limit is 0 (MSimStabilityLimit) */
  PetscInt          stability_degree = 0;
  PetscReal         stability_poly[MSIM_STABILITY_MAX_DEGREE + 1] = {};
  /* what the last step reports to monitors */
  PetscInt          nonlinear_its, linear_its;
  PetscReal         residual;
  PetscReal         phi;      /* implicit: Phi at the step's result, when want_phi (else 0) */
  PetscBool         want_phi; /* set by the time loop when a monitor prints Phi */
  PetscBool         failed; /* the step's solver diverged: the run stops as diverged */
  char              failure[512]; /* why, in the solver's words (" (-snes_type qn: DIVERGED_LINE_SEARCH)") */
  const char       *failed_what; /* what gave up, where not the nonlinear solver (a TS's error control); NULL: the solver */
  PetscReal         failed_t; /* a failed step that got part of the way (a TS's internal steps): the time it reached; < 0 where none */
  /* a stop signal cut the step short (msim/signals.h, MSimStopSignalAgreedInStep): X and V are
     the step's start again and the step counts as not taken */
  PetscBool         stopped;
  /* steps whose solver stopped at its iteration cap short of the tolerance it was given (a
     fixed iteration count, asked for with zero tolerances or -snes_pd_fixed, is not counted),
     and that tolerance in words, for the warning at the end of the run */
  PetscInt          unconverged_steps;
  char              tolerance[320];
  /* steps that ended on the step-length test (-snes_stol) with the last step cut short (a contact
     barrier's largest feasible step, or backtracking) while |g| was above its tolerance: a jam,
     not a converged step (elements locked against each other), and the last one in words */
  PetscInt          stalled_steps;
  char              stall[320];
  /* Newton on the exact Hessian factored by MUMPS (LDL^T): steps that converged where that factor
     had negative pivots, i.e. to a saddle point of Phi, not a minimum, and the most negative
     eigenvalues seen there (the inertia comes free with the factorization) */
  PetscInt          saddle_steps, saddle_negative;
  /* the energy (J) the contact barriers held at the start of this run's first step, which the
     system's potential does not count: pairs that start within the contact distance (a start
     resting in contact, -msim_self_contact_start_gap below it) spring apart and release it as
     kinetic energy, so the divergence check counts it in the start's energy (set at step 1 by
     the implicit integrators; 0 where there is none, and in a restarted run, whose E0 has it) */
  PetscReal         barrier_energy0;
  /* of barrier_energy0, the obstacles' part, their contact distance, and per obstacle holding
     some the vertices within it and the least distance (for the start's warning in run.cpp) */
  PetscReal         barrier_obstacles0, barrier_dhat0;
  char              barrier_near0[512];
  PetscBool         help_listing; /* a throwaway instance made only so -help lists its options */
};
