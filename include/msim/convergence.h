/* -msim_monitor_convergence FILE: per nonlinear iteration of each implicit step, the solver's wall
   time (monitoring itself excluded), Phi(x_k) and |g(x_k)|, so studies can plot relative energy
   (Phi_k - Phi*)/(Phi_0 - Phi*) against iterations and seconds. */
#pragma once
#include <msim/system.h>
#include <petscsnes.h>

typedef struct _n_MSimConvergenceMonitor *MSimConvergenceMonitor;
PetscErrorCode MSimConvergenceMonitorCreate(MSimSystem sys, MSimConvergenceMonitor *mon); /* NULL when off */
/* eval gives Phi and |g| at X (the integrator's problem: the monitor sits below it and knows
   none); its time is not counted as the solver's */
typedef PetscErrorCode (*MSimConvergenceEval)(void *ctx, Vec X, PetscReal *phi, PetscReal *gnorm);
PetscErrorCode MSimConvergenceMonitorAttach(MSimConvergenceMonitor mon, SNES snes, MSimConvergenceEval eval, void *ctx);
/* step: the step about to be taken; first_step: this run's first (rows of earlier steps in an
   existing file are kept when a restarted run opens it) */
PetscErrorCode MSimConvergenceMonitorOpen(MSimConvergenceMonitor mon, PetscInt first_step); /* collective; BeginStep opens it if not yet */
PetscErrorCode MSimConvergenceMonitorBeginStep(MSimConvergenceMonitor mon, PetscInt step, PetscInt first_step);
PetscErrorCode MSimConvergenceMonitorDestroy(MSimConvergenceMonitor *mon);
