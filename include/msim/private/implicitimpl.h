/* The implicit problem's body, its time scheme's and its energy terms' bodies and ops, for the
   problem (src/implicit/), its schemes and terms, and the implicit integrators (PETSc's
   include/petsc/private pattern). The solvers see the problem through SNES callbacks and
   MSimPDProblem (msim/solvers.h); users and tests through the functions of msim/implicit.h. */
#pragma once
#include <msim/implicit.h>
#include <vector>

/* What the terms need from the step, set from the scheme at each step (and for PD's matrix). */
typedef struct {
  PetscReal t, h;  /* start and size of the step */
  PetscReal h2;    /* beta h^2: the weight of potential energies in Phi */
  PetscReal hd;    /* the weight of a dissipation potential d/2 |x - xref|^2 for a viscous force
                      -d v(x): beta h^2 dv/dx (implicit Euler: h) */
  PetscReal tx;    /* time at which the unknown x sees the boundary b(t) (Euler: t + h) */
  PetscReal tref;  /* time of xref (Euler: t) */
  Vec       xref;  /* the state dissipative terms measure from, and spring damping takes its
                      axes from (Euler: x_n) */
} MSimImplicitStep;

/* A time scheme: Phi's y and beta, the first iterate, and the velocity update. */
typedef PetscErrorCode (*MSimImplicitSchemeBeginStep)(MSimImplicitScheme, MSimImplicit, PetscReal t, PetscReal h, Vec X, Vec V);
typedef PetscErrorCode (*MSimImplicitSchemeEndStep)(MSimImplicitScheme, MSimImplicit, Vec X, Vec V);
/* X := the unknown that the scheme's own position relation gives for the end-of-step velocity
   v_{n+1} = W (V holds v_n, imp->Xn x_n): the first iterate of -msim_implicit_guess extrapolate
   and filtered */
typedef PetscErrorCode (*MSimImplicitSchemePredict)(MSimImplicitScheme, MSimImplicit, Vec V, Vec W, Vec X);
typedef struct {
  /* from (X, V) at t: y, x_n and whatever history the scheme keeps; imp->step.xref, tref, tx */
  MSimImplicitSchemeBeginStep begin_step;
  /* X holds the minimizer on entry: x_{n+1} into X and v_{n+1} into V */
  MSimImplicitSchemeEndStep end_step;
  MSimImplicitSchemePredict predict;
  PetscErrorCode (*view)(MSimImplicitScheme, PetscViewer);
  PetscErrorCode (*destroy)(MSimImplicitScheme); /* what the scheme keeps besides its work vectors */
} MSimImplicitSchemeOps;

/* A scheme type: one constant table at the end of its file in schemes/, registered by name in
   registry.cpp, from which the problem makes the scheme (MSimImplicitCreateWithScheme). */
typedef struct {
  PetscReal                   beta, gamma, guess; /* the scheme's fields of the same names */
  PetscInt                    nwork, nhistory;    /* how many work vectors, and of them history */
  const char                 *no_barrier, *no_objective;
  MSimImplicitSchemeBeginStep begin_step;
  MSimImplicitSchemeEndStep   end_step;
  MSimImplicitSchemePredict   predict;
  PetscBool                   history_at_h; /* the history is states one step h back: valid only at the step it was written with */
} MSimImplicitSchemeType;

#define MSIM_SCHEME_MAX_WORK 8

