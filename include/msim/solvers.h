/* msim's own nonlinear solver types, registered with SNESRegister. */
#pragma once
#include <msim/petsc_compat.h>
#include <petscsnes.h>
#include <string>
#include <vector>

#define SNESPD "pd"
#define SNESNTR "ntr"
#define PCMSIMLLT "msimllt"

/* PC type msimllt (serial sparse Cholesky, up to four right-hand sides in one sweep of the factor). */
PetscErrorCode PCCreate_MSimLLT(PC pc);
/* x = A^-1 b for nrhs <= 4 columns stored interleaved (row i's values together, as in a Vec of
   block size nrhs), without copies; sets the PC up if needed. Errors unless pc is msimllt. */
PetscErrorCode PCMSimLLTSolveInterleaved(PC pc, PetscInt nrhs, const PetscScalar *b, PetscScalar *x);
/* This rank's sparse factor after set-up: stored entries (explicit zeros of merged supernodes
   included) and supernodes. Options -pc_msimllt_relax r (default 0.3) and -pc_msimllt_max_width w
   (16) merge neighbouring supernodes while the stored entries grow by at most the fraction r and
   none is wider than w columns: fewer, wider dense blocks for the solves. */
PetscErrorCode PCMSimLLTGetFactorSize(PC pc, PetscInt64 *entries, PetscInt *supernodes);
/* Serially, msimllt keeps the factor of the last matrix it factored (the base) while the matrix
   differs from it only on a few diagonal entries (-pc_msimllt_update, -pc_msimllt_update_max_rank),
   so its solves depend on the base as well as on the matrix: a restart that must repeat a run bit
   for bit carries the base's diagonal. Get: d := the base's diagonal (A's layout), *has true; false
   on several ranks or before the first factorization. Set: the next set-up first factors A with its
   diagonal replaced by d, as the base, then updates or refactors for A as usual; nothing on several
   ranks. */
PetscErrorCode PCMSimLLTGetBaseDiagonal(PC pc, Vec d, PetscBool *has);
PetscErrorCode PCMSimLLTSetBaseDiagonal(PC pc, Vec d);

/* Errors, naming the option, if ksp's PC is a factorization (lu, cholesky, ilu, icc) that A's
   matrix type has no package for (ICC over several ranks); call after KSPSetFromOptions, before
   KSPSetUp. Nothing is factored. */
PetscErrorCode MSimCheckFactorAvailable(KSP ksp, Mat A);

/* Phi carries roundoff from its spring terms' cancellation (l - L): changes below this fraction of
   |Phi| are not resolved, and Newton's line search and the trust region judge a step by |g| there. */
#define MSIM_PHI_ROUNDOFF 1e-12

/* Line search for Newton on the implicit step (a SNESLineSearch shell function): backtracking on
   Phi, and near convergence, where Phi stops resolving progress, on |g|. ctx is NULL or an
   MSimLineSearchCtx whose descent callback replaces a Newton direction that does not lower Phi
   (an indefinite Hessian's) by a direction that does (the PSD-projected Hessian's). */
typedef struct {
  /* Y := a descent direction of Phi at X (the step is X - lambda Y); F = g(X) */
  PetscErrorCode (*descent)(SNES snes, Vec X, Vec F, Vec Y, void *ctx);
  /* the largest lambda in (0, 1] for which X - lambda Y is feasible (NULL: 1): the search
     starts there (contact barriers are undefined beyond) */
  PetscErrorCode (*max_step)(SNES snes, Vec X, Vec Y, PetscReal *lambda, void *ctx);
  void    *ctx;
  PetscInt nfallback; /* directions replaced, over the life of the SNES */
  /* |Y| of the last search's direction before max_step's cut and the halvings: the length of
     the step the method asked for. A step rule (-msim_step_atol) reads it, so that a step cut
     short by a barrier's feasible set or by backtracking is not taken for a converged one. */
  PetscReal dxnorm;
} MSimLineSearchCtx;
PetscErrorCode MSimLineSearchEnergy(SNESLineSearch ls, void *ctx);

/* SNES type ntr: Newton trust region on the objective, truncated CG (-ksp_type stcg|nash|gltr). */
PetscErrorCode SNESCreate_NTR(SNES snes);
/* over the life of snes: steps ntr rejected, and its CG solves ended by negative curvature (both
   0 for other types; either pointer may be NULL) */
PetscErrorCode SNESNTRGetCounts(SNES snes, PetscInt *rejected, PetscInt *negative);

/* y = (A kron I3) x - b (b may be NULL) for a scalar AIJ matrix A on Vecs of interleaved x, y, z:
   one pass on one rank; elsewhere through the MAIJ *maij (made on first use, the caller's). */
PetscErrorCode MSimMatMultInterleaved3(Mat A, Mat *maij, Vec x, Vec b, Vec y);

/* Registers "pd", "ntr" and "msimllt" once. */
PetscErrorCode MSimSolversRegisterAll(void);

/* What the pd type needs from the problem it solves, composed on the SNES's DM under the name
   "MSimPDProblem" by whoever sets the problem up, so the type finds it also when it runs as the
   nonlinear preconditioner of another SNES (which shares the DM). */
