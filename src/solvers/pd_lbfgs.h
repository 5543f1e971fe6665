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
  /* With track (MSimLBFGSApply), A's Gram matrix of the pairs, gram[i m + j] = s_i^T A s_j (slots),
     kept without a product with A: d = gamma A^-1 q + sum_i b_i s_i, so A d = gamma q + sum_i b_i
     A s_i, and d^T A d and (A d) . s_j follow from q . d0 (d0 = gamma A^-1 q), the s_i . q, b and
     the Gram matrix; the apply leaves them in dad and arow for the pair -t d (MSimLBFGSPushGram) */
  std::vector<PetscReal>   gram, arow, b, qs;
  PetscReal                dad;
  /* the size of d^T A d's parts, (|d0|_A + sum_i |b_i s_i|_A)^2: where d^T A d is far below it (d
     mostly cancels: a step at roundoff, which near convergence still makes pairs) the Gram sum
     would carry the parts' roundoff, and the new pair's row is taken by a product with A
     (exact_rows counts them) */
  PetscReal                dad_scale;
  PetscInt                 exact_rows;
  /* every stored pair's Gram row was kept (pairs pushed by a solve without track write none): a
     tracked apply reads the Gram matrix only while this holds (a restart from a checkpoint that
     a run with -snes_pd_lbfgs_fused 0 wrote) */
  PetscBool                gram_valid;
  /* s . g of the newest pair and the next gradient, from the pass that made the pair: the first
     loop's first dot (valid for the g the pass saw, until Reset or Invalidate) */
  PetscScalar              sg;
  PetscBool                sg_valid;
} MSimLBFGS;

PetscErrorCode MSimLBFGSCreate(Vec tmpl, PetscInt m, MSimLBFGS *lb);
PetscErrorCode MSimLBFGSDestroy(MSimLBFGS *lb);
PetscErrorCode MSimLBFGSReset(MSimLBFGS *lb);
/* d = H g by the two-loop recursion, each loop's dot fused with the previous pair's update (one
   pass over the vectors per pair and loop); h0(ctx, q, r) applies A^-1 (r = A^-1 q); with gd,
   also g . d. d may not be g. */
PetscErrorCode MSimLBFGSApply(MSimLBFGS *lb, Vec g, Vec d, PetscErrorCode (*h0)(void *, Vec, Vec), void *ctx, PetscScalar *gd, PetscBool track);

/* The pd type's L-BFGS iteration, fused with PD's steps. Phi's gradient g = A x - rhs(x) and Phi
   come from the local step's passes (MSimPDProblem's gradient: each term's part of g where it
   computes its part of rhs, no product with A; -snes_pd_lbfgs_fused 0, or a problem whose terms
   cannot, take rhs(x) and the product), and H0 g one sweep of the factor. The scale gamma =
   s^T A s / s^T y comes from the Gram matrix kept by the two-loop recursion (MSimLBFGS), so an
   accepted iteration is one sweep, one local step and 2m + 3 passes over vectors. A step that
   does not lower Phi by Armijo's rule (to roundoff: it may pass a rise of MSIM_PHI_ROUNDOFF |Phi|,
   as msim's energy line search does; |Phi| counts gravity from the origin) is replaced by the
   plain PD step (which never raises Phi; its rhs from A x - g, one product) and the history
   restarts, as it does for a step that would leave the problem's feasible set (max_step < 1:
   shortened, it crawled along the barrier; pd_lbfgs.cpp). The pairs carry over
   from one solve to the next (the next time step's Hessian is close; the inertia term's y_n
   cancels in y). */
typedef struct {
  MSimPDProblem *pd;
  MSimLBFGS      lb;
  PetscReal      gamma_max;      /* H0's scale gamma = s^T A s / s^T y (newest pair), kept in [1, gamma_max] */
  Vec            rhs, G;         /* the local step's rhs and the gradient at the current iterate */
  Vec            D, Xt, Rt, Gt;  /* direction (the step is x - t D), trial iterate, its rhs and gradient */
  PetscReal      phi;            /* Phi at the current iterate */
  PetscBool      first;
  PetscInt       fallbacks, cut; /* plain PD steps taken instead; steps that would leave a feasible set (PD's instead) */
  PetscInt       backtracks;     /* steps shortened once by Phi's parabola */
  PetscBool      use_fused;      /* -snes_pd_lbfgs_fused: the gradient from the local step's passes where the problem can */
  PetscBool      check;          /* -snes_pd_lbfgs_check: compare g and s^T A s with the products (PetscInfo) */
  PetscBool      fused;          /* this solve's gradient is the problem's (rhs is not kept) */
  PetscBool      rhs_valid;      /* rhs is the local step's at the current iterate */
} MSimPDLBFGS;

PetscErrorCode MSimPDLBFGSCreate(MSimPDProblem *pd, Vec X, PetscInt m, PetscReal gamma_max, MSimPDLBFGS *st);
PetscErrorCode MSimPDLBFGSDestroy(MSimPDLBFGS *st);
/* a new solve from X: the local step and the gradient there (the history stays) */
PetscErrorCode MSimPDLBFGSBegin(MSimPDLBFGS *st, Vec X);
/* one iteration: X is replaced by the next iterate, whose local step, gradient and Phi are kept */
PetscErrorCode MSimPDLBFGSIterate(MSimPDLBFGS *st, Vec X);

/* For checkpoints: what the next solve reads besides X (MSimSolverHistory "pd_lbfgs"): the m
   pairs' slots, their rho and Gram matrix (the first apply of the next solve reads its rows), the
   ring's count and next slot, gamma, and the counters -info reports "so far". Get lends st's vectors; Set copies a restart's into st, if its m is st's. A field
   that a solve reads from the one before must be added to both, or restarts stop repeating the run
   bit for bit (tests/pd_lbfgs_restart.py). */
PetscErrorCode MSimPDLBFGSGetHistory(MSimPDLBFGS *st, MSimSolverHistory *h);
PetscErrorCode MSimPDLBFGSSetHistory(MSimPDLBFGS *st, const MSimSolverHistory *h, PetscBool *taken);