struct _n_MSimImplicitScheme {
  char                  type[64];
  MSimImplicit          imp;   /* the problem it belongs to (set before its create function) */
  PetscReal             beta;  /* h2 = beta h^2 */
  PetscReal             gamma; /* hd = gamma h (Euler 1; BDF2 2/3; midpoint and Newmark 1/2) */
  PetscReal             guess; /* the first iterate x_n + guess h v_n (Euler 1, midpoint 1/2) */
  /* why a term that keeps the unknown feasible (a contact barrier) cannot guarantee x_{n+1}
     with this scheme, or NULL where it can; such terms refuse the scheme with this reason */
  const char           *no_barrier;
  /* why the step's residual is not the gradient of Phi, or NULL where it is (all but
     discrete_gradient): the terms then give their discrete gradient between x_n and the unknown
     (discrete_gradient, discrete_jacobian) where they otherwise give Phi's gradient and Hessian,
     the problem has no objective, and what needs one (pd, qn, ntr, msim's energy line search) or
     a term without a discrete gradient refuses the scheme with this reason */
  const char           *no_objective;
  MSimImplicitSchemeOps ops;
  /* vectors shaped like x that the scheme keeps (made from its type's nwork, destroyed with it);
     the first nhistory are what an exact restart needs besides x and v (none for Euler; BDF2:
     x_{n-1}, v_{n-1}; Newmark: a_n): a checkpoint writes them, a restart loads them in place */
  Vec                   work[MSIM_SCHEME_MAX_WORK];
  PetscInt              nwork, nhistory;
  void                 *data;
  /* the history vectors hold the previous step's history: set by end_step, and by a restart
     that loaded them; while false, begin_step starts the scheme up from (x_n, v_n) alone */
  PetscBool             history_valid;
  PetscBool             history_at_h; /* its type's */
};

/* An energy term. Every op is optional but energy and gradient; a term with a diagonal op is the
   quadratic w/2 |x - c|^2 and needs no other: the problem folds it into its inertia pass (one
   loop over the dofs for energy, gradient, Hessian diagonal, PD matrix and right-hand side). Each
   op is NULL unless the term's type sets it (one static table per type, with designated
   initializers, copied into term->ops by its create function, which may then drop the ops its
   options make unneeded). */
