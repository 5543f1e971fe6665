/* Backtracking line search on the incremental potential Phi (SNES's objective) for Newton on the
   implicit step: Armijo decrease of Phi along the Newton direction, halving the step. One
   fallback for the end of a solve: Phi carries roundoff from the spring terms' cancellation
   (l - L) far above the decrease of the last Newton steps, so once Phi no longer changes beyond
   1e-12 of itself a step is accepted when it reduces |g|. PETSc's bt failed there
   (DIVERGED_LINE_SEARCH with |g| at 1e-7 of its start on the benchmark cloth), and at such a step
   the Newton direction is a descent direction of |g|^2 for the exact Jacobian. */
#include <msim/solvers.h>

PetscErrorCode MSimLineSearchEnergy(SNESLineSearch ls, void *ctx)
{
  SNES      snes;
  Vec       X, F, Y, W, G;
  PetscReal xnorm, fnorm, ynorm, gnorm = 0, phi0, phi, slope, lambda = 1, steptol, maxstep, rtol, atol, ltol;
  PetscInt  maxit, it;
  PetscBool accepted = PETSC_FALSE, have_g = PETSC_FALSE, domain;

  PetscFunctionBeginUser;
  PetscCall(SNESLineSearchGetSNES(ls, &snes));
  PetscCall(SNESLineSearchGetVecs(ls, &X, &F, &Y, &W, &G));
  PetscCall(SNESLineSearchGetNorms(ls, &xnorm, &fnorm, &ynorm));
  PetscCall(SNESLineSearchGetTolerances(ls, &steptol, &maxstep, &rtol, &atol, &ltol, &maxit));
  PetscCall(SNESComputeObjective(snes, X, &phi0));
  PetscCall(VecDot(F, Y, &slope)); /* the step is X - lambda Y: dPhi/dlambda = -g . Y */
  slope = -slope;
  for (it = 0; it < PetscMax(maxit, 40) && !accepted; it++, lambda *= 0.5) {
    PetscCall(VecWAXPY(W, -lambda, Y, X));
    PetscCall(SNESComputeObjective(snes, W, &phi));
    if (PetscIsInfOrNanReal(phi)) continue;
    if (phi <= phi0 + 1e-4 * lambda * slope) accepted = PETSC_TRUE;
    else if (PetscAbsReal(phi - phi0) <= 1e-12 * PetscAbsReal(phi0)) {
      PetscCall(SNESComputeFunction(snes, W, G));
      PetscCall(VecNorm(G, NORM_2, &gnorm));
      have_g   = PETSC_TRUE;
      accepted = (PetscBool)(gnorm < fnorm);
    }
    if (accepted) break;
  }
  if (!accepted) {
    PetscCall(PetscInfo(snes, "energy line search: no decrease of Phi or |g| after %" PetscInt_FMT " halvings\n", it));
    PetscCall(SNESLineSearchSetReason(ls, SNES_LINESEARCH_FAILED_REDUCT));
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
  PetscCall(VecCopy(W, X));
  PetscCall(VecCopy(G, F));
  PetscCall(VecNorm(X, NORM_2, &xnorm));
  PetscCall(SNESLineSearchSetLambda(ls, lambda));
  PetscCall(SNESLineSearchSetNorms(ls, xnorm, gnorm, ynorm));
  PetscCall(SNESLineSearchSetReason(ls, SNES_LINESEARCH_SUCCEEDED));
  PetscFunctionReturn(PETSC_SUCCESS);
}
