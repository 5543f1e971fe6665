/* The time loop shared by the msim program and the tests: stability guard, stepping, monitors,
   output, divergence detection. */
#pragma once
#include <msim/integrator.h>
#include <msim/output.h>

typedef struct {
  PetscInt  steps_done;
  PetscReal t;
  PetscBool diverged;
  PetscReal omega_max_bound; /* the bound the guard used (0 when no guard ran) */
  PetscReal critical_dt;     /* predicted limit on h for the explicit method (PETSC_INFINITY if none) */
  PetscBool warned;          /* the guard warned */
} MSimRunInfo;

/* Steps (X, V) from t = 0 for integ->steps steps. On divergence: writes the last finite state
   (DIR/last_finite.vtu), keeps every frame, returns PETSC_ERR_NOT_CONVERGED with a one-line message. */
PetscErrorCode MSimRun(MSimSystem sys, MSimIntegrator integ, Vec X, Vec V, MSimRunInfo *info);

/* omega_max bound used by the guard: Gershgorin, or SLEPc with -msim_spectrum_guard slepc. */
PetscErrorCode MSimStabilityLimit(MSimSystem sys, MSimIntegrator integ, PetscReal omega_max, PetscReal *hcrit);

/* The largest x = h omega with |R(x' mu)| <= 1 on [0, x] for the stability polynomial
   R(z) = sum_{k <= degree} c[k] z^k, mu = -s + i sqrt(1 - s^2) (s = gamma / (2 omega), 0 undamped:
   the imaginary axis); 0 where no step is stable (src/integrators/run.cpp) */
PetscErrorCode MSimStabilityPolynomialLimit(PetscInt degree, const PetscReal c[], PetscReal s, PetscReal *x);