typedef struct {
  /* global step: solve A x = rhs for the constant PD matrix A. guess (NULL: zero; may be x) is
     where an iterative solver starts, and the current iterate is the right one: the solver then
     reduces the residual of that guess, so its relative tolerance shrinks with PD's corrections */
  PetscErrorCode (*global_solve)(void *ctx, Vec rhs, Vec guess, Vec x);
  /* local step and right-hand side: rhs = M y + h^2 sum_s k_s A_s^T d_s(x) + boundary terms;
     when phi is not NULL also Phi(x), from the same pass over the springs */
  PetscErrorCode (*rhs)(void *ctx, Vec x, Vec rhs, PetscReal *phi);
  /* builds and factors the global step's matrix (else the first global_solve does) */
  PetscErrorCode (*setup)(void *ctx);
  /* y = (A kron I3) x - b (b NULL: 0) with A as the last local step left it (contact may
     reweight it): with b = rhs(x) it is Phi's gradient, for -snes_pd_lbfgs */
  PetscErrorCode (*apply)(void *ctx, Vec x, Vec b, Vec y);
  /* optional (NULL: rhs and apply): the local step's passes giving Phi's gradient g = A x - rhs(x)
     and Phi(x) without the product with A, for -snes_pd_lbfgs; *done false (g untouched) where
     some term of the problem cannot give its part there */
  PetscErrorCode (*gradient)(void *ctx, Vec x, Vec g, PetscReal *phi, PetscBool *done);
  /* the largest alpha in (0, 1] for which x - alpha d stays inside every term's feasible set
     (contact and volume barriers; 1 where no term has one), for steps global_solve does not make */
  PetscErrorCode (*max_step)(void *ctx, Vec x, Vec d, PetscReal *alpha);
  /* set by the solver while global_solve may leave its Phi check (feasible sets) to the next rhs
     on the same x, which sums Phi anyway: only where every global_solve(rhs, x, x) is followed by
     rhs(x) or finish and nothing reads x between (plain PD with -snes_pd_fixed) */
  PetscBool defer_check;
  /* completes a deferred check at the solver's last iterate (may change x): call after the loop */
  PetscErrorCode (*finish)(void *ctx);
  void *ctx;
} MSimPDProblem;
/* If snes, or its nonlinear preconditioner, is of type pd: set its problem's global step up now,
   so that a bad -pd_ksp_* / -pd_pc_* option stops the run before any output and -log_view counts
   the factorization where it is set up. Call after SNESSetFromOptions. */
PetscErrorCode MSimSNESSetUpPD(SNES snes);
/* Whether snes's type solves linear systems with the Jacobian (newtonls, ksponly, ntr, qn with
   -snes_qn_scale_type jacobian, ...; not pd, anderson, ngmres, ncg, nrichardson, plain qn): PETSc's
   own flag for it, read after SNESSetFromOptions. */
PetscErrorCode MSimSNESUsesJacobian(SNES snes, PetscBool *uses);
/* Refuses, in one line naming the option, the SNES types msim's problems cannot serve (ngs, nasm,
   aspin, patch, shell; composite without its solvers or with one of those), a nonlinear
   preconditioner the type would not run (pd, ntr, ksponly, the VI types), newtonls
   preconditioned on the left, a sub-solver (composite's, the nonlinear preconditioner, fas's)
   that would solve linear systems on PETSc's dense finite-difference Jacobian, and the options
   of a SNES type the run does not use (-snes_<type>_*). Call after SNESSetFromOptions, before any output. */
PetscErrorCode MSimSNESCheckServed(SNES snes);

/* What a solver carries from one SNESSolve to the next, beyond the problem's own state: SNES pd's
   L-BFGS pairs (-snes_pd_lbfgs) and ntr's trust radius. The next time step starts from it, so a
   restart repeats a run bit for bit only if checkpoints carry it (src/output/checkpoint.cpp). name
   says whose it is ("": nothing carried: a solver without such state, or before its first solve),
   real holds its scalars, vec its vectors, shaped like the SNES's solution. A type provides it by
   composing "MSimSNESGetHistory_C" and "MSimSNESSetHistory_C" (PetscObjectComposeFunction). */
typedef struct {
  std::string            name;
  std::vector<PetscReal> real;
  std::vector<Vec>       vec; /* from Get: the solver's own (do not destroy); to Set: copied from */
} MSimSolverHistory;
/* snes's, else its nonlinear preconditioner's (the pd NPC of anderson/ngmres) */
PetscErrorCode MSimSNESGetHistory(SNES snes, MSimSolverHistory *h);
/* a restart's: the solver takes it if it would carry state of that name and shape (same type and
   options), else starts afresh (*taken false) */
PetscErrorCode MSimSNESSetHistory(SNES snes, const MSimSolverHistory *h, PetscBool *taken);
/* whether all that snes (or its NPC) carries from one solve to the next is in its history: not
   for PETSc's qn, whose pairs stay in a Mat out of reach */
PetscErrorCode MSimSNESHistoryIsComplete(SNES snes, PetscBool *complete);
