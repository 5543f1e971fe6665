/* SNES type "pd": projective dynamics as a nonlinear solver of g(x) = 0 (local projections, then
   one solve with the constant factor). It knows nothing of time stepping: it finds the problem's
   local/global steps composed on the SNES's DM, so it also runs as the nonlinear preconditioner of
   anderson, ngmres or qn (which share the DM). PD is block coordinate descent on Phi: Phi never
   increases. Options: -snes_max_it (10 is Liu et al.'s setting), -snes_atol/-snes_rtol on |g|,
   -snes_pd_fixed to run exactly max_it iterations without evaluating g, -snes_pd_anderson m for
   Anderson acceleration with an energy safeguard (Peng et al. 2018) and the feasible sets' check
   (max_step) on its mixed iterate: PETSc's own -snes_type anderson -npc_snes_type pd composes
   too, but has neither, so its Phi can rise and its iterates can leave a feasible set.
   -snes_pd_lbfgs m: L-BFGS with the PD matrix as its initial Hessian (Liu et al. 2017), fused with
   PD's steps so that an iteration costs a PD iteration and a product with A (pd_lbfgs.cpp). */
#include <msim/solvers.h>
#include "anderson.h"
#include "pd_lbfgs.h"
#include <msim/log.h>
#include <msim/petsc_compat.h>
#include <msim/options.h>
#include <msim/registry.h>

PETSC_EXTERN PetscErrorCode SNESCreate_Shell(SNES); /* exported by PETSc, declared in no public header */

/* The pd type's options, read in the SNES's own options block: SNESSetFromOptions runs the handlers
   added to the object (PetscObjectAddOptionsHandler) inside its block, with its prefix, so pd as
   the NPC reads -npc_snes_pd_* and -help lists them once, under the SNES that is pd. */
typedef struct {
  PetscBool fixed;    /* -snes_pd_fixed */
  PetscInt  anderson; /* -snes_pd_anderson */
  PetscInt  lbfgs;    /* -snes_pd_lbfgs */
  PetscReal gamma_max; /* -snes_pd_lbfgs_scale_max */
  PetscBool lbfgs_fused, lbfgs_check; /* -snes_pd_lbfgs_fused, -snes_pd_lbfgs_check */
} SNESPDOptions;

