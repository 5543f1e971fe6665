/* Backtracking line search on the incremental potential Phi (SNES's objective) for Newton on the
   implicit step: Armijo decrease of Phi along the Newton direction, halving the step. One
   fallback for the end of a solve: Phi carries roundoff from the spring terms' cancellation
   (l - L) far above the decrease of the last Newton steps, so once Phi no longer changes beyond
   1e-12 of itself a step is accepted when it reduces |g|. PETSc's bt failed there
   (DIVERGED_LINE_SEARCH with |g| at 1e-7 of its start on the benchmark cloth), and at such a step
   the Newton direction is a descent direction of |g|^2 for the exact Jacobian.
   On the exact (indefinite) Hessian a Newton direction may raise Phi, or lower it so little that
   only a tiny step passes Armijo. Such a direction is never taken (an ascent direction used to
   pass the test with a positive slope, and Newton stalled): the caller's descent callback, where
   given, supplies the PSD-projected Hessian's direction instead; otherwise the search fails. */
#include <msim/solvers.h>

/* Backtracks from lambda = 1 along Y over at most maxhalvings halvings; W holds the accepted point. */
static PetscErrorCode Backtrack(SNES snes, Vec X, Vec F, Vec Y, Vec W, Vec G, PetscReal phi0, PetscReal slope, PetscReal fnorm, PetscReal lambda0, PetscInt maxhalvings, PetscReal *lambda, PetscBool *accepted, PetscBool *have_g, PetscReal *gnorm)
{
  PetscReal phi;

  PetscFunctionBeginUser;
  *accepted = PETSC_FALSE;
  *have_g   = PETSC_FALSE;
  *lambda   = lambda0;
  for (PetscInt it = 0; it < maxhalvings; it++, *lambda *= 0.5) {
    PetscCall(VecWAXPY(W, -*lambda, Y, X));
    PetscCall(SNESComputeObjective(snes, W, &phi));
    if (PetscIsInfOrNanReal(phi)) continue;
    if (phi <= phi0 + 1e-4 * *lambda * slope) *accepted = PETSC_TRUE;
    else if (PetscAbsReal(phi - phi0) <= MSIM_PHI_ROUNDOFF * PetscAbsReal(phi0)) {
      PetscCall(SNESComputeFunction(snes, W, G));
      PetscCall(VecNorm(G, NORM_2, gnorm));
      *have_g   = PETSC_TRUE;
      *accepted = (PetscBool)(*gnorm < fnorm);
    }
    if (*accepted) break;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* An exact Newton direction gets this many halvings (lambda >= 1/1024) before it counts as a
   poor direction of an indefinite Hessian and, where a descent callback is given, is replaced;
   accepting the tiny steps it would take stalled Newton on the benchmark cloth (|g| flat at 1e-5
   of its start for 100 iterations). */
#define MSIM_LS_EXACT_HALVINGS 10

PetscErrorCode MSimLineSearchEnergy(SNESLineSearch ls, void *vctx)
{
  MSimLineSearchCtx *ctx = (MSimLineSearchCtx *)vctx;
  SNES               snes;
  Vec                X, F, Y, W, G;
  PetscReal          xnorm, fnorm, ynorm, gnorm = 0, phi0, slope, lambda = 1, lambda0 = 1, steptol, maxstep, rtol, atol, ltol;
  PetscInt           maxit;
  PetscBool          accepted = PETSC_FALSE, have_g = PETSC_FALSE, domain, can_replace;

  PetscFunctionBeginUser;
  PetscCall(SNESLineSearchGetSNES(ls, &snes));
  PetscCall(SNESLineSearchGetVecs(ls, &X, &F, &Y, &W, &G));
  PetscCall(SNESLineSearchGetNorms(ls, &xnorm, &fnorm, &ynorm));
  PetscCall(SNESLineSearchGetTolerances(ls, &steptol, &maxstep, &rtol, &atol, &ltol, &maxit));
  PetscCall(SNESComputeObjective(snes, X, &phi0));
  PetscCall(VecDot(F, Y, &slope)); /* the step is X - lambda Y: dPhi/dlambda = -g . Y */
  slope       = -slope;
  can_replace = (PetscBool)(ctx && ctx->descent);
  if (ctx) PetscCall(VecNorm(Y, NORM_2, &ctx->dxnorm));
  if (ctx && ctx->max_step) PetscCall(ctx->max_step(snes, X, Y, &lambda0, ctx->ctx));
  if (slope < 0) PetscCall(Backtrack(snes, X, F, Y, W, G, phi0, slope, fnorm, lambda0, can_replace ? MSIM_LS_EXACT_HALVINGS : PetscMax(maxit, 40), &lambda, &accepted, &have_g, &gnorm));
  if (!accepted && can_replace) {
    PetscCall(PetscInfo(snes, "energy line search: %s direction replaced by the descent callback's\n", slope < 0 ? "poor" : "ascent"));
    PetscCall(ctx->descent(snes, X, F, Y, ctx->ctx));
    ctx->nfallback++;
    PetscCall(VecNorm(Y, NORM_2, &ctx->dxnorm));
    PetscCall(VecDot(F, Y, &slope));
    slope = -slope;
    if (ctx->max_step) PetscCall(ctx->max_step(snes, X, Y, &lambda0, ctx->ctx));
    if (slope < 0) PetscCall(Backtrack(snes, X, F, Y, W, G, phi0, slope, fnorm, lambda0, PetscMax(maxit, 40), &lambda, &accepted, &have_g, &gnorm));
  }
  if (!accepted) {
    PetscCall(PetscInfo(snes, "energy line search: no decrease of Phi or |g| (slope %g)\n", (double)slope));
    PetscCall(SNESLineSearchSetReason(ls, SNES_LINESEARCH_FAILED_REDUCT));
    /* newtonls takes a failed search on a step below -snes_stol |x| for convergence (Y at
       roundoff, where neither Phi nor |g| can still fall): it reads these norms, so they must be
       X's and the rejected direction's, not the stale ones PETSc handed in (the last accepted
       step's, 1.1 m on the falling benchmark cloth, which turned a converged step 8 into
       DIVERGED_LINE_SEARCH) */
    PetscCall(VecNorm(X, NORM_2, &xnorm));
    PetscCall(VecNorm(Y, NORM_2, &ynorm));
    PetscCall(SNESLineSearchSetNorms(ls, xnorm, fnorm, ynorm));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (!have_g) {
    PetscCall(SNESComputeFunction(snes, W, G));
    PetscCall(VecNorm(G, NORM_2, &gnorm));
  }
  PetscCall(SNESGetFunctionDomainError(snes, &domain));
  if (domain || PetscIsInfOrNanReal(gnorm)) {
    PetscCall(SNESLineSearchSetReason(ls, domain ? SNES_LINESEARCH_FAILED_DOMAIN : SNES_LINESEARCH_FAILED_NANORINF));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* SNES's step-length test (-snes_stol: |dx| < stol |x|) reads ynorm after the search: it must be
     the length of the step taken, lambda |Y|. PETSc hands the search a stale ynorm (1 at the first
     iteration), and passing that back kept -snes_stol from ever triggering. */
  PetscCall(VecNorm(Y, NORM_2, &ynorm));
  ynorm *= lambda;
  PetscCall(VecCopy(W, X));
  PetscCall(VecCopy(G, F));
  PetscCall(VecNorm(X, NORM_2, &xnorm));
  PetscCall(SNESLineSearchSetLambda(ls, lambda));
  /* with max_step's lambda0: runs/contact/study.py newton counts from this line the Newton steps a
     barrier's safe step cut (half of them on the benchmark cloth's drape) */
  PetscCall(PetscInfo(snes, "energy line search: lambda %g (max_step %g)\n", (double)lambda, (double)lambda0));
  PetscCall(SNESLineSearchSetNorms(ls, xnorm, gnorm, ynorm));
  PetscCall(SNESLineSearchSetReason(ls, SNES_LINESEARCH_SUCCEEDED));
  PetscFunctionReturn(PETSC_SUCCESS);
}