typedef struct {
  PetscErrorCode (*diagonal)(MSimImplicitTerm, PetscReal *w, Vec *c) = NULL;
  /* *e += this rank's part of the term's Phi at X (the problem sums over ranks) */
  PetscErrorCode (*energy)(MSimImplicitTerm, Vec X, PetscReal *e) = NULL;
  /* G += the term's gradient at X (owned rows) */
  PetscErrorCode (*gradient)(MSimImplicitTerm, Vec X, Vec G) = NULL;
  /* Hessian at X (psd: each block projected to PSD), as coefficients of the system's one-pass
     assembly ... */
  PetscErrorCode (*hessian_coefficients)(MSimImplicitTerm, Vec X, PetscBool psd, MSimMatrixCoefficients *c) = NULL;
  /* ... or as blocks of its own, added into the assembled J (ADD_VALUES, then assemble) */
  PetscErrorCode (*hessian)(MSimImplicitTerm, Vec X, PetscBool psd, Mat J) = NULL;
  /* projective dynamics: its weights in the scalar PD matrix A (ADD_VALUES; A is assembled by
     the problem), and its local step: rhs += sum A_s^T w_s p_s(X) (owned rows), *e += its Phi at X
     when e is not NULL. pd_begin (optional) starts what pd_rhs needs (the ghost exchange), so it
     travels while the problem's inertia pass runs. */
  PetscErrorCode (*pd_matrix)(MSimImplicitTerm, Mat A) = NULL;
  PetscErrorCode (*pd_begin)(MSimImplicitTerm, Vec X) = NULL;
  PetscErrorCode (*pd_rhs)(MSimImplicitTerm, Vec X, Vec rhs, PetscReal *e) = NULL;
  /* optional, PD + L-BFGS's gradient in the local step's pass (pd_gradient.cpp): G += the term's
     part of Phi's gradient at X, which is its pd_matrix part of A X less its pd_rhs at X (the
     springs: h2 k (1 - L/l) d where pd_rhs adds h2 k (L/l) d), and *e as pd_rhs. A term with
     pd_matrix but without it makes the fused gradient fall back to A X - rhs(X) */
  PetscErrorCode (*pd_gradient)(MSimImplicitTerm, Vec X, Vec G, PetscReal *e) = NULL;
  /* optional, before each local step: a term whose PD weights depend on the state (contact:
     the vertices near an obstacle) updates them at X and sets *changed when they changed; the
     problem then reassembles A and refactors it (pd_matrix and pd_rhs use the new weights) */
  PetscErrorCode (*pd_reweight)(MSimImplicitTerm, Vec X, PetscBool *changed) = NULL;
  /* the largest alpha in (0, *alpha] for which X - alpha Y stays where the term is defined
     (contact barriers: the line search starts there); lowers *alpha where it must, else leaves it */
  PetscErrorCode (*max_step)(MSimImplicitTerm, Vec X, Vec Y, PetscReal *alpha) = NULL;
  /* optional, with max_step: where the term's feasible set is per vertex (obstacles), moves back
     each vertex of X whose own segment from the feasible A would leave it (its own safe step), so
     that one vertex near an obstacle does not shorten every vertex's move (MSimImplicitGuess, on
     the first iterate) */
  PetscErrorCode (*clamp)(MSimImplicitTerm, Vec A, Vec X) = NULL;
  /* optional, with max_step: after it, whether PD's global step must check Phi along the step
     (halving until it does not rise); a term without it always asks for the check */
  PetscErrorCode (*pd_check)(MSimImplicitTerm, PetscBool *needed) = NULL;
  /* optional, PD: a term whose right-hand side is its gradient at X0 with diagonal weights w_v in
     A (obstacles; none: the tets' barrier) gives, for each step length alpha[j], gap[j] +=
     E(X0 - alpha D) - E(X0) + alpha grad E(X0).D - alpha^2/2 sum_v w_v |D_v|^2, summed over the
     ranks (+inf where it cannot say): its excess over the global step's quadratic model, from
     which PD bounds Phi without a pass over the other terms, to leave the check out or to size a
     rejected step (pd_steps.cpp, PDBound). Called after max_step with its X (as X0) and Y (as D,
     unchanged), alpha[j] at most its step */
  PetscErrorCode (*pd_gap)(MSimImplicitTerm, Vec X0, Vec D, PetscInt n, const PetscReal alpha[], PetscReal gap[]) = NULL;
  /* a term whose feasible set moves with time (moving obstacles): A holds x_n on entry; moves the
     vertices it must so that A is feasible at step.tx (MSimImplicitGuess pulls the first iterate
     back towards A instead of x_n) */
  PetscErrorCode (*feasible_start)(MSimImplicitTerm, Vec A) = NULL;
  /* optional: refuses (one line, collective) the state X at time t a run starts from where the
     term's feasible set does not hold it (self-contact: a surface through itself or closer than
     its start gap; the inversion barrier: an inverted tet), so that no step begins outside it.
     restart: NULL for the scene's start, else the checkpoint it was read from, in words
     (MSimCheckpointRestartState), as the line names it */
  PetscErrorCode (*check_start)(MSimImplicitTerm, PetscReal t, Vec X, const char *restart) = NULL;
  /* for a scheme whose residual is not Phi's gradient (scheme->no_objective): G += the term's
     part of that residual at X, its discrete gradient between imp->Xn and X (times step.h2) with
     its dissipation; and that part's exact Jacobian, blocks added into the assembled J
     (ADD_VALUES, then assemble) */
  PetscErrorCode (*discrete_gradient)(MSimImplicitTerm, Vec X, Vec G) = NULL;
  PetscErrorCode (*discrete_jacobian)(MSimImplicitTerm, Vec X, Mat J) = NULL;
  /* optional: state of the term that an exact restart needs besides x, v and the scheme's
     history (the obstacles' PD weights, which the factor of a fixed-iteration PD step holds): a
     Vec shaped like X, filled by get_history whenever asked (a checkpoint writes it), and read back
     by history_loaded after a restart loaded it. Its presence must depend on options only, as a
     checkpoint's count of history vectors must match at restart. */
  PetscErrorCode (*get_history)(MSimImplicitTerm, Vec *h) = NULL;
  /* optional: a term with quantities lagged over the step (friction: the normal forces and
     tangent bases it takes at x_n) takes them again at the step's solution X where they differ
     from those the solve used, and then sets *again (else leaves it): the integrator solves the
     step again from X (IPC's lag iterations, -msim_friction_lag_iterations). Collective: the same
     answer on every rank. A new step (its x_n) starts the lag afresh. */
  PetscErrorCode (*lag)(MSimImplicitTerm, Vec X, PetscBool *again) = NULL;
  PetscErrorCode (*history_loaded)(MSimImplicitTerm) = NULL;
  PetscErrorCode (*view)(MSimImplicitTerm, PetscViewer) = NULL;
  PetscErrorCode (*destroy)(MSimImplicitTerm) = NULL;
} MSimImplicitTermOps;