static PetscErrorCode SNESPDSetFromOptions(PetscObject obj, PetscOptionItems *PetscOptionsObject, void *ctx)
{
  SNESPDOptions *o = (SNESPDOptions *)ctx;
  PetscBool      pd, scale_set, fused_set, check_set;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare(obj, SNESPD, &pd));
  if (!pd) PetscFunctionReturn(PETSC_SUCCESS); /* the SNES was pd once and has another type now */
  PetscCall(PetscOptionsBool("-snes_pd_fixed", "SNES pd: run exactly -snes_max_it iterations, no residual evaluations", NULL, o->fixed, &o->fixed, NULL));
  PetscCall(MSimOptionsInt("-snes_pd_anderson", "SNES pd: Anderson acceleration with m previous iterates and an energy safeguard (0: plain PD)", NULL, o->anderson, &o->anderson, NULL));
  PetscCheck(o->anderson >= 0, PetscObjectComm(obj), PETSC_ERR_ARG_OUTOFRANGE, "-snes_pd_anderson must be >= 0 (got %" PetscInt_FMT ")", o->anderson);
  PetscCall(MSimOptionsInt("-snes_pd_lbfgs", "SNES pd: L-BFGS with m pairs and the PD matrix as initial Hessian, Armijo-safeguarded on Phi (0: plain PD)", NULL, o->lbfgs, &o->lbfgs, NULL));
  PetscCall(PetscOptionsReal("-snes_pd_lbfgs_scale_max", "SNES pd: L-BFGS scales its initial Hessian A^-1 by s^T A s / s^T y of the newest pair, kept in [1, this] (1: unscaled)", NULL, o->gamma_max, &o->gamma_max, &scale_set));
  PetscCheck(o->gamma_max >= 1, PetscObjectComm(obj), PETSC_ERR_ARG_OUTOFRANGE, "-snes_pd_lbfgs_scale_max must be >= 1 (got %g)", (double)o->gamma_max);
  PetscCall(PetscOptionsBool("-snes_pd_lbfgs_fused", "SNES pd: L-BFGS takes Phi's gradient from the local step's passes where every term can (0: A x - rhs(x), one product with A per iteration)", NULL, o->lbfgs_fused, &o->lbfgs_fused, &fused_set));
  PetscCall(PetscOptionsBool("-snes_pd_lbfgs_check", "SNES pd: L-BFGS compares its fused gradient and s^T A s with the products A x - rhs(x) and A s, printed with -info (costs products; for tests)", NULL, o->lbfgs_check, &o->lbfgs_check, &check_set));
  PetscCheck(o->lbfgs >= 0, PetscObjectComm(obj), PETSC_ERR_ARG_OUTOFRANGE, "-snes_pd_lbfgs must be >= 0 (got %" PetscInt_FMT ")", o->lbfgs);
  /* L-BFGS's own options are read by it alone: plain PD or Anderson went on without them */
  PetscCheck(o->lbfgs > 0 || !(scale_set || fused_set || check_set), PetscObjectComm(obj), PETSC_ERR_SUP, "-%ssnes_pd_lbfgs_%s without -%ssnes_pd_lbfgs m > 0 is not supported: only pd's L-BFGS reads it", PetscOptionsObject->prefix ? PetscOptionsObject->prefix : "", scale_set ? "scale_max" : fused_set ? "fused" : "check", PetscOptionsObject->prefix ? PetscOptionsObject->prefix : "");
  PetscCheck(!(o->lbfgs > 0 && o->anderson > 0), PetscObjectComm(obj), PETSC_ERR_ARG_INCOMP, "-snes_pd_lbfgs and -snes_pd_anderson cannot be used together: choose one");
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The options composed on the SNES (made with it, freed with it) */
static PetscErrorCode SNESPDGetOptions(SNES snes, SNESPDOptions **o)
{
  PetscContainer c;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectQuery((PetscObject)snes, "SNESPDOptions", (PetscObject *)&c));
  if (!c) {
    PetscCall(PetscNew(o));
    (*o)->lbfgs_fused = PETSC_TRUE;
    (*o)->gamma_max = 3; /* runs/speed_accuracy/README.md: on the benchmark cloth (newmark, 5 pairs, 10 iterations) 2.3 cm from RK4 at 0.2 s, unscaled 3.6 cm, at 2, 5, 100: 2.5, 2.7, 3.1 cm */
    PetscCall(PetscContainerCreate(PetscObjectComm((PetscObject)snes), &c));
    PetscCall(PetscContainerSetPointer(c, *o));
    PetscCall(PetscContainerSetUserDestroy(c, PetscContainerUserDestroyDefault));
    PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDOptions", (PetscObject)c));
    PetscCall(PetscContainerDestroy(&c));
    PetscCall(PetscObjectAddOptionsHandler((PetscObject)snes, SNESPDSetFromOptions, NULL, *o));
  } else PetscCall(PetscContainerGetPointer(c, (void **)o));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESPDLBFGSDestroyContainer(void *ctx)
{
  MSimPDLBFGS *st = (MSimPDLBFGS *)ctx;
  PetscFunctionBeginUser;
  PetscCall(MSimPDLBFGSDestroy(st));
  delete st;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESPDRestartDestroy(void *ctx)
{
  MSimSolverHistory *h = (MSimSolverHistory *)ctx;
  PetscFunctionBeginUser;
  for (Vec &v : h->vec) PetscCall(VecDestroy(&v));
  delete h;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* L-BFGS's state lives with the SNES (made on its first solve, freed with it): its pairs carry
   over to the next time step's solve, where the Hessian they sample has changed little (the
   inertia term's y_n cancels in y = g_{k+1} - g_k). A restart's state (SNESSetHistory_PD) waits
   on the SNES until the state is made here: where pd is another SNES's NPC, its problem (on the
   DM, which the NPC gets at set-up) is not known when the checkpoint is read. */
static PetscErrorCode SNESPDGetLBFGS(SNES snes, MSimPDProblem *pd, Vec X, PetscInt m, PetscReal gamma_max, MSimPDLBFGS **st)
{
  PetscContainer c;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectQuery((PetscObject)snes, "SNESPDLBFGS", (PetscObject *)&c));
  if (c) {
    PetscCall(PetscContainerGetPointer(c, (void **)st));
    PetscInt n, nst;
    PetscCall(VecGetLocalSize(X, &n));
    PetscCall(VecGetLocalSize((*st)->G, &nst));
    if ((*st)->lb.m == m && (*st)->pd == pd && n == nst) {
      (*st)->gamma_max = gamma_max;
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDLBFGS", NULL)); /* another m: a new state */
  }
  *st = new MSimPDLBFGS();
  PetscCall(MSimPDLBFGSCreate(pd, X, m, gamma_max, *st));
  PetscCall(PetscContainerCreate(PetscObjectComm((PetscObject)snes), &c));
  PetscCall(PetscContainerSetPointer(c, *st));
  PetscCall(PetscContainerSetUserDestroy(c, SNESPDLBFGSDestroyContainer));
  PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDLBFGS", (PetscObject)c));
  PetscCall(PetscContainerDestroy(&c));
  PetscCall(PetscObjectQuery((PetscObject)snes, "SNESPDLBFGSRestart", (PetscObject *)&c));
  if (c) {
    MSimSolverHistory *h;
    PetscBool          taken;
    PetscCall(PetscContainerGetPointer(c, (void **)&h));
    PetscCall(MSimPDLBFGSSetHistory(*st, h, &taken));
    if (!taken) PetscCall(PetscInfo(snes, "pd: the checkpoint's L-BFGS state does not fit: the history starts afresh\n"));
    PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDLBFGSRestart", NULL));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESPDGetProblem(SNES snes, MSimPDProblem **pd)
{
  DM                 dm;
  PetscContainer     c;

  PetscFunctionBeginUser;
  PetscCall(SNESGetDM(snes, &dm));
  PetscCall(PetscObjectQuery((PetscObject)dm, "MSimPDProblem", (PetscObject *)&c));
  PetscCheck(c, PetscObjectComm((PetscObject)snes), PETSC_ERR_ARG_WRONGSTATE, "-snes_type pd needs a problem that provides projective-dynamics steps (msim's implicit schemes: implicit_euler, bdf2, implicit_midpoint, newmark; not -msim_integrator ts)");
  PetscCall(PetscContainerGetPointer(c, (void **)pd));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSNESSetUpPD(SNES snes)
{
  PetscBool      pd, has_npc;
  MSimPDProblem *problem;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESPD, &pd));
  PetscCall(SNESHasNPC(snes, &has_npc));
  if (!pd && has_npc) {
    SNES npc;
    PetscCall(SNESGetNPC(snes, &npc));
    PetscCall(PetscObjectTypeCompare((PetscObject)npc, SNESPD, &pd));
  }
  if (!pd) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESPDGetProblem(snes, &problem));
  if (problem->setup) PetscCall((*problem->setup)(problem->ctx));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* a monitor that stops the solve sets a failed reason (msim's stop signal inside a step,
   msim/signals.h): pd then stops as PETSc's types stop for their convergence test */
static PetscErrorCode MonitorStop(SNES snes, SNESConvergedReason *reason)
{
  SNESConvergedReason set;

  PetscFunctionBeginUser;
  PetscCall(SNESGetConvergedReason(snes, &set));
  if (set < 0) *reason = set;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESSolve_PD(SNES snes, Vec X)
{
  MSimPDProblem      *pd;
  Vec                 F, rhs, G = NULL, Y = NULL, D = NULL;
  PetscReal           atol, rtol, stol, fnorm = 0, fnorm0 = 0, phi = 0, phi_new;
  PetscInt            maxit, maxf, k, m, lm, fallbacks = 0, cut = 0;
  PetscBool           fixed, accelerated;
  SNESPDOptions      *opts;
  SNESConvergedReason reason = SNES_CONVERGED_ITERATING;
  MSimAnderson        aa;
  MSimPDLBFGS        *lbp = NULL;
  static PetscLogEvent lbfgs_event = 0;

  PetscFunctionBeginUser;
  PetscCall(SNESPDGetProblem(snes, &pd));
  PetscCall(SNESPDGetOptions(snes, &opts));
  fixed = opts->fixed;
  m     = opts->anderson;
  lm    = opts->lbfgs;
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &maxit, &maxf));
  PetscCall(SNESGetFunction(snes, &F, NULL, NULL));
  /* the right-hand side's Vec made once, freed with the SNES (one VecDuplicate a solve, which
     zeroes its array, was 0.25 M instructions of a PD-10 step of the 101 x 101 drape) */
  PetscCall(PetscObjectQuery((PetscObject)snes, "SNESPDRHS", (PetscObject *)&rhs));
  if (rhs) { /* X's layout (its ranges, the same on every rank, so every rank decides alike) */
    PetscLayout lx, lr;
    PetscBool   same;
    PetscCall(VecGetLayout(X, &lx));
    PetscCall(VecGetLayout(rhs, &lr));
    PetscCall(PetscLayoutCompare(lx, lr, &same));
    if (!same) rhs = NULL;
  }
  if (!rhs) {
    PetscCall(VecDuplicate(X, &rhs));
    PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDRHS", (PetscObject)rhs));
    PetscCall(PetscObjectDereference((PetscObject)rhs));
  }
  if (m > 0) {
    PetscCall(VecDuplicate(X, &G));
    PetscCall(VecDuplicate(X, &Y));
    PetscCall(VecDuplicate(X, &D));
    PetscCall(MSimAndersonCreate(X, m, &aa));
  }
  if (lm > 0) {
    if (!lbfgs_event) PetscCall(PetscLogEventRegister("MSimPDLBFGS", MSIM_CLASSID, &lbfgs_event));
    PetscCall(SNESPDGetLBFGS(snes, pd, X, lm, opts->gamma_max, &lbp));
    lbp->use_fused = opts->lbfgs_fused;
    lbp->check     = opts->lbfgs_check;
  }
  PetscCall(SNESSetIterationNumber(snes, 0));
  PetscCall(SNESSetConvergedReason(snes, SNES_CONVERGED_ITERATING)); /* a monitor may set a stop (below) */
  /* plain PD with -snes_pd_fixed: every global step is followed by a local step at X or by the
     end of the loop, and nothing reads X between (no residual; a monitor of the solution would
     see the step before its check), so the global step's Phi check
     (feasible sets) may wait for the next local step, which sums Phi(X) anyway; pd->finish
     completes it at the last iterate. Anderson, L-BFGS and the residual's path check at once. */
  pd->defer_check = (PetscBool)(fixed && !m && !lm && pd->finish);
  /* A fixed count evaluates no residual: the SNES's function Vec keeps what it held before the
     solve (the outer solver's F at its own iterate, where pd is a nonlinear preconditioner). No
     norm schedule says so, and PETSc's solvers that run pd as their right preconditioner
     (anderson, ngmres, newtonls) then evaluate the residual at pd's result (SNESGetNPCFunction)
     instead of reading the stale Vec as it. pd has no other use for the schedule, so this takes
     the place of any -snes_norm_schedule given for it. */
  PetscCall(SNESSetNormSchedule(snes, fixed ? SNES_NORM_NONE : SNES_NORM_ALWAYS));
  if (!fixed) {
    PetscCall(SNESComputeFunction(snes, X, F));
    PetscCall(VecNorm(F, NORM_2, &fnorm));
    fnorm0 = fnorm;
    if (fnorm <= atol) reason = SNES_CONVERGED_FNORM_ABS;
  }
  PetscCall(SNESMonitor(snes, 0, fnorm));
  PetscCall(MonitorStop(snes, &reason));
  /* with Anderson, rhs always holds the local step at the current X and phi its Phi */
  if (m > 0 && reason == SNES_CONVERGED_ITERATING) PetscCall((*pd->rhs)(pd->ctx, X, rhs, &phi));
  if (lm > 0 && reason == SNES_CONVERGED_ITERATING) {
    PetscCall(MSimPDLBFGSBegin(lbp, X));
    PetscCall(PetscInfo(snes, "pd: L-BFGS iteration 0 Phi %.17g\n", (double)lbp->phi));
  }
  for (k = 1; k <= maxit && reason == SNES_CONVERGED_ITERATING; k++) {
    if (lm > 0) {
      /* the event holds the whole iteration (its sweep, local step and product are logged
         inside it too): against MSimPDLocal + MSimPDGlobal it is L-BFGS's cost over PD's */
      PetscCall(PetscLogEventBegin(lbfgs_event, X, 0, 0, 0));
      PetscCall(MSimPDLBFGSIterate(lbp, X));
      PetscCall(PetscLogEventEnd(lbfgs_event, X, 0, 0, 0));
      PetscCall(PetscInfo(snes, "pd: L-BFGS iteration %" PetscInt_FMT " Phi %.17g\n", k, (double)lbp->phi));
    } else if (!m) {
      PetscCall((*pd->rhs)(pd->ctx, X, rhs, NULL));      /* local step */
      PetscCall((*pd->global_solve)(pd->ctx, rhs, X, X)); /* global step */
    } else {
      /* Anderson on the PD map, with Peng et al.'s energy safeguard: keep the mixed iterate Y only
         if the straight way to it from X stays inside every term's feasible set (max_step: the
         contact barriers' CCD, the inversion barrier) and it lowers Phi below X's; otherwise take
         the plain PD step G (whose global step keeps the feasible set and never raises Phi) and
         restart the history. Phi alone cannot tell: Y mixes earlier iterates, so it can lie past
         a barrier, where the barrier is zero again and Phi lower: the 13 x 13 fold (BDF2) passed
         an edge through a triangle at step 42, handles pushing a sheet passed through it
         (tests/self_contact.py, tests/self_contact_mesh.py). Like L-BFGS's step (pd_lbfgs.cpp),
         Y is not shortened: the plain step holds near vertices by the barrier's weights */
      PetscCall((*pd->global_solve)(pd->ctx, rhs, X, G));
      PetscCall(MSimAndersonMix(&aa, X, G, Y, &accelerated));
      PetscReal t = 1;
      if (accelerated && pd->max_step) {
        PetscCall(VecWAXPY(D, -1.0, Y, X)); /* Y = X - D */
        PetscCall((*pd->max_step)(pd->ctx, X, D, &t));
        if (t < 1) cut++;
      }
      if (t < 1) phi_new = phi; /* not evaluated: the fallback below */
      else {
        PetscCall(VecCopy(Y, X));
        PetscCall((*pd->rhs)(pd->ctx, X, rhs, &phi_new));
      }
      if (accelerated && !(phi_new < phi)) {
        fallbacks++;
        PetscCall(VecCopy(G, X));
        PetscCall(MSimAndersonReset(&aa));
        PetscCall((*pd->rhs)(pd->ctx, X, rhs, &phi_new));
      }
      phi = phi_new;
    }
    PetscCall(SNESSetIterationNumber(snes, k));
    if (!fixed) {
      /* L-BFGS has g = A x - rhs(x) at X already: it is the SNES function (the same sum, so
         the same |g| to roundoff) */
      if (lm > 0) PetscCall(VecCopy(lbp->G, F));
      else PetscCall(SNESComputeFunction(snes, X, F));
      PetscCall(VecNorm(F, NORM_2, &fnorm));
      PetscCheck(!PetscIsInfOrNanReal(fnorm), PetscObjectComm((PetscObject)snes), PETSC_ERR_FP, "pd: the residual is not finite");
      if (fnorm <= atol) reason = SNES_CONVERGED_FNORM_ABS;
      else if (fnorm <= rtol * fnorm0) reason = SNES_CONVERGED_FNORM_RELATIVE;
    }
    PetscCall(SNESMonitor(snes, k, fnorm));
    PetscCall(MonitorStop(snes, &reason));
  }
  if (pd->defer_check) {
    PetscCall((*pd->finish)(pd->ctx)); /* the SNES never returns an unchecked iterate */
    pd->defer_check = PETSC_FALSE;
  }
  if (reason == SNES_CONVERGED_ITERATING) reason = fixed ? SNES_CONVERGED_ITS : SNES_DIVERGED_MAX_IT;
  PetscCall(SNESSetConvergedReason(snes, reason));
  if (m > 0) {
    PetscCall(PetscInfo(snes, "pd: Anderson(%" PetscInt_FMT "): fell back to the plain PD step %" PetscInt_FMT " times, %" PetscInt_FMT " of them for mixed iterates leaving a feasible set\n", m, fallbacks, cut));
    PetscCall(MSimAndersonDestroy(&aa));
    PetscCall(VecDestroy(&G));
    PetscCall(VecDestroy(&Y));
    PetscCall(VecDestroy(&D));
  }
  if (lm > 0) {
    PetscCall(PetscInfo(snes, "pd: L-BFGS(%" PetscInt_FMT ") so far: fell back to the plain PD step %" PetscInt_FMT " times, %" PetscInt_FMT " of them for steps leaving a feasible set, %" PetscInt_FMT " by a backtrack, %" PetscInt_FMT " pairs of negative curvature skipped\n", lm, lbp->fallbacks, lbp->cut, lbp->backtracks, lbp->lb.skipped));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* For checkpoints (MSimSolverHistory): L-BFGS's state once a solve has made it. Plain PD and
   Anderson carry nothing from one solve to the next (Anderson's history is made and freed in each
   solve). The type test: the functions stay composed if the SNES changes type. */
static PetscErrorCode SNESGetHistory_PD(SNES snes, MSimSolverHistory *h)
{
  PetscBool      pd;
  PetscContainer c;
  SNESPDOptions *opts;
  MSimPDLBFGS   *st;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESPD, &pd));
  if (!pd) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESPDGetOptions(snes, &opts));
  PetscCall(PetscObjectQuery((PetscObject)snes, "SNESPDLBFGS", (PetscObject *)&c));
  if (!c || opts->lbfgs <= 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscContainerGetPointer(c, (void **)&st));
  if (st->lb.m == opts->lbfgs) PetscCall(MSimPDLBFGSGetHistory(st, h));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* a restart's L-BFGS state, of the m this SNES runs with: a copy waits on the SNES for the state
   its first solve makes (SNESPDGetLBFGS) */
static PetscErrorCode SNESSetHistory_PD(SNES snes, const MSimSolverHistory *h, PetscBool *taken)
{
  PetscBool          pd;
  SNESPDOptions     *opts;
  MSimSolverHistory *copy;
  PetscContainer     c;

  PetscFunctionBeginUser;
  *taken = PETSC_FALSE;
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESPD, &pd));
  if (!pd) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESPDGetOptions(snes, &opts));
  if (opts->lbfgs <= 0 || h->name != "pd_lbfgs" || h->real.empty() || h->real[0] != opts->lbfgs || (PetscInt)h->vec.size() != 2 * opts->lbfgs) PetscFunctionReturn(PETSC_SUCCESS);
  copy       = new MSimSolverHistory();
  copy->name = h->name;
  copy->real = h->real;
  for (Vec v : h->vec) {
    copy->vec.push_back(NULL);
    PetscCall(VecDuplicate(v, &copy->vec.back()));
    PetscCall(VecCopy(v, copy->vec.back()));
  }
  PetscCall(PetscContainerCreate(PetscObjectComm((PetscObject)snes), &c));
  PetscCall(PetscContainerSetPointer(c, copy));
  PetscCall(PetscContainerSetUserDestroy(c, SNESPDRestartDestroy));
  PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDLBFGSRestart", (PetscObject)c));
  PetscCall(PetscContainerDestroy(&c));
  PetscCall(PetscObjectCompose((PetscObject)snes, "SNESPDLBFGS", NULL)); /* the first solve makes the state anew */
  *taken = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SNESCreate_PD(SNES snes)
{
  SNESPDOptions *opts;

  PetscFunctionBeginUser;
  PetscCall(SNESCreate_Shell(snes));
  PetscCall(SNESShellSetSolve(snes, SNESSolve_PD));
  PetscCall(PetscObjectComposeFunction((PetscObject)snes, "MSimSNESGetHistory_C", SNESGetHistory_PD));
  PetscCall(PetscObjectComposeFunction((PetscObject)snes, "MSimSNESSetHistory_C", SNESSetHistory_PD));
  PetscCall(SNESPDGetOptions(snes, &opts)); /* its options handler, for the SetFromOptions that follows */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc's own lists hold these types: only the once-only flag of MSimRegistry is used */
static MSimRegistry<PetscErrorCode (*)(SNES)> MSimSolvers;

PetscErrorCode MSimSolversRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (!MSimSolvers.Fill()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESRegister(SNESPD, SNESCreate_PD));
  PetscCall(SNESRegister(SNESNTR, SNESCreate_NTR));
  PetscCall(PCRegister(PCMSIMLLT, PCCreate_MSimLLT));
  PetscFunctionReturn(PETSC_SUCCESS);
}

