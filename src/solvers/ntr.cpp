/* SNES type "ntr": Newton's method with a trust region on the objective (SNESSetObjective), for
   g(x) = grad Phi(x) = 0 where the Hessian J may be indefinite. Each iteration minimizes the
   quadratic model q(p) = -g.p + 1/2 p.J p over ||p||_P <= delta by Steihaug-Toint truncated CG
   (KSPSTCG, or KSPNASH / KSPGLTR), whose preconditioner P must be SPD and sets the norm of the
   region; x - p is taken when Phi falls by at least eta of the model's prediction, and the radius
   follows how well the model predicted (Nocedal & Wright, Algorithms 4.1 and 7.2).
   Why not newtonls: on the implicit step of a crumpling cloth, compressed springs make Phi
   nonconvex; a line search along the Newton direction of an indefinite Hessian heads for saddle
   points and walks on at tiny steps (40 to 100 iterations per step on the benchmark cloth). The
   truncated CG follows directions of negative curvature to the region's edge instead, and stops
   early wherever the model is only trusted nearby, so the CG work adapts too.
   Inexact Newton: CG stops at the relative residual min(forcing_max, sqrt(|g|/|g_0|)), which
   gives superlinear convergence near a minimum and cheap steps far from it. PETSc 3.18's own
   newtontr measures progress by |g| rather than by an objective and cannot tell a saddle from a
   minimum. Options: -snes_ntr_eta, -snes_ntr_forcing_max, -snes_ntr_delta0.
   Feasible set: a contact barrier (obstacles, self-contact, the volume term) is +inf outside its
   set, and the region knows nothing of it. Each trial step p is cut to the terms' max_step
   through the SNES line search's pre-check, which msim sets wherever a term has one (as msim's
   energy line search asks max_step itself), and judged by the model's decrease along the cut
   step. Without it an infeasible trial point (Phi = inf) was rejected and quartered the radius
   (14 times in 9 steps of a 41 x 41 cloth dropped on a ball), and feasible steps went up to the
   barrier (4.7e-8 m from the ball): tests/contact_ntr.py's 21 x 21 drop stopped 8 of its 150 steps
   at the 50-iteration cap, 1 with the cut (under |dx| < 1e-3 and 20 iterations, 90 steps: 15
   against 2).
   The region is measured in P's norm: with the contact-free PD factor as P (the default) it does
   not see the barrier's stiffness, the cut steps stay at 0.2-5% of CG's, and the drape still
   fails; -msim_contact_pc_pd_weight puts the barrier in P (runs/contact/README.md, "The trust
   region on the true Hessian"). */
#include <petsc/private/snesimpl.h>
#include <msim/solvers.h>
#include <msim/options.h>

typedef struct {
  PetscReal eta;         /* accept a step when actual / predicted decrease of Phi > eta */
  PetscReal forcing_max; /* largest relative CG tolerance */
  PetscReal delta0;      /* first radius as a multiple of |P^-1 g|_P (a full preconditioned
                            gradient step); later solves start from the last solve's radius,
                            which checkpoints carry (SNESGetHistory_NTR) */
  PetscReal delta;       /* current radius, carried from one solve to the next */
  PetscInt  rejected;    /* steps rejected over the life of the SNES */
  PetscInt  negative;    /* CG solves stopped by a direction of negative curvature */
} SNES_NTR;