struct _n_MSimImplicitTerm {
  char                type[64];
  MSimImplicit        imp;
  MSimImplicitTermOps ops;
  void               *data;
  /* its energy is already in the system's potential (MSimSystemComputeEnergy: the tets' volume
     term), so the start's barrier energy (implicit.cpp) must not count it again */
  PetscBool           in_potential = PETSC_FALSE;
};

/* The ops of a term computed by one pass over what this rank holds (self-contact's pairs, their
   friction): LocalEnergy adds this rank's part of E, unreduced; AddGradient adds sign grad E to G
   (owned rows, ghosts sent back). energy sums the parts over the ranks; gradient is +grad E;
   pd_rhs is -grad E with the local part of E, which PD sums with the other terms' in one
   reduction. */
template <PetscErrorCode (*LocalEnergy)(MSimImplicitTerm, Vec, PetscReal *)>
PetscErrorCode MSimTermSummedEnergy(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  PetscReal local = 0;

  PetscFunctionBeginUser;
  PetscCall(LocalEnergy(term, X, &local));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, PetscObjectComm((PetscObject)X)));
  *e += local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <PetscErrorCode (*AddGradient)(MSimImplicitTerm, Vec, Vec, PetscReal)>
PetscErrorCode MSimTermGradient(MSimImplicitTerm term, Vec X, Vec G)
{
  PetscFunctionBeginUser;
  PetscCall(AddGradient(term, X, G, 1.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <PetscErrorCode (*LocalEnergy)(MSimImplicitTerm, Vec, PetscReal *), PetscErrorCode (*AddGradient)(MSimImplicitTerm, Vec, Vec, PetscReal)>
PetscErrorCode MSimTermPDRHS(MSimImplicitTerm term, Vec X, Vec rhs, PetscReal *e)
{
  PetscFunctionBeginUser;
  PetscCall(AddGradient(term, X, rhs, -1.0));
  if (e) PetscCall(LocalEnergy(term, X, e));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -msim_implicit_guess's choices, in the order of MSimImplicitGuessTypes */
enum { MSIM_GUESS_CONSTANT_VELOCITY, MSIM_GUESS_EXTRAPOLATE, MSIM_GUESS_FILTERED, MSIM_GUESS_INERTIAL };

struct _n_MSimImplicit {
  MSimSystem         sys;
  PetscReal          h, t;    /* step and start time of the current step */
  MSimImplicitStep   step;    /* the terms' view of the step (MSimImplicitStepUpdate) */
  Vec                Xn, Y;   /* x_n and y */
  Vec                guess_a, guess_d; /* MSimImplicitGuess's work: the feasible start and the step from it (made once) */
  /* the first iterate (-msim_implicit_guess, problem.cpp): x_n + guess h v_n, the scheme's
     position at the extrapolated v_{n+1} = 2 v_n - v_{n-1} (Vprev: v_{n-1}, kept by EndStep,
     valid once a step has ended or a restart loaded it; a checkpoint carries it after the
     scheme's history), the same with v_n - v_{n-1} filtered by the PD matrix, or y; Vstar, Vwork:
     work */
  PetscInt           guess_type;
  Vec                Vprev, Vstar, Vwork;
  PetscBool          vprev_valid;
  PetscBool          psd;     /* project Hessian blocks to PSD in the Jacobian */
  MSimImplicitScheme scheme;
  PetscInt           nterms;
  MSimImplicitTerm   terms[16];
  /* projective dynamics: scalar matrix A = M + the terms' weights (springs: h^2 k_s + h kd per
     spring's Laplacian; drag: h c I) over free vertices, factored once (KSP prefix pd_), three
     columns solved together */
  Mat        A;
  Mat        A3;              /* A kron I3 on block-size-3 Vecs (MAIJ), made on first use */
  KSP        pdksp;
  Mat        B, Xd;           /* dense nown x 3: right-hand sides and solutions */
  PetscBool  pd_direct;       /* preonly + msimllt: solve the interleaved Vec arrays directly */
  PetscBool  pd_iterative;    /* a Krylov -pd_ksp_type: x, y, z one at a time from a guess */
  Vec        pdb, pdx;        /* one column of the right-hand side and of the solution */
  PetscInt   pd_lits;         /* Krylov iterations of the PD solves in the current step */
  PetscInt   nfactor;         /* numeric factorizations done by the PD solves */
  PetscBool  pd_pc;           /* the PD factor preconditions a SNES's linear solves (MSimImplicitPDSetPC) */
  Vec        rhs;
  /* Phi at the last local step's X (the Vec of that id, at that state; id 0: none), where the
     global step's check starts */
  PetscReal        pd_phi       = 0;
  PetscObjectId    pd_phi_id    = 0;
  PetscObjectState pd_phi_state = 0;
  /* The global step's Phi check deferred to the next local step (plain PD with -snes_pd_fixed,
     MSimPDProblem's defer_check): X = X0 - alpha D must not raise Phi above phi0; the local step
     at X sums Phi(X) anyway, where a separate evaluation cost a term pass per iteration. pd_px
     holds a reference to the iterate, pd_pstate its state after the step (pd_steps.cpp) */
  PetscBool        pd_pending   = PETSC_FALSE;
  Vec              pd_px        = NULL;
  PetscObjectState pd_pstate    = 0;
  Vec              pd_x0 = NULL, pd_d = NULL; /* the global step's work: x_k and D, made once */
  PetscReal        pd_alpha = 0, pd_phi0 = 0;
  PetscObjectState pd_astate = 0; /* A's state when D was solved: the bound on Phi holds only for that A */
  PetscObjectState pd_start_ystate = 0; /* y's state at the step whose first iterate was compared with x_n (PDStartNoWorse) */
  /* the last check halved the step: the next one is done at once, where each halving costs a
     pass of MSimImplicitObjective instead of a local step (rejections come in runs) */
  PetscBool        pd_rejected  = PETSC_FALSE;
  MSimPDProblem pd;
  /* a term's reason that the step has no feasible start (its feasible_start, where carrying
     vertices cannot help: the tets' barrier under moving handles); empty: none. The integrator
     fails the step with it, unsolved, as a failed solve (the last finite state kept) */
  char             refused[512] = "";
};

/* For the schemes' begin_step: what the terms measure from (imp->step.xref, tref) and when the
   unknown sees the boundary (tx) */
PetscErrorCode MSimImplicitSetReference(MSimImplicit imp, Vec xref, PetscReal tref, PetscReal tx);
/* the sum of the diagonal terms' weights w (each term w/2 |x - c|^2), for the Jacobian's and PD's
   diagonals */
PetscErrorCode MSimImplicitDiagonalWeight(MSimImplicit imp, PetscReal *w);
/* PD's weights of state-dependent terms (contact) taken at X, A refactored where they changed
   (pd_steps.cpp); for Newton's Jacobian with the PD factor as preconditioner */
PetscErrorCode MSimImplicitPDReweight(MSimImplicit imp, Vec X);
/* PD's global step's moves (pd_steps.cpp), for the passes that skip the vertices far from a
   barrier: a max_step's bound on every vertex's |D_v| of a step direction D (valid while D is
   unchanged), and, for an iterate X that the step overwrote in place, the state X had before and a
   bound on every vertex's move from there (has: X is as the step left it) */
PetscErrorCode MSimImplicitPDSetVertexBound(Vec D, PetscReal bound);
PetscErrorCode MSimImplicitPDMoveBound(Vec X, PetscObjectState *from, PetscReal *bound, PetscBool *has);
/* The start of PD's local pass, shared by MSimImplicitPDRHS and MSimImplicitPDGradient: every
   term's pd_begin at X (the ghost exchange starts), and the first diagonal term's weight w and
   centre C (imp->Y and w = 0 where there is none), which the inertia pass takes in the same loop;
   *next: the index after that term, where the other diagonal terms' pass starts. */
PetscErrorCode MSimImplicitPDLocalBegin(MSimImplicit imp, Vec X, PetscReal *w, Vec *C, PetscInt *next);
/* PD + L-BFGS's gradient (MSimPDProblem's gradient, pd_gradient.cpp): G = Phi's gradient at X
   (A X - rhs(X), without the product with A) and Phi(X), in the local step's passes; *done false
   (G untouched) where a term cannot give its part (pd_matrix without pd_gradient, or
   pd_reweight): the caller then takes the local step and the product. ctx: the MSimImplicit. */
PetscErrorCode MSimImplicitPDGradient(void *ctx, Vec X, Vec G, PetscReal *phi, PetscBool *done);
