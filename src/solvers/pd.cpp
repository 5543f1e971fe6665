/* SNES type "pd": projective dynamics as a nonlinear solver of g(x) = 0 (local projections, then
   one solve with the constant factor). It knows nothing of time stepping: it finds the problem's
   local/global steps composed on the SNES's DM, so it also runs as the nonlinear preconditioner of
   anderson, ngmres or qn (which share the DM). PD is block coordinate descent on Phi: Phi never
   increases. Options: -snes_max_it (10 is Liu et al.'s setting), -snes_atol/-snes_rtol on |g|,
   -snes_pd_fixed to run exactly max_it iterations without evaluating g. */
#include <msim/solvers.h>

PETSC_EXTERN PetscErrorCode SNESCreate_Shell(SNES); /* exported by PETSc, declared in no public header */

static PetscErrorCode SNESPDGetProblem(SNES snes, MSimPDProblem **pd)
{
  DM                 dm;
  PetscContainer     c;

  PetscFunctionBeginUser;
  PetscCall(SNESGetDM(snes, &dm));
  PetscCall(PetscObjectQuery((PetscObject)dm, "MSimPDProblem", (PetscObject *)&c));
  PetscCheck(c, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_WRONGSTATE, "-snes_type pd needs a problem that provides projective-dynamics steps (msim's implicit_euler)");
  PetscCall(PetscContainerGetPointer(c, (void **)pd));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESSolve_PD(SNES snes, Vec X)
{
  MSimPDProblem      *pd;
  Vec                 F, rhs;
  PetscReal           atol, rtol, stol, fnorm = 0, fnorm0 = 0;
  PetscInt            maxit, maxf, k;
  PetscBool           fixed = PETSC_FALSE;
  const char         *prefix;
  SNESConvergedReason reason = SNES_CONVERGED_ITERATING;

  PetscFunctionBeginUser;
  PetscCall(SNESPDGetProblem(snes, &pd));
  PetscCall(SNESGetOptionsPrefix(snes, &prefix));
  PetscCall(PetscOptionsGetBool(NULL, prefix, "-snes_pd_fixed", &fixed, NULL));
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &maxit, &maxf));
  PetscCall(SNESGetFunction(snes, &F, NULL, NULL));
  PetscCall(VecDuplicate(X, &rhs));
  PetscCall(SNESSetIterationNumber(snes, 0));
  if (!fixed) {
    PetscCall(SNESComputeFunction(snes, X, F));
    PetscCall(VecNorm(F, NORM_2, &fnorm));
    fnorm0 = fnorm;
    PetscCall(SNESMonitor(snes, 0, fnorm));
    if (fnorm <= atol) reason = SNES_CONVERGED_FNORM_ABS;
  } else PetscCall(SNESMonitor(snes, 0, 0.0));
  for (k = 1; k <= maxit && reason == SNES_CONVERGED_ITERATING; k++) {
    PetscCall((*pd->rhs)(pd->ctx, X, rhs));          /* local step */
    PetscCall((*pd->global_solve)(pd->ctx, rhs, X)); /* global step */
    PetscCall(SNESSetIterationNumber(snes, k));
    if (!fixed) {
      PetscCall(SNESComputeFunction(snes, X, F));
      PetscCall(VecNorm(F, NORM_2, &fnorm));
      PetscCheck(!PetscIsInfOrNanReal(fnorm), PetscObjectComm((PetscObject)snes), PETSC_ERR_FP, "pd: the residual is not finite");
      if (fnorm <= atol) reason = SNES_CONVERGED_FNORM_ABS;
      else if (fnorm <= rtol * fnorm0) reason = SNES_CONVERGED_FNORM_RELATIVE;
    }
    PetscCall(SNESMonitor(snes, k, fnorm));
  }
  if (reason == SNES_CONVERGED_ITERATING) reason = fixed ? SNES_CONVERGED_ITS : SNES_DIVERGED_MAX_IT;
  PetscCall(SNESSetConvergedReason(snes, reason));
  PetscCall(VecDestroy(&rhs));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESCreate_PD(SNES snes)
{
  PetscFunctionBeginUser;
  PetscCall(SNESCreate_Shell(snes));
  PetscCall(SNESShellSetSolve(snes, SNESSolve_PD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscBool MSimSolversRegistered = PETSC_FALSE;

PetscErrorCode MSimSolversRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (MSimSolversRegistered) PetscFunctionReturn(PETSC_SUCCESS);
  MSimSolversRegistered = PETSC_TRUE;
  PetscCall(SNESRegister(SNESPD, SNESCreate_PD));
  PetscCall(PCRegister(PCMSIMLLT, PCCreate_MSimLLT));
  PetscFunctionReturn(PETSC_SUCCESS);
}

