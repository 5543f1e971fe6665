/* L-BFGS with the projective-dynamics matrix as its initial Hessian (Liu, Bouaziz and Kavan 2017,
   "Quasi-Newton methods for real-time simulation of hyperelastic materials"): the two-loop
   recursion on the last m pairs s = x_{k+1} - x_k, y = g_{k+1} - g_k around H0 = gamma A^-1,
   which is one global step's sweep. The caller (SNES pd, -snes_pd_lbfgs) safeguards each step on
   Phi. */
#pragma once
#include <msim/solvers.h>
#include <petscvec.h>
#include <vector>

typedef struct {
  PetscInt                 m, count, next; /* history length, stored pairs, slot to overwrite */
  std::vector<Vec>         S, Y;           /* ring buffers of the pairs */
  Vec                      q;              /* the first loop's vector */
  std::vector<PetscReal>   rho;            /* 1 / (s . y) */
  std::vector<PetscScalar> a;              /* the first loop's coefficients */
  PetscReal                gamma;          /* H0 = gamma A^-1 */
  PetscInt                 skipped;        /* pairs not stored: s . y <= 0 (non-convex Phi) */
} MSimLBFGS;

PetscErrorCode MSimLBFGSCreate(Vec tmpl, PetscInt m, MSimLBFGS *lb);
PetscErrorCode MSimLBFGSDestroy(MSimLBFGS *lb);
PetscErrorCode MSimLBFGSReset(MSimLBFGS *lb);
/* d = H g by the two-loop recursion, each loop's dot fused with the previous pair's update (one
   pass over the vectors per pair and loop); h0(ctx, q, r) applies A^-1 (r = A^-1 q); with gd,
   also g . d. d may not be g. */
PetscErrorCode MSimLBFGSApply(MSimLBFGS *lb, Vec g, Vec d, PetscErrorCode (*h0)(void *, Vec, Vec), void *ctx, PetscScalar *gd);

/* The pd type's L-BFGS iteration, fused with PD's steps: the local step at an iterate gives
   rhs(x) and Phi(x) in one pass, so Phi's gradient g = A x - rhs(x) costs one product with A,
   and H0 g one sweep of the factor. An accepted iteration is one sweep, one local step, one
   product with A and 2m + 6 passes over vectors. A step that does not lower Phi by Armijo's rule
   (to roundoff: it may pass a rise of MSIM_PHI_ROUNDOFF |Phi|, as msim's energy line search does;
   |Phi| counts gravity from the origin) is replaced by the plain PD step (which never raises Phi)
   and the history restarts. Steps are shortened to the problem's feasible set (max_step). The pairs
   carry over from one solve to the next (the next time step's Hessian is close; the inertia
   term's y_n cancels in y); checkpoints carry them (MSimPDLBFGSGetHistory), so a restart with
   -snes_pd_lbfgs repeats the run bit for bit. */
typedef struct {
  MSimPDProblem *pd;
  MSimLBFGS      lb;
  PetscReal      gamma_max;      /* H0's scale gamma = s^T A s / s^T y (newest pair), kept in [1, gamma_max] */
  Vec            rhs, G;         /* the local step's rhs and the gradient at the current iterate */
  Vec            D, Xt, Rt, Gt;  /* direction (the step is x - t D), trial iterate, its rhs and gradient */
  PetscReal      phi;            /* Phi at the current iterate */
  PetscBool      first;
  PetscInt       fallbacks, cut; /* plain PD steps taken instead; steps a feasible set shortened */
  PetscInt       backtracks;     /* steps shortened once by Phi's parabola */
} MSimPDLBFGS;

PetscErrorCode MSimPDLBFGSCreate(MSimPDProblem *pd, Vec X, PetscInt m, PetscReal gamma_max, MSimPDLBFGS *st);
PetscErrorCode MSimPDLBFGSDestroy(MSimPDLBFGS *st);
/* a new solve from X: the local step and the gradient there (the history stays) */
PetscErrorCode MSimPDLBFGSBegin(MSimPDLBFGS *st, Vec X);
/* one iteration: X is replaced by the next iterate, whose local step, gradient and Phi are kept */
PetscErrorCode MSimPDLBFGSIterate(MSimPDLBFGS *st, Vec X);

/* For checkpoints: what the next solve reads besides X (MSimSolverHistory "pd_lbfgs"): the m
   pairs' slots, their rho, the ring's count and next slot, gamma, and the counters -info reports
   "so far". Get lends st's vectors; Set copies a restart's into st, if its m is st's. A field
   that a solve reads from the one before must be added to both, or restarts stop repeating the run
   bit for bit (tests/pd_lbfgs_restart.py). */
PetscErrorCode MSimPDLBFGSGetHistory(MSimPDLBFGS *st, MSimSolverHistory *h);
PetscErrorCode MSimPDLBFGSSetHistory(MSimPDLBFGS *st, const MSimSolverHistory *h, PetscBool *taken);
