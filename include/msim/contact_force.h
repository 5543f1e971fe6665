/* The obstacles' force on each vertex at a given state: one function that the frames (the point
   array `contact_force`) and -msim_monitor_csv's totals (contact_fx, fy, fz, contact_n) both call
   on the state they describe, the end of a step, so that the two agree (the solver's last
   gradient evaluation is not necessarily at that state). msim/contact.h holds the obstacles. */
#pragma once
#include <msim/system.h>

/* Which force the run's integrator applies: the implicit schemes' contact (kappa m |e'(d)| n, minus
   the contact energy's gradient divided by the step's weight beta h^2: a force in N, zero beyond
   dhat; plus friction's force when -msim_friction is set), or for every other integrator (explicit ones and PETSc's TS) the penalty kc max(0, -d) n.
   Called once by the time loop with the integrator's type, before the first frame. */
PetscErrorCode MSimContactForceSetIntegrator(MSimSystem sys, const char type[]);
/* F (a free-vertex Vec, or NULL) = the obstacles' force on each owned free vertex at X and time t
   (summed over obstacles); totals (or NULL) = its sum over ranks (x, y, z), the vertices in contact
   (barrier: within dhat; penalty: inside) and the energy whose gradient the normal force is
   (barrier: kappa m b(d); penalty: kc d^2 / 2; per vertex and obstacle; friction, dissipative, has
   none; VI bounds' reactions store none: 0). Zeros without obstacles, and for the barrier before
   its kappa is chosen (at the first step). Collective. */
PetscErrorCode MSimContactForce(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscReal totals[5]);
/* Whether the system has obstacles (collective on first use: reads the contact options). */
PetscErrorCode MSimContactHasObstacles(MSimSystem sys, PetscBool *has);