static PetscErrorCode SNESSetUp_NTR(SNES snes)
{
  KSP       ksp;
  PetscBool tr;

  PetscFunctionBeginUser;
  PetscCall(SNESSetWorkVecs(snes, 3));
  PetscCall(SNESSetUpMatrices(snes));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)ksp, &tr, KSPSTCG, KSPNASH, KSPGLTR, ""));
  PetscCheck(tr, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_INCOMP, "-snes_type ntr needs a trust-region Krylov method: -ksp_type stcg, nash or gltr (got %s)", ((PetscObject)ksp)->type_name);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESSolve_NTR(SNES snes)
{
  SNES_NTR          *tr = (SNES_NTR *)snes->data;
  Vec                X = snes->vec_sol, F = snes->vec_func, Y = snes->work[0], W = snes->work[1], G = snes->work[2];
  KSP                ksp;
  KSPConvergedReason kreason;
  SNESLineSearch     ls;
  PetscReal          fnorm, fnorm0, gnorm, xnorm, ynorm = 0, phi, phi_w, q, dnorm, pred, ared, rho, rtol, abstol, dtol, pnorm, alpha, gp, pJp;
  PetscScalar        dot;
  PetscInt           lits, maxit;
  PetscBool          accepted, have_g = PETSC_FALSE, cut = PETSC_FALSE, roundoff;

  PetscFunctionBeginUser;
  PetscCheck(!snes->vec_rhs, PetscObjectComm((PetscObject)snes), PETSC_ERR_SUP, "-snes_type ntr solves grad Phi(x) = 0: no right-hand side");
  snes->reason = SNES_CONVERGED_ITERATING;
  PetscCall(SNESSetIterationNumber(snes, 0));
  snes->norm = 0;
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(SNESGetLineSearch(snes, &ls));
  PetscCall(KSPGetTolerances(ksp, NULL, &abstol, &dtol, &maxit));
  PetscCall(SNESComputeFunction(snes, X, F));
  PetscCall(VecNorm(F, NORM_2, &fnorm));
  SNESCheckFunctionNorm(snes, fnorm);
  PetscCall(SNESComputeObjective(snes, X, &phi));
  PetscCall(VecNorm(X, NORM_2, &xnorm));
  fnorm0     = fnorm;
  snes->norm = fnorm;
  PetscCall(SNESLogConvergenceHistory(snes, fnorm, 0));
  PetscCall(SNESMonitor(snes, 0, fnorm));
  PetscUseTypeMethod(snes, converged, 0, xnorm, 0.0, fnorm, &snes->reason, snes->cnvP);
  while (!snes->reason) {
    PetscCall(SNESComputeJacobian(snes, X, snes->jacobian, snes->jacobian_pre));
    SNESCheckJacobianDomainerror(snes);
    PetscCall(KSPSetOperators(ksp, snes->jacobian, snes->jacobian_pre));
    rtol = PetscMin(tr->forcing_max, PetscSqrtReal(fnorm / fnorm0));
    PetscCall(KSPSetTolerances(ksp, rtol, abstol, dtol, maxit));
    if (tr->delta <= 0) {
      /* first solve: the P-norm of the preconditioned gradient step, |P^-1 g|_P = sqrt(g.P^-1 g) */
      PC        pc;
      PetscReal gz;
      PetscCall(KSPSetUp(ksp));
      PetscCall(KSPGetPC(ksp, &pc));
      PetscCall(PCApply(pc, F, Y));
      PetscCall(VecDot(F, Y, &gz));
      PetscCheck(gz > 0, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_INCOMP, "-snes_type ntr: the preconditioner is not positive definite (g.P^-1 g = %g)", (double)gz);
      tr->delta = tr->delta0 * PetscSqrtReal(gz);
    }
    accepted = PETSC_FALSE;
    while (!accepted && !snes->reason) {
      PetscCall(KSPCGSetRadius(ksp, tr->delta));
      PetscCall(KSPSolve(ksp, F, Y));
      PetscCall(KSPGetConvergedReason(ksp, &kreason));
      PetscCall(KSPGetIterationNumber(ksp, &lits));
      snes->linear_its += lits;
      if (kreason == KSP_CONVERGED_CG_NEG_CURVE) tr->negative++;
      PetscCheck(kreason != KSP_DIVERGED_INDEFINITE_PC && kreason != KSP_DIVERGED_NANORINF, PetscObjectComm((PetscObject)snes), PETSC_ERR_NOT_CONVERGED, "-snes_type ntr: the trust-region CG failed (%s)", KSPConvergedReasons[kreason]);
      PetscCall(KSPCGGetObjFcn(ksp, &q));
      PetscCall(KSPCGGetNormD(ksp, &dnorm));
      pred = -q; /* q = -g.p + 1/2 p.J p: the model's change of Phi along x - p */
      /* the feasible set: p cut to alpha p by the terms' max_step (the pre-check scales Y), and
         the model's decrease along the cut step, alpha g.p - alpha^2/2 p.J p */
      PetscCall(VecNorm(Y, NORM_2, &pnorm));
      PetscCall(VecDot(F, Y, &dot));
      gp  = PetscRealPart(dot);
      pJp = 2 * (q + gp);
      PetscCall(SNESLineSearchPreCheck(ls, X, Y, &cut));
      alpha = 1;
      if (cut) {
        PetscCall(VecNorm(Y, NORM_2, &ynorm));
        alpha = pnorm > 0 ? ynorm / pnorm : 1;
        pred  = alpha * gp - 0.5 * alpha * alpha * pJp;
        PetscCall(PetscInfo(snes, "ntr: trial step cut to %g of CG's by max_step\n", (double)alpha));
      }
      PetscCall(VecWAXPY(W, -1.0, Y, X));
      PetscCall(SNESComputeObjective(snes, W, &phi_w));
      ared   = phi - phi_w;
      have_g = PETSC_FALSE;
      if (PetscIsInfOrNanReal(phi_w)) PetscCall(PetscInfo(snes, "ntr: trial point outside the feasible set (Phi = %g)\n", (double)phi_w)); /* tests/contact_ntr.py counts these */
      if (PetscIsInfOrNanReal(phi_w) || !(pred > 0)) rho = -1;
      else if (PetscAbsReal(ared) <= MSIM_PHI_ROUNDOFF * PetscAbsReal(phi) && pred <= MSIM_PHI_ROUNDOFF * PetscAbsReal(phi)) {
        /* a decrease Phi cannot resolve: judged by |g|, as the energy line search does */
        PetscCall(SNESComputeFunction(snes, W, G));
        PetscCall(VecNorm(G, NORM_2, &gnorm));
        have_g = PETSC_TRUE;
        rho    = gnorm < fnorm ? 1 : -1;
      } else rho = ared / pred;
      /* a step inside the region below -snes_stol |x| is roundoff (a free fall solved exactly by
         the first iteration), where rho is noise (-4e-4 or 0.01 at |p|_P 3e-15): it must not set
         the radius, which the next time step starts from (shrunk to 1e-15, it made every later
         step stop after one roundoff iteration) */
      roundoff = (PetscBool)(!cut && (kreason == KSP_CONVERGED_RTOL || kreason == KSP_CONVERGED_ATOL) && pnorm < snes->stol * xnorm);
      if (roundoff) PetscCall(PetscInfo(snes, "ntr: roundoff step (|p| %g < stol |x|), radius kept\n", (double)pnorm));
      else if (rho < 0.25) tr->delta = 0.25 * PetscMin(tr->delta, alpha * dnorm);
      else if (rho > 0.75 && !cut && dnorm >= 0.99 * tr->delta) tr->delta *= 2;
      if (rho > tr->eta) accepted = PETSC_TRUE;
      else if (roundoff) {
        /* rejected for noise (it shrank the region to nothing, DIVERGED_TR_DELTA, at the
           benchmark cloth's first step; kept, the radius would repeat the same solve): converged,
           as newtonls takes a failed search on such a step */
        PetscCall(PetscInfo(snes, "ntr: roundoff step rejected (rho %g): converged\n", (double)rho));
        snes->reason = SNES_CONVERGED_SNORM_RELATIVE;
      } else {
        tr->rejected++;
        snes->numFailures++;
        PetscCall(PetscInfo(snes, "ntr: step rejected (rho %g, |p|_P %g), radius now %g\n", (double)rho, (double)dnorm, (double)tr->delta));
        if (tr->delta <= PETSC_MACHINE_EPSILON * PetscMax(xnorm, 1)) snes->reason = SNES_DIVERGED_TR_DELTA;
      }
    }
    if (!accepted) break;
    PetscCall(VecCopy(W, X));
    phi = phi_w;
    if (have_g) PetscCall(VecCopy(G, F));
    else PetscCall(SNESComputeFunction(snes, X, F));
    PetscCall(VecNorm(F, NORM_2, &fnorm));
    SNESCheckFunctionNorm(snes, fnorm);
    PetscCall(VecNorm(X, NORM_2, &xnorm));
    /* a step the region or max_step cut short gives no length to step rules (-msim_step_atol's,
       -snes_stol): with a contact barrier such steps are short because a vertex nears an obstacle,
       not because Newton converged (taken for converged, the 41 x 41 drape diverged at step 8) */
    if (cut || kreason == KSP_CONVERGED_CG_CONSTRAINED || kreason == KSP_CONVERGED_CG_NEG_CURVE) ynorm = PETSC_INFINITY;
    else ynorm = pnorm;
    PetscCall(PetscInfo(snes, "ntr: rho %g, |p|_P %g, CG %" PetscInt_FMT " its (%s), radius %g\n", (double)rho, (double)dnorm, lits, KSPConvergedReasons[kreason], (double)tr->delta));
    snes->iter++;
    snes->norm = fnorm;
    PetscCall(SNESLogConvergenceHistory(snes, fnorm, lits));
    PetscCall(SNESMonitor(snes, snes->iter, fnorm));
    PetscUseTypeMethod(snes, converged, snes->iter, xnorm, ynorm, fnorm, &snes->reason, snes->cnvP);
    if (!snes->reason && snes->iter >= snes->max_its) snes->reason = SNES_DIVERGED_MAX_IT;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESSetFromOptions_NTR(SNES snes, PetscOptionItems *PetscOptionsObject)
{
  SNES_NTR *tr = (SNES_NTR *)snes->data;

  PetscFunctionBeginUser;
  PetscOptionsHeadBegin(PetscOptionsObject, "SNES ntr (Newton trust region on the objective)");
  PetscCall(MSimOptionsReal("-snes_ntr_eta", "Accept a step when Phi falls by more than this fraction of the model's prediction", NULL, tr->eta, &tr->eta, NULL));
  PetscCall(MSimOptionsReal("-snes_ntr_forcing_max", "Largest relative CG tolerance (inexact Newton: min(this, sqrt(|g|/|g0|)))", NULL, tr->forcing_max, &tr->forcing_max, NULL));
  PetscCall(MSimOptionsReal("-snes_ntr_delta0", "First trust-region radius as a multiple of the preconditioned gradient step's P-norm", NULL, tr->delta0, &tr->delta0, NULL));
  PetscOptionsHeadEnd();
  PetscCheck(tr->eta >= 0 && tr->eta < 0.25, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_OUTOFRANGE, "-snes_ntr_eta must be in [0, 0.25) (got %g)", (double)tr->eta);
  PetscCheck(tr->forcing_max > 0 && tr->forcing_max < 1, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_OUTOFRANGE, "-snes_ntr_forcing_max must be in (0, 1) (got %g)", (double)tr->forcing_max);
  PetscCheck(tr->delta0 > 0, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_OUTOFRANGE, "-snes_ntr_delta0 must be > 0 (got %g)", (double)tr->delta0);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESView_NTR(SNES snes, PetscViewer viewer)
{
  SNES_NTR *tr = (SNES_NTR *)snes->data;
  PetscBool ascii;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (ascii) PetscCall(PetscViewerASCIIPrintf(viewer, "  trust region on the objective: eta %g, forcing_max %g, radius now %g; steps rejected %" PetscInt_FMT ", CG solves ended by negative curvature %" PetscInt_FMT "\n", (double)tr->eta, (double)tr->forcing_max, (double)tr->delta, tr->rejected, tr->negative));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* For checkpoints (MSimSolverHistory "ntr"): the radius the next solve starts from, and the
   counters over the SNES's life */
static PetscErrorCode SNESGetHistory_NTR(SNES snes, MSimSolverHistory *h)
{
  SNES_NTR *tr = (SNES_NTR *)snes->data;

  PetscFunctionBeginUser;
  h->name = "ntr";
  h->real = {tr->delta, (PetscReal)tr->rejected, (PetscReal)tr->negative};
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESSetHistory_NTR(SNES snes, const MSimSolverHistory *h, PetscBool *taken)
{
  SNES_NTR *tr = (SNES_NTR *)snes->data;

  PetscFunctionBeginUser;
  *taken = (PetscBool)(h->name == "ntr" && h->real.size() == 3 && h->vec.empty());
  if (!*taken) PetscFunctionReturn(PETSC_SUCCESS);
  tr->delta    = h->real[0];
  tr->rejected = (PetscInt)h->real[1];
  tr->negative = (PetscInt)h->real[2];
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESDestroy_NTR(SNES snes)
{
  PetscFunctionBeginUser;
  PetscCall(PetscObjectComposeFunction((PetscObject)snes, "MSimSNESGetHistory_C", NULL));
  PetscCall(PetscObjectComposeFunction((PetscObject)snes, "MSimSNESSetHistory_C", NULL));
  PetscCall(PetscFree(snes->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SNESCreate_NTR(SNES snes)
{
  SNES_NTR *tr;
  KSP       ksp;

  PetscFunctionBeginUser;
  snes->ops->setup          = SNESSetUp_NTR;
  snes->ops->solve          = SNESSolve_NTR;
  snes->ops->setfromoptions = SNESSetFromOptions_NTR;
  snes->ops->view           = SNESView_NTR;
  snes->ops->destroy        = SNESDestroy_NTR;
  snes->usesksp                     = PETSC_TRUE;
  snes->usesnpc                     = PETSC_FALSE;
  snes->alwayscomputesfinalresidual = PETSC_TRUE;
  PetscCall(PetscNew(&tr));
  tr->eta         = 1e-4;
  tr->forcing_max = 0.5;
  tr->delta0      = 1;
  snes->data      = tr;
  PetscCall(PetscObjectComposeFunction((PetscObject)snes, "MSimSNESGetHistory_C", SNESGetHistory_NTR));
  PetscCall(PetscObjectComposeFunction((PetscObject)snes, "MSimSNESSetHistory_C", SNESSetHistory_NTR));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPSetType(ksp, KSPSTCG));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SNESNTRGetCounts(SNES snes, PetscInt *rejected, PetscInt *negative)
{
  PetscBool is;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESNTR, &is));
  if (rejected) *rejected = is ? ((SNES_NTR *)snes->data)->rejected : 0;
  if (negative) *negative = is ? ((SNES_NTR *)snes->data)->negative : 0;
  PetscFunctionReturn(PETSC_SUCCESS);
}
