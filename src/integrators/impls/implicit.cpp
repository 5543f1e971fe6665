/* The implicit integrators (implicit_euler and every scheme registered in src/implicit/): one
   SNES (unprefixed) per step on g(x) = grad Phi(x) = 0 of the implicit problem (msim/implicit.h),
   which holds the scheme and the energy terms; the SNES sees only its callbacks. The SNES type picks
   the method: newtonls (Newton, analytic Jacobian, line search on Phi), ksponly (Baraff-Witkin: one
   linearized step from x0 = x_n + h v_n), pd (projective dynamics), anderson/ngmres with
   -npc_snes_type pd (accelerated PD), qn with -snes_qn_scale_type jacobian (L-BFGS whose initial
   Hessian is the PD factor). */
#include <msim/integrator.h>
#include <msim/implicit.h>
#include <msim/convergence.h>
#include <msim/contact_bounds.h>
#include <msim/volume.h>
#include <msim/private/integratorimpl.h>
#include <msim/signals.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h> /* MSimContactGetForStep: kappa at set-up */
#include <msim/destroy.h>
#include <petsc/private/petscimpl.h> /* PetscObjectStateIncrease: Phi at X changes with a lag iteration */

#define MSIM_MAX_TERM_HISTORY 4 /* terms' history vectors (MSimImplicitTermOps.get_history) */

typedef struct {
  MSimImplicit           imp;
  SNES                   snes;
  Mat                    J;
  Vec                    G;
  PetscBool              pc_pd;          /* the SNES's linear solves preconditioned by the PD factor */
  MSimConvergenceMonitor conv;
  PetscBool              psd_fallback;   /* exact Hessian: PSD-projected direction where it fails */
  PetscBool              psd_set;        /* -msim_psd given */
  PetscBool              pc_pd_set, psd_fallback_set, check_saddle_set; /* -msim_pc_pd, -msim_psd_fallback, -msim_check_saddle given */
  PetscBool              exact_mumps;    /* newtonls on the exact Hessian factored by MUMPS Cholesky (SetUpInertia) */
  MSimLineSearchCtx      ls;
  PetscReal              ls_cut;         /* the last pre-check's cut of PETSc's search direction (1: none) */
  PetscBool              check_saddle;   /* -msim_check_saddle */
  PetscBool              inertia;        /* Newton's PC is MUMPS LDL^T of the exact Hessian: its inertia is known */
  PetscBool              inertia_correction; /* -msim_inertia_correction */
  MSimInertiaCorrection  ic;
  PetscReal              step_atol;      /* -msim_step_atol: converged once a step moves less */
  PetscReal              step_gtol;      /* and |g| at most this (free mass x step_atol with a barrier; else no bound) */
  /* what the user chose for the SNES's parts, asked in its options block (SNESUserChoices) */
  PetscBool              mg_levels_set;  /* GAMG's smoothers (-mg_levels_ksp_type) */
  PetscBool              sub_pc_set;     /* block Jacobi's blocks (-sub_pc_type) */
  PetscBool              pc_type_set;    /* the preconditioner (-pc_type) */
  PetscBool              ksp_type_set;   /* the Krylov method (-ksp_type) */
  PetscBool              linesearch_set; /* the line search (-snes_linesearch_type) */
  PetscInt               icntl13;        /* MUMPS's ICNTL(13) (-mat_mumps_icntl_13; 1 unless set) */
  MSimContactBounds      bounds;         /* obstacles as VI bounds (-msim_contact_bounds), or NULL */
  PetscBool              semismooth;     /* -snes_type vinewtonssls: no objective, a nonsymmetric Jacobian */
  PetscBool              history_loaded; /* a restart gave the scheme its history (HistoryLoaded_Implicit) */
  PetscBool              linearised_noted; /* the note that a fixed-count solve makes a residual scheme linearised is out */
  Vec                    history[MSIM_SCHEME_MAX_WORK + 1 + MSIM_MAX_TERM_HISTORY]; /* what a checkpoint carries (GetHistory_Implicit) */
  Vec                    vi_step;        /* LineSearchPostCheckVI's work: the VI search's step (made once) */
} ImplicitData;

/* -msim_step_atol d: also converged once an iteration's step dx has |dx|_2 < d (in metres), the rule
   of graphics codes' Newton (e.g. |dx| < 1e-3 with at most 20 iterations). PETSc's own step test,
   -snes_stol, is relative to |x|: it would make convergence depend on where the scene sits in
   space. Read by the SNES types that report their step length (newtonls, ntr, qn; not pd).
   The length judged is the step the method asked for (the line search's direction), not the
   step taken: a contact barrier's max_step cuts a step short where a vertex nears an obstacle,
   and so does backtracking, and such a short step says nothing about convergence (taking it for
   one ended the benchmark cloth's steps on a ball after one cut iteration each, far from the
   step's minimum, until the run diverged at step 9). An inexact Newton direction (CG to the
   Eisenstat-Walker tolerance) falls short of Newton's step too: CG's iterates grow in length
   from 0, and one CG iteration on a barrier's stiff blocks, which the PD factor lacks, gave a
   direction of 1e-5 m where the step was centimetres. So newtonls's direction is counted with
   the step it still misses, P^-1 r (the linear solve's preconditioned residual, in metres where
   the preconditioner P approximates the Hessian: a factor, ICC, GAMG; not with -pc_type none,
   whose residual is a force, nor with a direct solve, where it is 0).
   A short step is also no evidence where a barrier is stiff: a vertex at a distance s << d from an
   obstacle with the log barrier's force pushing it out has a Newton move of about s (the force
   halves as s doubles), so |dx| < d holds at once whatever the force. With -snes_type ntr (21 x 21
   cloth on the ball, |dx| < 1e-3, 20 iterations) one vertex's first iterate was clamped to 0.2 of
   its distance at each step, one iteration doubled it, the rule stopped there with the vertex
   left moving inwards, and it sank by 0.41 a step for 20 steps, to 2e-12 m, with |g| 3e4 and a
   contact force of 2e7 N (m g = 9.81 N). So where a barrier is in Phi (a term with a feasible set:
   obstacles, self-contact, the tets' inversion barrier) the rule also asks |g| <= M d (M the free
   vertices' mass; g has units of mass x length): the unbalanced force |g| / h^2 at most the force
   that moves the whole mass by d in one step. Steps the rule ended right stop at |g| below it
   (at most 0.7 M d on the 41 x 41 drape with newtonls, 0.2 M d with ntr). Without a barrier a
   short Newton step is the evidence it always was, and what |g| is left after it grows with the
   springs' stiffness, not the mass (a free 41 x 41 cloth at k = 1e6 N/m: 40 iterations in 10
   steps without the force condition, 200 with it, 9 steps at the cap). */
static PetscErrorCode ConvergedStep(SNES snes, PetscInt it, PetscReal xnorm, PetscReal snorm, PetscReal fnorm, SNESConvergedReason *reason, void *ctx)
{
  ImplicitData *ie = (ImplicitData *)ctx;
  PetscReal     dx = PetscMax(snorm, ie->ls.dxnorm);

  PetscFunctionBeginUser;
  ie->ls.dxnorm = 0; /* read once: the next iteration's search sets it again */
  if (it > 0 && dx < ie->step_atol) {
    KSP       ksp;
    PC        pc;
    KSPNormType nt;
    PetscBool newton, none;
    PetscReal rnorm;
    PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESNEWTONLS, &newton));
    PetscCall(SNESGetKSP(snes, &ksp));
    PetscCall(KSPGetNormType(ksp, &nt));
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCNONE, &none));
    if (newton && nt == KSP_NORM_PRECONDITIONED && !none) {
      PetscCall(KSPGetResidualNorm(ksp, &rnorm));
      dx += rnorm;
    }
  }
  PetscCall(SNESConvergedDefault(snes, it, xnorm, snorm, fnorm, reason, NULL));
  if ((*reason == SNES_CONVERGED_ITERATING || *reason == SNES_DIVERGED_MAX_IT) && it > 0 && dx < ie->step_atol) {
    const PetscReal gtol = ie->step_gtol;
    if (fnorm <= gtol) {
      PetscCall(PetscInfo(snes, "converged: step length %g < -msim_step_atol %g\n", (double)dx, (double)ie->step_atol));
      *reason = SNES_CONVERGED_SNORM_RELATIVE;
    } else PetscCall(PetscInfo(snes, "step length %g < -msim_step_atol %g but |g| %g > M d %g: not converged\n", (double)dx, (double)ie->step_atol, (double)fnorm, (double)gtol));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode FormFunction(SNES snes, Vec X, Vec G, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitResidual((MSimImplicit)ctx, X, G));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode FormObjective(SNES snes, Vec X, PetscReal *phi, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitObjective((MSimImplicit)ctx, X, phi));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode FormJacobian(SNES snes, Vec X, Mat J, Mat P, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitJacobian((MSimImplicit)ctx, X, P));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Newton on the exact Hessian, where its direction does not lower Phi (compressed springs make
   the Hessian indefinite): the direction of the PSD-projected Hessian at the same x, which the
   Armijo search always accepts. The next iteration assembles the exact Hessian again, so Newton
   keeps its quadratic convergence where the Hessian turns definite near the solution. */
static PetscErrorCode DescentProjected(SNES snes, Vec X, Vec F, Vec Y, void *ctx)
{
  MSimImplicit       imp = (MSimImplicit)ctx;
  Mat                J, P;
  KSP                ksp;
  KSPConvergedReason reason;

  PetscFunctionBeginUser;
  PetscCall(SNESGetJacobian(snes, &J, &P, NULL, NULL));
  PetscCall(SNESGetKSP(snes, &ksp));
  imp->psd = PETSC_TRUE;
  PetscCall(MSimImplicitJacobian(imp, X, P));
  imp->psd = PETSC_FALSE;
  PetscCall(KSPSetOperators(ksp, J, P));
  PetscCall(KSPSolve(ksp, F, Y));
  PetscCall(KSPGetConvergedReason(ksp, &reason));
  PetscCheck(reason >= 0, PetscObjectComm((PetscObject)snes), PETSC_ERR_NOT_CONVERGED, "implicit Euler: the linear solve for the PSD-projected Newton direction failed (%s)", KSPConvergedReasons[reason]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Newton with inertia correction: H + delta M, factored here with no negative pivot; the KSP
   solve that follows finds the factor current and reuses it. */
static PetscErrorCode FormJacobianInertiaCorrected(SNES snes, Vec X, Mat J, Mat P, void *ctx)
{
  ImplicitData *ie = (ImplicitData *)ctx;
  KSP            ksp;

  PetscFunctionBeginUser;
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(MSimImplicitJacobianInertiaCorrected(ie->imp, ksp, X, P, &ie->ic));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* L-BFGS: the PD matrix is constant; returning without touching it keeps one factorization. */
static PetscErrorCode FormJacobianConstant(SNES snes, Vec X, Mat J, Mat P, void *ctx)
{
  PetscFunctionBeginUser;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the convergence monitor's row: Phi and |g| at X */
static PetscErrorCode ConvergenceEval(void *ctx, Vec X, PetscReal *phi, PetscReal *gnorm)
{
  ImplicitData *ie = (ImplicitData *)ctx;

  PetscFunctionBeginUser;
  if (ie->imp->scheme->no_objective) *phi = NAN; /* no Phi: the residual only */
  else PetscCall(MSimImplicitObjective(ie->imp, X, phi));
  PetscCall(MSimImplicitResidual(ie->imp, X, ie->G));
  PetscCall(VecNorm(ie->G, NORM_2, gnorm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the line search starts where every term is still defined */
static PetscErrorCode LineSearchMaxStep(SNES snes, Vec X, Vec Y, PetscReal *lambda, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitMaxStep((MSimImplicit)ctx, X, Y, lambda));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc's own line searches (L-BFGS's cp, a user's bt): the step X - Y shortened to the terms'
   max_step, so that no trial point leaves the feasible set of a contact barrier. msim's energy
   search (shell) never calls it: it asks max_step itself. The direction's length before the
   cut goes to -msim_step_atol's test (ConvergedStep), as the shell search's does. */
static PetscErrorCode LineSearchPreCheckMaxStep(SNESLineSearch ls, Vec X, Vec Y, PetscBool *changed, void *ctx)
{
  ImplicitData *ie    = (ImplicitData *)ctx;
  PetscReal     alpha = 1;

  PetscFunctionBeginUser;
  PetscCall(VecNorm(Y, NORM_2, &ie->ls.dxnorm));
  PetscCall(MSimImplicitMaxStep(ie->imp, X, Y, &alpha));
  ie->ls_cut = PetscMin(alpha, 1); /* the search's lambda is of the cut Y: StepStalled multiplies */
  *changed = (PetscBool)(alpha < 1);
  if (*changed) PetscCall(VecScale(Y, alpha));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PETSc's VI line search projects each trial point onto the bounds, off the segment X - lambda Y
   the pre-check cleared: the other barriers' (self-contact's) feasibility is checked again on the
   step the search took, X -> W, and W cut back along it where needed. Without it the 21 x 21 fold
   of tests/self_contact.py on a plane held as bounds crossed itself (2 triangle pairs from step 26). */
static PetscErrorCode LineSearchPostCheckVI(SNESLineSearch ls, Vec X, Vec Y, Vec W, PetscBool *changed_y, PetscBool *changed_w, void *ctx)
{
  ImplicitData *ie    = (ImplicitData *)ctx;
  PetscReal     alpha = 1;

  PetscFunctionBeginUser;
  *changed_y = PETSC_FALSE;
  *changed_w = PETSC_FALSE;
  if (!ie->vi_step) PetscCall(VecDuplicate(X, &ie->vi_step));
  PetscCall(VecWAXPY(ie->vi_step, -1.0, W, X)); /* W = X - step */
  PetscCall(MSimImplicitMaxStep(ie->imp, X, ie->vi_step, &alpha));
  if (alpha < 1) {
    PetscCall(VecWAXPY(W, -alpha, ie->vi_step, X));
    *changed_w = PETSC_TRUE;
    PetscCall(PetscInfo(ls, "VI search's step cut to %g of it by the barriers' max_step\n", (double)alpha));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Newton (newtonls) on the exact Hessian with MUMPS Cholesky, which is LDL^T with pivoting on an
   indefinite matrix: its inertia tells whether a converged step sits at a minimum of Phi or at a
   saddle (compressed springs: on the benchmark cloth from the third step on, with hundreds of
   negative eigenvalues, where descent methods find lower Phi), and -msim_inertia_correction needs
   it to steer Newton to minima. -msim_check_saddle turns the check off. In parallel MUMPS counts
   the pivots of its last front only with ICNTL(13) = 1 (no ScaLAPACK there): set on the factor
   matrix itself, where a user's -mat_mumps_icntl_13 still wins (MUMPS reads it at factorization). */
static PetscErrorCode SetUpInertia(ImplicitData *ie, PetscMPIInt size)
{
  KSP           ksp;
  PC            pc;
  PetscBool     newton, cholesky, mumps;
  MatSolverType solver;
  PetscInt      icntl13 = 1;

  PetscFunctionBeginUser;
  ie->inertia = ie->exact_mumps = PETSC_FALSE;
  PetscCall(PetscObjectTypeCompare((PetscObject)ie->snes, SNESNEWTONLS, &newton));
  if (!newton || ie->imp->psd || ie->pc_pd) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESGetKSP(ie->snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCHOLESKY, &cholesky));
  if (!cholesky) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCFactorGetMatSolverType(pc, &solver));
  PetscCall(PetscStrcmp(solver, MATSOLVERMUMPS, &mumps));
  if (!solver || !mumps) PetscFunctionReturn(PETSC_SUCCESS);
  ie->exact_mumps = PETSC_TRUE; /* where -msim_check_saddle and -msim_inertia_correction are read (RefuseUnread) */
  if (!(ie->check_saddle || ie->inertia_correction)) PetscFunctionReturn(PETSC_SUCCESS);
  if (size > 1) {
    Mat F;
    icntl13 = ie->icntl13; /* a user's -mat_mumps_icntl_13 wins over the 1 set below */
    PetscCall(KSPSetOperators(ksp, ie->J, ie->J));
    PetscCall(PCFactorSetUpMatSolverType(pc));
    PetscCall(PCFactorGetMatrix(pc, &F));
    PetscCall(MatMumpsSetIcntl(F, 13, 1));
  }
  ie->inertia = (PetscBool)(icntl13 == 1);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* GAMG's default Chebyshev smoothing, with its estimated spectrum, made the preconditioner
   indefinite for CG on cloth Jacobians (DIVERGED_INDEFINITE_PC on the 21 x 21 cloth); symmetric
   SOR under Richardson keeps it SPD. Not on solids: there the six rigid-body modes of an
   aggregate of one vertex include three zero columns (rotations about itself), and SOR's inverse
   of that coarse node's 6 x 6 diagonal block fails (zero pivot) on tet boxes; GAMG's own Chebyshev
   over point Jacobi takes them. GAMG makes its smoothers (Chebyshev) inside every set-up, so they
   are changed on the PC's smoothers after it, before each solve; a user's -mg_levels_ksp_type
   wins. */
static PetscErrorCode GAMGSmoothersSOR(PC pc, KSP ksp)
{
  PetscInt levels;

  PetscFunctionBeginUser;
  PetscCall(PCMGGetLevels(pc, &levels));
  for (PetscInt l = 1; l < levels; l++) {
    KSP       smoother;
    PC        sub;
    PetscBool cheb;
    PetscCall(PCMGGetSmoother(pc, l, &smoother));
    PetscCall(PetscObjectTypeCompare((PetscObject)smoother, KSPCHEBYSHEV, &cheb));
    if (!cheb) continue;
    PetscCall(KSPSetType(smoother, KSPRICHARDSON));
    PetscCall(KSPGetPC(smoother, &sub));
    PetscCall(PCSetType(sub, PCSOR));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* On several ranks CG's default block Jacobi factors each block with ILU(0), which has no pivot
   shift: on the PSD-projected Hessian of a folded cloth with self-contact barriers it met a
   negative pivot (DIVERGED_INDEFINITE_PC at 2 ranks, examples/cloth_fold.opts, step 27), where one
   rank's ICC, with its positive-definite shift, does not. So CG's blocks get ICC as well: the
   blocks exist only once the PC is set up, hence before each solve; a user's -sub_pc_type wins. */
static PetscErrorCode BlockJacobiICC(PC pc, KSP ksp)
{
  KSP      *sub;
  PetscInt  n;
  PetscBool bjacobi;

  PetscFunctionBeginUser;
  /* the PC may have changed type since the hook was set (a later -pc_type, msim's PD factor) */
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCBJACOBI, &bjacobi));
  if (!bjacobi) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCBJacobiGetSubKSP(pc, &n, NULL, &sub));
  for (PetscInt b = 0; b < n; b++) {
    PC        bpc;
    PetscBool ilu;
    PetscCall(KSPGetPC(sub[b], &bpc));
    PetscCall(PetscObjectTypeCompare((PetscObject)bpc, PCILU, &ilu));
    if (ilu) PetscCall(PCSetType(bpc, PCICC));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SetUpGAMGSmoothers(ImplicitData *ie, MSimSystem sys, KSP ksp)
{
  PC        pc;
  PetscBool gamg, bjacobi, cg;

  PetscFunctionBeginUser;
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCGAMG, &gamg));
  if (gamg && !ie->mg_levels_set && sys->cell_size != 4) PetscCall(PCSetPreSolve(pc, GAMGSmoothersSOR));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCBJACOBI, &bjacobi));
  PetscCall(PetscObjectTypeCompare((PetscObject)ksp, KSPCG, &cg));
  if (bjacobi && cg && !ie->sub_pc_set) PetscCall(PCSetPreSolve(pc, BlockJacobiICC));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* What msim knows of a SNES type, the one list of them: whether it minimizes Phi (pd, L-BFGS and
   the trust region need an objective, so a scheme without one refuses them: RefuseMinimizers),
   and what msim chooses for it by default: the trust region (ntr) handles indefinite Hessians, so
   it gets the exact one; it and L-BFGS (qn) precondition with the constant PD factor unless a
   -pc_type is given, and L-BFGS then takes the PD matrix itself as its constant Jacobian (its
   initial Hessian). */
static const struct {
  const char *type;
  PetscBool   minimizer, pc_pd, jacobian_pd, exact;
} kTypeDefaults[] = {
  {SNESPD,  PETSC_TRUE, PETSC_FALSE, PETSC_FALSE, PETSC_FALSE},
  {SNESQN,  PETSC_TRUE, PETSC_TRUE,  PETSC_TRUE,  PETSC_FALSE},
  {SNESNTR, PETSC_TRUE, PETSC_TRUE,  PETSC_FALSE, PETSC_TRUE },
};

/* whether snes's type minimizes Phi (kTypeDefaults) */
static PetscErrorCode SNESIsMinimizer(SNES snes, PetscBool *minimizer)
{
  PetscFunctionBeginUser;
  *minimizer = PETSC_FALSE;
  for (const auto &d : kTypeDefaults) {
    PetscBool match;
    PetscCall(PetscObjectTypeCompare((PetscObject)snes, d.type, &match));
    if (match) *minimizer = d.minimizer;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A scheme with no objective (discrete_gradient) solves with its exact Jacobian, which is not
   symmetric: the linear solvers that assume a symmetric matrix (CG and its kin, MINRES, SYMMLQ,
   CR) and the symmetric factorizations (Cholesky, ICC; a block's too) take its symmetric part or
   half of it. PETSc runs them without a word: with -pc_type cholesky (as examples/box.opts sets)
   Newton took 183 iterations where LU took 80 on a 16 x 4 x 4 box, 40 steps, and the energy
   error was 7e-7 where LU's was 9e-12. Refused in one line naming the option and what to use.
   The same for vinewtonssls's semismooth Jacobian (SetUpSemismooth): examples/cloth_table.opts'
   Cholesky under it diverged at step 6 (the energy rose by 2043 J) where LU ran through. */
static PetscErrorCode RefuseSymmetricOnly(MSimIntegrator integ, ImplicitData *ie, KSP ksp)
{
  const char *reason = ie->imp->scheme->no_objective;
  char        with[64];
  PC          pc;
  KSPType     ktype;
  PCType      ptype;
  const char *prefix;
  PetscBool   sym, block;
  char        sub[64];

  PetscFunctionBeginUser;
  if (reason) PetscCall(PetscSNPrintf(with, sizeof(with), "-msim_integrator %s", integ->type));
  else if (ie->semismooth) {
    reason = "vinewtonssls solves the Fischer-Burmeister equation of the bounds, whose Jacobian scales J's rows near a bound";
    PetscCall(PetscStrncpy(with, "-snes_type vinewtonssls", sizeof(with)));
  } else PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(KSPGetOptionsPrefix(ksp, &prefix));
  if (!prefix) prefix = "";
  PetscCall(KSPGetType(ksp, &ktype));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)ksp, &sym, KSPCG, KSPGROPPCG, KSPPIPECG, KSPPIPECGRR, KSPPIPELCG, KSPPIPECG2, KSPFCG, KSPPIPEFCG, KSPNASH, KSPSTCG, KSPGLTR, KSPQCG, KSPMINRES, KSPSYMMLQ, KSPCR, KSPPIPECR, ""));
  PetscCheck(!sym, integ->comm, PETSC_ERR_SUP, "-%sksp_type %s with %s is not supported: it needs a symmetric matrix, and the Jacobian is not symmetric (%s); use -%sksp_type gmres", prefix, ktype, with, reason, prefix);
  if (ie->pc_pd) PetscFunctionReturn(PETSC_SUCCESS); /* the PD factor is the PC: an SPD approximation GMRES solves with */
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCGetType(pc, &ptype));
  PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &sym, PCCHOLESKY, PCICC, ""));
  PetscCheck(!sym, integ->comm, PETSC_ERR_SUP, "-%spc_type %s with %s is not supported: it factors a symmetric matrix, and the Jacobian is not symmetric (%s); use -%spc_type %s", prefix, ptype, with, reason, prefix,
             !strcmp(ptype, PCICC) ? "ilu" : "lu");
  /* a block's PC is made at the first solve: its type is read from the options */
  PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &block, PCBJACOBI, PCASM, ""));
  if (!block) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscOptionsGetString(((PetscObject)pc)->options, prefix, "-sub_pc_type", sub, sizeof(sub), &sym));
  PetscCheck(!sym || (strcmp(sub, PCCHOLESKY) && strcmp(sub, PCICC)), integ->comm, PETSC_ERR_SUP, "-%ssub_pc_type %s with %s is not supported: it factors a symmetric matrix, and the Jacobian is not symmetric (%s); use -%ssub_pc_type %s", prefix, sub, with, reason, prefix,
             !strcmp(sub, PCICC) ? "ilu" : "lu");
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SetUpJacobian(MSimIntegrator integ, ImplicitData *ie, MSimSystem sys, KSP ksp)
{
  PetscBool uses, has_pc, jacobian_pd = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(MSimSNESUsesJacobian(ie->snes, &uses));
  has_pc = ie->pc_type_set;
  for (const auto &d : kTypeDefaults) {
    PetscBool match;
    PetscCall(PetscObjectTypeCompare((PetscObject)ie->snes, d.type, &match));
    if (!match) continue;
    if (d.pc_pd && !has_pc) ie->pc_pd = PETSC_TRUE;
    if (d.exact && !ie->psd_set) ie->imp->psd = PETSC_FALSE;
    jacobian_pd = (PetscBool)(d.jacobian_pd && ie->pc_pd);
  }
  if (!uses) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(RefuseSymmetricOnly(integ, ie, ksp));
  if (ie->pc_pd && has_pc) {
    /* only a -msim_pc_pd the user gave gets here (the types' default gives way to a -pc_type):
       the PD factor would take the PC's place, and the -pc_type asked for would go unused */
    PC     pc;
    PCType type;
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCGetType(pc, &type));
    SETERRQ(PetscObjectComm((PetscObject)ksp), PETSC_ERR_ARG_INCOMP, "-msim_pc_pd replaces the preconditioner: drop -pc_type %s or -msim_pc_pd", type);
  }
  if (jacobian_pd) {
    /* L-BFGS with the PD matrix as initial Hessian: constant shell Jacobian, PD factor as PC */
    PetscCall(MSimImplicitPDCreateShell(ie->imp, &ie->J));
    PetscCall(SNESSetJacobian(ie->snes, ie->J, ie->J, FormJacobianConstant, ie->imp));
    PetscCall(KSPSetType(ksp, KSPPREONLY));
    PetscCall(MSimImplicitPDSetPC(ie->imp, ksp));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MSimSystemCreateMatrix(sys, &ie->J));
  if (ie->imp->scheme->no_objective || ie->semismooth) {
    /* a discrete gradient's Jacobian is not symmetric, nor the semismooth one (SetUpSemismooth) */
    PetscCall(MatSetOption(ie->J, MAT_SYMMETRY_ETERNAL, PETSC_FALSE));
    PetscCall(MatSetOption(ie->J, MAT_SYMMETRIC, PETSC_FALSE));
  }
  {
    /* rigid-body modes of the rest state: the near null space algebraic multigrid (GAMG, ML)
       needs for a vector problem; other solvers ignore it */
    MatNullSpace nsp;
    PetscCall(MatNullSpaceCreateRigidBody(sys->X0, &nsp));
    PetscCall(MatSetNearNullSpace(ie->J, nsp));
    PetscCall(MatNullSpaceDestroy(&nsp));
  }
  PetscCall(SNESSetJacobian(ie->snes, ie->J, ie->J, FormJacobian, ie->imp));
  if (ie->pc_pd) PetscCall(MSimImplicitPDSetPC(ie->imp, ksp));
  else PetscCall(MSimCheckFactorAvailable(ksp, ie->J));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Whether the user chose the SNES's preconditioner, line search and GAMG smoothers, and MUMPS's
   ICNTL(13): msim's defaults for them depend on the SNES type and give way to a user's choice.
   Asked inside the SNES's own options block (an options handler, run by SNESSetFromOptions after
   the type is set, with the SNES's prefix, which its KSP, PC and line search share). PETSc keeps
   no record of whether a type came from an option or a default, so this asks whether the names
   are set; it lists nothing in -help (their owners do, when they read them). */
static PetscErrorCode SNESUserChoices(PetscObject obj, PetscOptionItems *PetscOptionsObject, void *ctx)
{
  ImplicitData *ie = (ImplicitData *)ctx;
  PetscBool     set;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsHasName(PetscOptionsObject->options, PetscOptionsObject->prefix, "-pc_type", &ie->pc_type_set));
  PetscCall(PetscOptionsHasName(PetscOptionsObject->options, PetscOptionsObject->prefix, "-ksp_type", &ie->ksp_type_set));
  PetscCall(PetscOptionsHasName(PetscOptionsObject->options, PetscOptionsObject->prefix, "-snes_linesearch_type", &ie->linesearch_set));
  PetscCall(PetscOptionsHasName(PetscOptionsObject->options, PetscOptionsObject->prefix, "-mg_levels_ksp_type", &ie->mg_levels_set));
  PetscCall(PetscOptionsHasName(PetscOptionsObject->options, PetscOptionsObject->prefix, "-sub_pc_type", &ie->sub_pc_set));
  ie->icntl13 = 1;
  PetscCall(PetscOptionsGetInt(PetscOptionsObject->options, PetscOptionsObject->prefix, "-mat_mumps_icntl_13", &ie->icntl13, &set));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode ReadOptions(MSimIntegrator integ, ImplicitData *ie)
{
  PetscFunctionBeginUser;
  PetscOptionsBegin(integ->comm, NULL, "msim implicit integrators", NULL);
  PetscCall(PetscOptionsBool("-msim_psd", "Project each spring's Hessian block to PSD in the Newton Jacobian (keeps CG and Cholesky applicable; default off for -snes_type ntr)", NULL, ie->imp->psd, &ie->imp->psd, &ie->psd_set));
  PetscCall(PetscOptionsBool("-msim_psd_fallback", "With -msim_psd 0: where the exact Hessian's Newton direction raises Phi, or needs a step below 1/1024 to lower it, take the PSD-projected Hessian's", NULL, ie->psd_fallback, &ie->psd_fallback, &ie->psd_fallback_set));
  PetscCall(PetscOptionsBool("-msim_check_saddle", "Newton on the exact Hessian with MUMPS Cholesky (LDL^T): after each converged step, factor the Hessian at the solution once more and warn where it has negative eigenvalues (a saddle of Phi)", NULL, ie->check_saddle, &ie->check_saddle, &ie->check_saddle_set));
  PetscCall(PetscOptionsBool("-msim_inertia_correction", "Newton on the exact Hessian with MUMPS Cholesky (LDL^T): factor H + delta M with the least delta (0, then 1e-3 x 8^k) that leaves no negative pivot, so Newton converges to minima of Phi, not saddles", NULL, ie->inertia_correction, &ie->inertia_correction, NULL));
  PetscCall(MSimOptionsReal("-msim_step_atol", "Converged also once an iteration's step dx has |dx|_2 below this (m; 0: off), with a contact or inversion barrier only if also |g| <= free mass x this (a barrier's short steps hide its force): graphics codes' rule, absolute where -snes_stol is relative to |x| (newtonls, ntr, qn)", NULL, ie->step_atol, &ie->step_atol, NULL));
  PetscCheck(ie->step_atol >= 0, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_step_atol must be >= 0 (got %g)", (double)ie->step_atol);
  PetscCall(PetscOptionsBool("-msim_pc_pd", "Precondition the SNES's linear solves with the constant PD factor in place of a -pc_type, so not with one (default for -snes_type qn and ntr when no -pc_type is given)", NULL, ie->pc_pd, &ie->pc_pd, &ie->pc_pd_set));
  PetscOptionsEnd();
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* what a term with a feasible set (a barrier) is, as the user set it up, for refusals */
static const char *BarrierName(MSimImplicitTerm term)
{
  if (!strcmp(term->type, "self_contact")) return "self-contact (-msim_self_contact)";
  if (!strcmp(term->type, "volume")) return "the tets' volume barrier (-msim_volume)";
  return "obstacles (-msim_contact_*)";
}

/* A scheme with no objective (discrete_gradient: its residual is no function's gradient): the
   solvers that minimize Phi are refused in one line naming the option, the SNES's own type and a
   nonlinear preconditioner's alike. */
static PetscErrorCode RefuseMinimizers(MSimIntegrator integ, ImplicitData *ie)
{
  const char *reason = ie->imp->scheme->no_objective;
  SNES        snes   = ie->snes;
  PetscBool   has_npc;

  PetscFunctionBeginUser;
  PetscCheck(!ie->inertia_correction, integ->comm, PETSC_ERR_SUP, "-msim_inertia_correction with -msim_integrator %s is not supported: it steers Newton to minima of Phi, and %s", integ->type, reason);
  PetscCall(SNESHasNPC(snes, &has_npc));
  for (int level = 0; level < 2; level++) {
    PetscBool   minimizer;
    SNESType    type;
    const char *prefix = level ? "npc_" : "";
    if (level) {
      if (!has_npc) break;
      PetscCall(SNESGetNPC(ie->snes, &snes));
    }
    PetscCall(SNESIsMinimizer(snes, &minimizer));
    PetscCall(SNESGetType(snes, &type));
    PetscCheck(!minimizer, integ->comm, PETSC_ERR_SUP, "-%ssnes_type %s with -msim_integrator %s is not supported: %s minimizes an energy, and the scheme has none (%s); use newtonls (MUMPS LU by default on one rank)", prefix, type, integ->type, type, reason);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* vinewtonssls (the semismooth Newton of PETSc's VI solvers, with obstacles as bounds) solves the
   Fischer-Burmeister reformulation phi(x) = 0 of the bounds and g, one equation per component,
   whose Jacobian is diag(Db) J + diag(Da): J's rows scaled where a bound is near, so nonsymmetric.
   CG with ICC, msim's default for J, broke down on it (DIVERGED_ITS at 10,000 iterations, step 11
   of the table drop, tests/contact_bounds_table.py): GMRES with ILU (block Jacobi-ILU in
   parallel) unless the user chose a -ksp_type or -pc_type. And no objective: its Newton direction
   descends for the method's merit |phi|^2, not for Phi, and PETSc's line searches use an objective
   wherever one is set (l2 on Phi, flat to roundoff at 1.2442e-4 J along the whole search, halved
   or stretched the step at random: 50 iterations ending at |phi| = 3e-9, steps 11-12); without
   one they work on |phi|^2, which falls to 0 with no roundoff floor. (SNESSetObjective(NULL) does
   not unset one in PETSc 3.18, so CreateSNES sets it only after the type is known.) */
static PetscErrorCode SetUpSemismooth(ImplicitData *ie, PetscMPIInt size, KSP ksp)
{
  PC pc;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)ie->snes, SNESVINEWTONSSLS, &ie->semismooth));
  if (!ie->semismooth) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(KSPGetPC(ksp, &pc));
  if (!ie->ksp_type_set) PetscCall(KSPSetType(ksp, KSPGMRES));
  if (!ie->pc_type_set && size == 1) PetscCall(PCSetType(pc, PCILU));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The SNES with msim's defaults, which a user overrides with the usual options: Newton, msim's
   line search on Phi, CG with ICC (block Jacobi-ICC in parallel) on the PSD-projected Jacobian;
   for a scheme with no objective, no Phi: on one rank MUMPS LU on its nonsymmetric Jacobian unless
   a -ksp_type, -pc_type or -msim_pc_pd is given, else GMRES with ILU (block Jacobi-ILU in parallel),
   and PETSc's l2 line search, which minimizes |r|^2 along the Newton step by secant steps (bt,
   backtracking on |r|^2, stalled at a local minimum of |r| where the Jacobian is nearly singular,
   step 103 of an 11 x 11 cloth at h = 1/30 s; l2 ran through). */
static PetscErrorCode CreateSNES(MSimIntegrator integ, ImplicitData *ie, KSP *ksp)
{
  MSimSystem      sys = integ->sys;
  PC              pc;
  DM              dm;
  const PetscBool discrete = (PetscBool)(ie->imp->scheme->no_objective != NULL);

  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(sys->X0, &ie->G));
  PetscCall(SNESCreate(integ->comm, &ie->snes));
  PetscCall(PetscObjectAddOptionsHandler((PetscObject)ie->snes, SNESUserChoices, NULL, ie));
  PetscCall(SNESSetFunction(ie->snes, ie->G, FormFunction, ie->imp));
  PetscCall(SNESGetDM(ie->snes, &dm));
  PetscCall(MSimImplicitPDCompose(ie->imp, dm));
  PetscCall(SNESSetType(ie->snes, SNESNEWTONLS));
  PetscCall(SNESGetKSP(ie->snes, ksp));
  PetscCall(KSPSetType(*ksp, discrete ? KSPGMRES : KSPCG));
  PetscCall(KSPGetPC(*ksp, &pc));
  PetscCall(PCSetType(pc, sys->size > 1 ? PCBJACOBI : (discrete ? PCILU : PCICC)));
  /* |g| has units of mass x length: below 1e-10 of total mass x scene size the step is converged
     to roundoff, and line searches on Phi can only fail there. -snes_max_it is the one budget: no
     cap on function evaluations (PETSc's 10,000 stopped L-BFGS, two per iteration, at 5,000
     iterations as a failure). */
  PetscCall(SNESSetTolerances(ie->snes, 1e-10 * sys->total_mass * PetscMax(sys->diameter, PETSC_SMALL), 1e-8, 1e-12, 50, -1));
  if (discrete) {
    /* a GMRES iterate that stopped short still lowers the linearized |r| (GMRES minimizes it over
       its space), so it descends for |r|^2: Newton goes on with it (GMRES(30) with ILU stalled at
       step 238 of a 7 x 7 cloth at h = 1/30 s); -snes_max_linear_solve_fail overrides */
    PetscCall(SNESSetMaxLinearSolveFailures(ie->snes, PETSC_MAX_INT));
  }
  /* Newton's line search: msim's backtracking on Phi with the |g| fallback near convergence; a
     default set before SNESSetFromOptions, so a user's -snes_linesearch_type replaces it there */
  if (discrete) {
    SNESLineSearch ls;
    PetscCall(SNESGetLineSearch(ie->snes, &ls));
    PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHL2));
  } else {
    SNESLineSearch ls;
    PetscCall(SNESGetLineSearch(ie->snes, &ls));
    PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHSHELL));
    /* inertia-corrected directions always descend: no fallback needed */
    ie->ls.descent  = ie->imp->psd || !ie->psd_fallback || ie->inertia_correction ? NULL : DescentProjected;
    ie->ls.max_step = LineSearchMaxStep;
    ie->ls.ctx      = ie->imp;
    PetscCall(SNESLineSearchShellSetUserFunc(ls, MSimLineSearchEnergy, &ie->ls));
  }
  if (ie->step_atol > 0) PetscCall(SNESSetConvergenceTest(ie->snes, ConvergedStep, ie, NULL));
  /* |g| at each iteration of the current solve (reset by each): its first entry is |g0|, the
     relative tolerance's base, which StepStalled reads */
  PetscCall(SNESSetConvergenceHistory(ie->snes, NULL, NULL, PETSC_DECIDE, PETSC_TRUE));
  PetscCall(SNESSetFromOptions(ie->snes));
  PetscCall(MSimSNESCheckServed(ie->snes));
  if (ie->step_atol > 0) {
    /* the rule is in the SNES's convergence test (ConvergedStep), on the step length the type hands
       it. pd stops on |g| or after a fixed count and ksponly after its one linear solve: neither
       calls the test, and the unconverged-steps warning named the rule as if it had run. ngmres
       hands it 0 and stopped after one iteration at |g| 1e-3 (the 7 x 7 unit-test cloth, where
       it takes 143 without the rule); nrichardson, ms and fas ran as if it were not set */
    PetscBool reads;
    SNESType  type;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)ie->snes, &reads, SNESNEWTONLS, SNESNTR, SNESQN, SNESNCG, SNESANDERSON, SNESVINEWTONRSLS, SNESVINEWTONSSLS, ""));
    PetscCall(SNESGetType(ie->snes, &type));
    PetscCheck(reads, integ->comm, PETSC_ERR_SUP, "-msim_step_atol with -snes_type %s is not supported: %s; newtonls, ntr, qn, ncg and anderson read it", type,
               !strcmp(type, SNESPD) ? "it never tests its step length (it stops at -snes_atol/-snes_rtol, or after -snes_max_it with -snes_pd_fixed)" : !strcmp(type, SNESKSPONLY) ? "it never tests its step length (it stops after its one linear solve)" : "it does not hand the convergence test its step length");
  }
  PetscCall(SetUpSemismooth(ie, sys->size, *ksp));
  if (!discrete && !ie->semismooth) PetscCall(SNESSetObjective(ie->snes, FormObjective, ie->imp));
#if defined(PETSC_HAVE_MUMPS)
  if (discrete && sys->size == 1 && !ie->ksp_type_set && !ie->pc_type_set && !ie->pc_pd) {
    /* the discrete gradient's Jacobian near the iterates its line search stops at is nearly
       singular (the 31 x 31 cloth at h = 1/30 s: Newton took 36-773 iterations a step), where
       GMRES with ILU left steps short and the energy drifted 1.76 J in 60 steps; MUMPS LU held it
       to 1.2e-11 J (runs/energy_conserving): LU unless the user chose a KSP or PC, on one rank
       (2 x GMRES-ILU's CPU on an 8-vertex chain and a 7 x 7 cloth, 200 steps). Not on several:
       there MUMPS took 4 x the CPU of GMRES with block Jacobi-ILU on the chain (2 ranks), which
       put tests/energy_conserving.py past its time limit. Set after the options so that -pc_type
       alone (ILU, ...) keeps GMRES; the PC's own options are read again for the factor
       (-pc_factor_mat_solver_type, -mat_mumps_*). Not with -msim_pc_pd, whose factor takes the
       PC's place (SetUpJacobian): preonly would take one application of it for Newton's direction
       (50 iterations a step without converging, a 6 x 6 cloth), where GMRES solves with it. */
    PetscCall(KSPSetType(*ksp, KSPPREONLY));
    PetscCall(PCSetType(pc, PCLU));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
    PetscCall(PCSetFromOptions(pc));
  }
#endif
  if (discrete) PetscCall(RefuseMinimizers(integ, ie));
  /* before the barrier's checks: it takes the obstacles it serves as bounds out of the system's
     contact object for good, so -help's throwaway integrators must not make one */
  if (!integ->help_listing) PetscCall(MSimContactBoundsCreate(sys, ie->snes, &ie->bounds));
  for (PetscInt k = 0; k < ie->imp->nterms; k++)
    if (ie->imp->terms[k]->ops.max_step) {
      SNESLineSearch ls;
      PetscBool qn, guarded;
      SNESType  type;
      /* the types whose every step goes through the line search msim cuts to the feasible set
         (pd keeps its own iterates feasible; the VI types serve obstacles as bounds, and their
         search takes the other barriers'). The others step without it: one linear step
         (ksponly), PETSc's mixing of iterates (anderson, ngmres), ncg's and ms's updates, PETSc's
         own trust region (newtontr) or sub-solvers (fas, composite): a vertex went inside a
         sphere a cloth fell on, or the run diverged (ncg, ms at step 10, newtontr's region shrank
         to nothing at step 11, 21 x 21 cloth on the ball) */
      PetscCall(PetscObjectTypeCompareAny((PetscObject)ie->snes, &guarded, SNESNEWTONLS, SNESNTR, SNESPD, SNESQN, SNESNRICHARDSON, SNESVINEWTONRSLS, SNESVINEWTONSSLS, ""));
      PetscCall(SNESGetType(ie->snes, &type));
      PetscCheck(guarded, integ->comm, PETSC_ERR_SUP, "-snes_type %s with %s is not supported: its steps have no feasible line search; use newtonls (to convergence: one Newton step, Baraff-Witkin's, stops wherever its line search meets the barrier), pd (-snes_pd_anderson m to accelerate it), qn or ntr", type, BarrierName(ie->imp->terms[k]));
      /* a nonlinear preconditioner's own steps: only pd keeps its iterates feasible (its step
         halving on Phi); any other type moves past the barrier before the outer search sees the
         point (newtonls, qn, ksponly as newtonls's preconditioner ended in a failed line search,
         DIVERGED_INNER or a diverged step on a cloth dropped on a ball) */
      {
        PetscBool has_npc, pd;
        SNES      npc;
        PetscCall(SNESHasNPC(ie->snes, &has_npc));
        if (has_npc) {
          PetscCall(SNESGetNPC(ie->snes, &npc));
          PetscCall(PetscObjectTypeCompare((PetscObject)npc, SNESPD, &pd));
          PetscCall(SNESGetType(npc, &type));
          PetscCheck(pd, integ->comm, PETSC_ERR_SUP, "-npc_snes_type %s with %s is not supported: a nonlinear preconditioner's steps have no feasible line search; use -npc_snes_type pd (its steps stay feasible) or none", type, BarrierName(ie->imp->terms[k]));
        }
      }
      PetscCall(SNESGetLineSearch(ie->snes, &ls));
      PetscCall(SNESLineSearchSetPreCheck(ls, LineSearchPreCheckMaxStep, ie));
      if (ie->bounds) PetscCall(SNESLineSearchSetPostCheck(ls, LineSearchPostCheckVI, ie));
      /* L-BFGS's default cp search extrapolates past the shortened step on gradients alone (it
         left the feasible set and ended in DIVERGED_DTOL on a cloth dropped on a plane): with a
         barrier, backtracking on Phi unless the user chose a search */
      PetscCall(PetscObjectTypeCompare((PetscObject)ie->snes, SNESQN, &qn));
      if (qn) {
        /* Broyden's directions (broyden, badbroyden) need not descend Phi: bt found no decrease for
           any lambda down to 1e-12 and the run failed at step 2 of a cloth falling towards a plane
           it had not reached (cp: a NaN residual at step 5), and at step 1 of a cloth in
           self-contact. PETSc has no getter for qn's type; its names are upper case. */
        static const char *const qn_names[] = {"lbfgs", "broyden", "badbroyden"}; /* SNESQNType's order */
        SNESQNType               qn_type    = SNES_QN_LBFGS;
        const char *prefix;
        PetscCall(SNESGetOptionsPrefix(ie->snes, &prefix));
        PetscCall(PetscOptionsGetEnum(NULL, prefix, "-snes_qn_type", SNESQNTypes, (PetscEnum *)&qn_type, NULL));
        PetscCheck(qn_type == SNES_QN_LBFGS, integ->comm, PETSC_ERR_SUP, "-snes_qn_type %s with %s is not supported: its directions need not descend the energy, which the feasible line search backtracks on: use -snes_qn_type lbfgs (the default)", qn_names[qn_type], BarrierName(ie->imp->terms[k]));
        if (!ie->linesearch_set) PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHBT));
      }
      {
        /* a user's l2 or cp: their secant steps take lambda up to the search's maxstep (1e8),
           past 1, the pre-check's feasible step: l2 passed the 41 x 41 fold's 6 crossing
           triangle pairs through each other in one step (examples/cloth_fold.opts with its
           start check off), where the CCD had cut the step. So lambda <= 1 for them (bt reads
           maxstep as a length in metres, and never extrapolates: left alone). */
        PetscBool secant;
        PetscReal steptol, maxstep, rtol, atol, ltol;
        PetscInt  maxits;
        PetscCall(PetscObjectTypeCompareAny((PetscObject)ls, &secant, SNESLINESEARCHL2, SNESLINESEARCHCP, ""));
        PetscCall(SNESLineSearchGetTolerances(ls, &steptol, &maxstep, &rtol, &atol, &ltol, &maxits));
        if (secant) PetscCall(SNESLineSearchSetTolerances(ls, steptol, PetscMin(maxstep, 1.0), rtol, atol, ltol, maxits));
      }
      break;
    }
  if (ie->conv) PetscCall(MSimConvergenceMonitorAttach(ie->conv, ie->snes, ConvergenceEval, ie));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The SNES's type, and its nonlinear preconditioner's, as the options name them */
static PetscErrorCode SNESTypes(SNES snes, char buf[], size_t len)
{
  SNESType  type;
  PetscBool has_npc;

  PetscFunctionBeginUser;
  PetscCall(SNESGetType(snes, &type));
  PetscCall(SNESHasNPC(snes, &has_npc));
  if (has_npc) {
    SNES     npc;
    SNESType npc_type;
    PetscCall(SNESGetNPC(snes, &npc));
    PetscCall(SNESGetType(npc, &npc_type));
    PetscCall(PetscSNPrintf(buf, len, "-snes_type %s -npc_snes_type %s", type, npc_type));
  } else PetscCall(PetscSNPrintf(buf, len, "-snes_type %s", type));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The barrier's PD and Newton options (-msim_contact_*, read by contact.cpp), refused where the run
   would go on without them: decided from what the run uses, not from which options are set
   (-msim_pc_pd is the default for qn and ntr). PD's own steps (-snes_type pd, or pd as the
   nonlinear preconditioner, the one a barrier allows) take the weights, refactor rule,
   selective refresh and step bound; Newton's PD preconditioner on an assembled Hessian takes the
   weights and refactor rule with -msim_contact_pc_pd_weight; the PSD-projected Hessian (-msim_psd,
   or the fallback's projected direction) takes the curvature clamp. Without a barrier (no
   obstacle, or VI bounds) MSimContactRefuseUnread refuses them. */
static PetscErrorCode RefuseUnreadContact(MSimIntegrator integ, ImplicitData *ie, const char types[], PetscBool hessian, PetscBool projected)
{
  MSimContact ct;
  PetscBool   pd, npc_pd = PETSC_FALSE, has_npc;
  PetscBool   set[6];
  char        where[192];
  static const char *const names[] = {"-msim_contact_pd_weight", "-msim_contact_pd_refactor", "-msim_contact_pd_refactor_selective", "-msim_contact_pd_bound", "-msim_contact_pc_pd_weight", "-msim_contact_psd_curvature"};

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(integ->sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  for (int k = 0; k < 6; k++) PetscCall(PetscOptionsHasName(NULL, NULL, names[k], &set[k]));
  PetscCall(PetscObjectTypeCompare((PetscObject)ie->snes, SNESPD, &pd));
  PetscCall(SNESHasNPC(ie->snes, &has_npc));
  if (has_npc) {
    SNES npc;
    PetscCall(SNESGetNPC(ie->snes, &npc));
    PetscCall(PetscObjectTypeCompare((PetscObject)npc, SNESPD, &npc_pd));
  }
  const PetscBool pd_steps = (PetscBool)(pd || npc_pd);
  const PetscBool pc_pd    = (PetscBool)(ie->imp->pd_pc && hessian); /* the PD factor preconditions solves with the Hessian the obstacles add to */
  const PetscBool weighted = (PetscBool)(pd_steps || (pc_pd && ct->pc_pd_weight)); /* where -msim_contact_pd_weight 1 puts weights in a factor */
  PetscCall(PetscSNPrintf(where, sizeof(where), "%s%s", types, weighted && !ct->pd_weight ? " -msim_contact_pd_weight 0" : ""));
  PetscCheck(!set[0] || weighted, integ->comm, PETSC_ERR_SUP, "-msim_contact_pd_weight with %s is not supported: it sets the barrier's weights in PD's matrix, which only PD's steps (-snes_type pd or -npc_snes_type pd) and, with -msim_contact_pc_pd_weight, Newton's PD preconditioner (-msim_pc_pd) use", types);
  PetscCheck(!set[4] || pc_pd, integ->comm, PETSC_ERR_SUP, "-msim_contact_pc_pd_weight with %s is not supported: it puts the barrier's weights in the PD factor that preconditions Newton's solves with the assembled Hessian (-msim_pc_pd with newtonls, or ntr's default), and this run has none", types);
  PetscCheck(!set[4] || !ct->pc_pd_weight || ct->pd_weight, integ->comm, PETSC_ERR_SUP, "-msim_contact_pc_pd_weight with -msim_contact_pd_weight 0 is not supported: the one puts the barrier's weights in the PD preconditioner, the other leaves them out");
  PetscCheck(!set[1] || (weighted && ct->pd_weight), integ->comm, PETSC_ERR_SUP, "-msim_contact_pd_refactor with %s is not supported: it says when the barrier's weights in PD's matrix are refactored, and this run puts none there (they are in PD's steps, -snes_type pd or -npc_snes_type pd, and with -msim_contact_pc_pd_weight in Newton's PD preconditioner; -msim_contact_pd_weight 1)", where);
  PetscCheck(!set[2] || (pd_steps && ct->pd_weight && ct->pd_refactor > 0), integ->comm, PETSC_ERR_SUP, "-msim_contact_pd_refactor_selective with %s%s is not supported: it picks the vertices whose weights PD's own steps (-snes_type pd or -npc_snes_type pd) refresh at a refactorization, with -msim_contact_pd_weight 1 and -msim_contact_pd_refactor > 0", pd_steps ? where : types, pd_steps && ct->pd_weight ? " -msim_contact_pd_refactor 0" : "");
  PetscCheck(!set[3] || pd_steps, integ->comm, PETSC_ERR_SUP, "-msim_contact_pd_bound with %s is not supported: it sets how PD's global step (-snes_type pd or -npc_snes_type pd) takes its length, and this run takes no PD step", types);
  PetscCheck(!set[5] || (hessian && (ie->imp->psd || projected)), integ->comm, PETSC_ERR_SUP, "-msim_contact_psd_curvature with %s%s is not supported: it clamps the barrier's curvature in the PSD-projected Hessian (-msim_psd 1, or -msim_psd_fallback's projected direction), and this run assembles none", types, hessian ? " -msim_psd 0" : "");
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* msim's options that only some solvers read, refused in one line naming the option and the
   SNES's type where the user set them and the run would go on without them (-msim_psd and
   -msim_pc_pd with pd: the same steps as without). Read after the SNES is set up (SetUpJacobian,
   SetUpInertia); -msim_step_atol and -msim_inertia_correction are refused where they are read,
   the types' own options (-snes_pd_*, -snes_ntr_*, -snes_qn_*) by MSimSNESCheckServed. A
   nonlinear preconditioner assembles no Hessian and solves nothing with the PD factor (one that
   would solve linear systems is refused by MSimSNESCheckServed): only the SNES's own type counts. */
static PetscErrorCode RefuseUnread(MSimIntegrator integ, ImplicitData *ie)
{
  PetscBool uses, shell = PETSC_FALSE, newton, ls_shell = PETSC_FALSE;
  char      types[128];

  PetscFunctionBeginUser;
  PetscCall(SNESTypes(ie->snes, types, sizeof(types)));
  PetscCall(MSimSNESUsesJacobian(ie->snes, &uses));
  if (ie->J) PetscCall(PetscObjectTypeCompare((PetscObject)ie->J, MATSHELL, &shell));
  const PetscBool hessian = (PetscBool)(ie->J && !shell); /* the springs' Hessian assembled (not L-BFGS's constant PD matrix) */
  PetscCheck(!ie->pc_pd_set || uses, integ->comm, PETSC_ERR_SUP, "-msim_pc_pd with %s is not supported: it preconditions the SNES's linear solves, and this one solves none (newtonls, ntr, ksponly, the VI types and qn with -snes_qn_scale_type jacobian do)", types);
  /* a discrete gradient's Jacobian is the terms' exact discrete_jacobian, which nothing projects */
  PetscCheck(!ie->psd_set || !ie->imp->scheme->no_objective, integ->comm, PETSC_ERR_SUP, "-msim_psd with -msim_integrator %s is not supported: it projects the blocks of Phi's Hessian, and %s", integ->type, ie->imp->scheme->no_objective);
  PetscCheck(!ie->psd_set || hessian, integ->comm, PETSC_ERR_SUP, "-msim_psd with %s is not supported: it projects the Hessian's blocks, and this SNES assembles none (%s)", types,
             uses ? "qn's Jacobian is the constant PD matrix unless a -pc_type is given" : "newtonls, ntr, ksponly, the VI types and qn with -snes_qn_scale_type jacobian and a -pc_type do");
  PetscCall(PetscObjectTypeCompare((PetscObject)ie->snes, SNESNEWTONLS, &newton));
  if (newton) {
    SNESLineSearch ls;
    PetscCall(SNESGetLineSearch(ie->snes, &ls));
    PetscCall(PetscObjectTypeCompare((PetscObject)ls, SNESLINESEARCHSHELL, &ls_shell));
  }
  PetscCheck(!ie->psd_fallback_set || (newton && ls_shell && hessian && !ie->imp->psd && !ie->inertia_correction), integ->comm, PETSC_ERR_SUP,
             "-msim_psd_fallback with %s%s is not supported: it replaces the exact Hessian's Newton direction in msim's line search, which needs -snes_type newtonls, -msim_psd 0, no -snes_linesearch_type and no -msim_inertia_correction", types, ie->imp->psd ? " and -msim_psd 1" : "");
  PetscCheck(!ie->check_saddle_set || ie->exact_mumps, integ->comm, PETSC_ERR_SUP, "-msim_check_saddle with %s is not supported here: it reads the inertia of Newton's factor of the exact Hessian, which needs -snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps", types);
  PetscCall(RefuseUnreadContact(integ, ie, types, hessian, (PetscBool)(newton && ls_shell && ie->ls.descent)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Setup_Implicit(MSimIntegrator integ)
{
  ImplicitData *ie  = (ImplicitData *)integ->data;
  MSimSystem    sys = integ->sys;
  KSP           ksp;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitCreateWithScheme(sys, integ->type, &ie->imp));
  PetscCall(MSimImplicitCheckTermsCoverScene(ie->imp));
  ie->imp->h = integ->dt;
  if (!integ->help_listing) {
    /* the barrier's stiffness kappa (its default needs beta h^2) now rather than at the first
       step: the step-0 monitor row and frame 0 report the force of a start within dhat of an
       obstacle, which the run applies from its first step (they showed 0, then the force). Not
       for -help's listing, whose scheme's beta is not the run's. */
    MSimContact ct;
    PetscCall(MSimImplicitStepUpdate(ie->imp));
    PetscCall(MSimContactGetForStep(sys, ie->imp->step.h2, &ct));
  }
  PetscCall(ReadOptions(integ, ie));
  if (ie->imp->scheme->no_objective) ie->check_saddle = PETSC_FALSE; /* saddles of a Phi it has not */
  PetscCall(CreateSNES(integ, ie, &ksp));
  ie->step_gtol = PETSC_MAX_REAL; /* -msim_step_atol's force condition, with a barrier only (ConvergedStep) */
  for (PetscInt k = 0; k < ie->imp->nterms; k++)
    if (ie->imp->terms[k]->ops.max_step && ie->step_atol > 0) {
      PetscScalar m3;
      PetscCall(VecSum(sys->mass, &m3)); /* the free dofs' masses, 3 per vertex */
      ie->step_gtol = PetscRealPart(m3) / 3 * ie->step_atol;
      break;
    }
  PetscCall(SetUpGAMGSmoothers(ie, sys, ksp));
  PetscCall(SetUpJacobian(integ, ie, sys, ksp));
  PetscCall(MSimSNESSetUpPD(ie->snes));
  PetscCall(SetUpInertia(ie, sys->size));
  if (ie->inertia_correction) {
    PetscCheck(ie->inertia, integ->comm, PETSC_ERR_ARG_INCOMP, "-msim_inertia_correction needs Newton on the exact Hessian factored by MUMPS: -snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps (and, in parallel, -mat_mumps_icntl_13 1)");
    PetscCall(SNESSetJacobian(ie->snes, ie->J, ie->J, FormJacobianInertiaCorrected, ie));
  }
  PetscCall(RefuseUnread(integ, ie));
  PetscCall(MSimStopSignalSetSNES(ie->snes)); /* last: it wraps the convergence test set above */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* After a converged Newton solve: one more factorization, of the exact Hessian at the solution X
   (Newton's last one was at the iterate before, which after one or two iterations can still be
   far: a chain compressed further by gravity turned indefinite only at the solution). */
static PetscErrorCode CountSaddle(MSimIntegrator integ, ImplicitData *ie, Vec X)
{
  KSP      ksp;
  PetscInt its, nneg;

  PetscFunctionBeginUser;
  PetscCall(SNESGetIterationNumber(ie->snes, &its));
  if (!ie->inertia || !ie->check_saddle || its == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimImplicitJacobian(ie->imp, X, ie->J));
  PetscCall(SNESGetKSP(ie->snes, &ksp));
  PetscCall(MSimImplicitFactorInertia(ksp, ie->J, &nneg));
  if (nneg > 0) {
    integ->saddle_steps++;
    integ->saddle_negative = PetscMax(integ->saddle_negative, nneg);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A solve that ended on the step-length test (-snes_stol |x|, SNES_CONVERGED_SNORM_RELATIVE)
   while |g| is still above max(-snes_atol, -snes_rtol |g0|), and whose last step was cut short
   (line search lambda < 1), did not converge: the step is short because a contact barrier's
   largest feasible step (self-contact's CCD, an obstacle's) or the backtracking cut it, not because
   Newton's step was. A surface whose elements start crossing or touching (locked by the barrier)
   ended every step so after one iteration, |g| frozen at 0.77 of |g0| and the cloth at rest
   (examples/cloth_fold.opts at 41 x 41), counted as converged. -msim_step_atol's rule is the
   user's: a step it accepted (the Newton step asked for below it) is not a stall.
   The cut is the search's lambda for msim's energy search, which asks max_step itself; PETSc's
   searches (bt, l2, cp) get Newton's direction already cut by the pre-check
   (LineSearchPreCheckMaxStep), and their lambda is of the cut direction: bt ends on -snes_stol
   with lambda = 1 when the cut direction is below -snes_stol |x|, so the locked cloth's steps
   passed as converged with bt until the pre-check's cut was counted here too.
   atol and rtol: the tolerances the last solve ran to (a friction lag's solve has its own atol). */
static PetscErrorCode StepStalled(ImplicitData *ie, SNESConvergedReason reason, PetscReal residual, PetscReal atol, PetscReal rtol, PetscBool *stalled, PetscReal *lambda, PetscReal *target)
{
  SNESLineSearch   ls;
  const PetscReal *hist;
  PetscInt         nhist;

  PetscFunctionBeginUser;
  *stalled = PETSC_FALSE;
  *lambda  = 1;
  *target  = 0;
  if (reason != SNES_CONVERGED_SNORM_RELATIVE) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESGetConvergenceHistory(ie->snes, (PetscReal **)&hist, NULL, &nhist));
  *target = PetscMax(atol, nhist > 0 ? rtol * hist[0] : 0.0);
  if (!(residual > *target)) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESGetLineSearch(ie->snes, &ls));
  PetscCall(SNESLineSearchGetLambda(ls, lambda));
  *lambda *= ie->ls_cut;
  if (!(*lambda < 1)) PetscFunctionReturn(PETSC_SUCCESS);
  if (ie->step_atol > 0) { /* the rule judges the step asked for: the search's direction before the pre-check's cut */
    Vec       Y;
    PetscReal ynorm;
    PetscCall(SNESGetSolutionUpdate(ie->snes, &Y));
    PetscCall(VecNorm(Y, NORM_2, &ynorm));
    if (ynorm < ie->step_atol * ie->ls_cut) PetscFunctionReturn(PETSC_SUCCESS);
  }
  *stalled = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The energy (J) the barrier terms (those with a max_step: obstacles, self-contact, the volume
   term's) hold at X: their part of Phi over the step's h2 (beta h^2), the weight Phi gives a
   potential. A touching mesh started 0.1 m from a triangle with dhat = 0.2 m (tests/self_contact_
   start_rest.py) held 1254 J there against a scene energy of 0.70 J: the first step released it
   as kinetic energy, and the divergence check, which did not count it, stopped the run as
   "diverged" at step 1 (run.cpp now counts it in the start's energy E0 and the scale). Sets
   integ's barrier_energy0, and the obstacles' part with where they hold it for run.cpp's warning. */
static PetscErrorCode BarrierEnergy(MSimIntegrator integ, PetscReal t, Vec X)
{
  ImplicitData *ie  = (ImplicitData *)integ->data;
  MSimImplicit  imp = ie->imp;
  PetscReal     phi = 0;

  PetscFunctionBeginUser;
  integ->barrier_energy0 = integ->barrier_obstacles0 = 0;
  if (imp->scheme->no_objective || !(imp->step.h2 > 0)) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt k = 0; k < imp->nterms; k++) {
    PetscReal before = phi;
    PetscBool obstacles;
    if (!imp->terms[k]->ops.max_step || !imp->terms[k]->ops.energy || imp->terms[k]->in_potential) continue;
    PetscCall(imp->terms[k]->ops.energy(imp->terms[k], X, &phi)); /* summed over the ranks */
    PetscCall(PetscStrcmp(imp->terms[k]->type, "obstacles", &obstacles));
    if (obstacles) integ->barrier_obstacles0 = (phi - before) / imp->step.h2;
  }
  integ->barrier_energy0 = phi / imp->step.h2;
  if (integ->barrier_obstacles0 > 0) { /* which obstacles hold it, so that the warning can say where */
    MSimContact                ct;
    const PetscScalar         *x;
    std::vector<PetscReal>     dmin;
    std::vector<PetscInt>      count;
    size_t                     len = 0;
    PetscCall(MSimContactGetForStep(imp->sys, imp->step.h2, &ct));
    dmin.assign(ct->obs.size(), PETSC_MAX_REAL);
    count.assign(ct->obs.size(), 0);
    PetscCall(VecGetArrayRead(X, &x));
    std::vector<PetscInt> last(ct->obs.size(), -1); /* a vertex in a mesh's creases has several contacts: counted once */
    MSimContactForEachNear(ct, imp->sys->nown, x, t, ct->dhat, PETSC_FALSE, [&](PetscInt v, const MSimObstacle &o, PetscReal d, const PetscReal *, const PetscReal *) {
      const size_t k = (size_t)(&o - ct->obs.data());
      if (last[k] != v) count[k]++, last[k] = v;
      dmin[k] = PetscMin(dmin[k], d);
    });
    PetscCall(VecRestoreArrayRead(X, &x));
    PetscCall(MPIU_Allreduce(MPI_IN_PLACE, count.data(), (PetscMPIInt)count.size(), MPIU_INT, MPI_SUM, integ->comm));
    PetscCall(MPIU_Allreduce(MPI_IN_PLACE, dmin.data(), (PetscMPIInt)dmin.size(), MPIU_REAL, MPIU_MIN, integ->comm));
    integ->barrier_dhat0    = ct->dhat;
    integ->barrier_near0[0] = 0;
    for (size_t k = 0; k < ct->obs.size(); k++)
      if (count[k]) {
        PetscCall(PetscSNPrintf(integ->barrier_near0 + len, sizeof(integ->barrier_near0) - len, "%sobstacle %d: %" PetscInt_FMT " vertices within it, the nearest at %g m", len ? "; " : "", (int)k, count[k], (double)dmin[k]));
        PetscCall(PetscStrlen(integ->barrier_near0, &len));
      }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Step_Implicit(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  ImplicitData       *ie = (ImplicitData *)integ->data;
  SNESConvergedReason reason;
  PetscInt            its, lits;
  SNESType            type;
  Vec                 F;

  PetscFunctionBeginUser;
  if (integ->step == integ->first_step && integ->first_step > 1 && ie->imp->scheme->nhistory > 0 && !ie->history_loaded)
    /* the checkpoint's history is another integrator's, or has another count: GetHistory_Implicit
       adds v_{n-1} with some guesses. bdf2 restarted from a constant_velocity checkpoint with
       -msim_implicit_guess extrapolate took its start-up step again without a word and ended
       3e-4 m off the uninterrupted run 10 steps later (solved to |g| < 1e-12) */
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: -msim_restart: the checkpoint holds no %s history this run can take (another integrator wrote it, or another -msim_implicit_guess, which changes what a checkpoint carries), so %s starts as at step 1 (BDF2's start-up step, Newmark's acceleration from the force) and the run does not repeat the uninterrupted one\n", integ->type, integ->type));
  PetscCall(MSimImplicitBeginStep(ie->imp, t, integ->dt, X, V));
  if (ie->conv) PetscCall(MSimConvergenceMonitorBeginStep(ie->conv, integ->step, integ->first_step));
  if (ie->bounds) PetscCall(MSimContactBoundsBeginStep(ie->bounds, X)); /* from x_n */
  if (integ->step == 1) PetscCall(BarrierEnergy(integ, t, X)); /* at x_0, after BeginStep set the barriers up; a restart has it in its E0 */
  PetscCall(MSimImplicitGuess(ie->imp, V, X));
  if (ie->imp->refused[0]) { /* no feasible start (a term's feasible_start said why): nothing to solve */
    integ->failed      = PETSC_TRUE;
    integ->failed_what = ie->imp->refused;
    integ->failure[0]  = 0;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* the step's solve, again from its result while a term's lag asks for it (friction's lag
     iterations: its normal forces taken at the result); what follows reads the last solve, and
     the iteration counts are the solves' sums. A lag's solve starts next to the step's solution,
     at a |g0| that is only the lag's change: it is converged to the first solve's tolerance,
     max(atol, rtol |g0|) of the step's own start, not to rtol of its own small |g0|, which asks
     for more digits than the step has. The user's tolerances are back after the last solve: the
     messages below and the roundoff rule name and use them, the stall test is given atol_solve */
  PetscReal atol0, rtol0, stol0, atol_solve;
  PetscInt  maxit0, maxf0, solves = 0;
  PetscCall(SNESGetTolerances(ie->snes, &atol0, &rtol0, &stol0, &maxit0, &maxf0));
  atol_solve = atol0;
  integ->nonlinear_its = integ->linear_its = 0;
  for (PetscBool again = PETSC_TRUE; again; solves++) {
    ie->ls_cut = 1;
    PetscCall(SNESSolve(ie->snes, NULL, X));
    if (MSimStopSignalAgreedInStep()) {
      /* a stop signal inside the step: the step is taken back to its start, x_n (V still holds
         v_n and the scheme's history is the step before's until EndStep), and the time loop keeps
         that state. What the terms and the solver carry changed in the step (PD's contact
         weights, L-BFGS's pairs) is kept as it is, so a restart repeats this step to the solver's
         tolerance, not bit for bit */
      PetscCall(VecCopy(ie->imp->Xn, X));
      if (atol_solve != atol0) PetscCall(SNESSetTolerances(ie->snes, atol0, rtol0, stol0, maxit0, maxf0));
      integ->stopped = PETSC_TRUE;
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(SNESGetConvergedReason(ie->snes, &reason));
    PetscCall(SNESGetIterationNumber(ie->snes, &its));
    PetscCall(SNESGetLinearSolveIterations(ie->snes, &lits));
    integ->nonlinear_its += its;
    integ->linear_its += lits;
    again = PETSC_FALSE;
    if (reason > 0 || reason == SNES_DIVERGED_MAX_IT) /* not from a failed solve's result */
      for (PetscInt k = 0; k < ie->imp->nterms; k++)
        if (ie->imp->terms[k]->ops.lag) PetscCall(ie->imp->terms[k]->ops.lag(ie->imp->terms[k], X, &again));
    if (again && solves == 0) {
      const PetscReal *hist;
      PetscInt         nhist;
      PetscCall(SNESGetConvergenceHistory(ie->snes, (PetscReal **)&hist, NULL, &nhist));
      if (nhist > 0) {
        atol_solve = PetscMax(atol0, rtol0 * hist[0]);
        PetscCall(SNESSetTolerances(ie->snes, atol_solve, rtol0, stol0, maxit0, maxf0));
      }
    }
    /* Phi at X changed with the lag: what solvers keep for X's state (PD's Phi) is stale */
    if (again) PetscCall(PetscObjectStateIncrease((PetscObject)X));
  }
  if (atol_solve != atol0) PetscCall(SNESSetTolerances(ie->snes, atol0, rtol0, stol0, maxit0, maxf0));
  PetscCall(SNESGetType(ie->snes, &type));
  /* plus the Krylov iterations of PD's global steps (iterative -pd_ksp_type only), which no SNES
     counts, also where pd runs as another SNES's nonlinear preconditioner */
  integ->linear_its += ie->imp->pd_lits;
  if (reason == SNES_CONVERGED_ITS && ie->imp->scheme->no_objective && !ie->linearised_noted) {
    /* a scheme whose step is a residual's root, not Phi's minimizer (discrete_gradient), stopped
       after a fixed count (ksponly's one linear solve) is a linearised scheme, as ts says of its
       implicit types: its energy is kept only to what the step leaves in the residual (the
       scheme's balance moves it by (2/h) v_m . r a step). For the schemes that minimize Phi,
       one Newton step is Baraff-Witkin's method, as documented */
    ie->linearised_noted = PETSC_TRUE;
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: note: -snes_type %s with -msim_integrator %s stops each step after a fixed count (a linearised scheme), not at -snes_atol/-snes_rtol: the monitor's residual is |r| where it stopped, and the energy is kept only to what that residual leaves\n", type, integ->type));
  }
  /* the types that stop after a fixed count (ksponly, fixed-count pd) do not evaluate g at their
     result: do it here for the monitor */
  PetscCall(SNESGetFunction(ie->snes, &F, NULL, NULL));
  if (reason == SNES_CONVERGED_ITS) PetscCall(SNESComputeFunction(ie->snes, X, F));
  if (ie->bounds) {
    PetscBool moved;
    PetscCall(MSimContactBoundsProject(ie->bounds, X, &moved));
    if (moved) PetscCall(SNESComputeFunction(ie->snes, X, F));
  }
  PetscCall(VecNorm(F, NORM_2, &integ->residual));
  if (ie->bounds) PetscCall(MSimContactBoundsEndStep(ie->bounds, X, F, ie->imp->step.h2, &integ->residual)); /* reactions; |g| off the active bounds */
  {
    PetscBool stalled;
    PetscReal lambda, target;
    PetscCall(StepStalled(ie, reason, integ->residual, atol_solve, rtol0, &stalled, &lambda, &target));
    if (stalled) {
      integ->stalled_steps++;
      PetscCall(PetscSNPrintf(integ->stall, sizeof(integ->stall), "step %" PetscInt_FMT " ended on -snes_stol with its step cut to %g of Newton's (a contact barrier's largest feasible step, or backtracking) at |g| = %g > its tolerance %g: elements locked against each other (crossing or touching at the start?)", integ->step, (double)lambda, (double)integ->residual, (double)target));
    } else if (reason > 0) PetscCall(CountSaddle(integ, ie, X)); /* a stalled step did not converge, to a saddle or otherwise */
  }
  if (integ->want_phi && ie->imp->scheme->no_objective) integ->phi = NAN; /* the monitor's phi: none */
  else if (integ->want_phi) PetscCall(MSimImplicitObjective(ie->imp, X, &integ->phi));
  if (reason == SNES_DIVERGED_LINE_SEARCH && integ->residual <= 10 * atol0) {
    /* within a decade of -snes_atol Phi's decrease along any direction is below its roundoff
       (|g|^2 / |H| against eps |Phi|), so no line search can accept a step: the iterate is as
       converged as this precision allows. Counted with the steps that stopped short, not failed. */
    integ->unconverged_steps++;
    PetscCall(PetscSNPrintf(integ->tolerance, sizeof(integ->tolerance), "-snes_type %s: the line search found no decrease at |g| = %g, within 10 x -snes_atol %g (roundoff; raise -snes_max_it, or for a fixed count set -snes_rtol 0 -snes_atol 0, or -snes_pd_fixed with pd)", type, (double)integ->residual, (double)atol0));
  }
  else if (reason == SNES_DIVERGED_MAX_IT) {
    if (atol0 > 0 || rtol0 > 0 || ie->step_atol > 0) {
      integ->unconverged_steps++;
      char step_rule[96] = "";
      if (ie->step_atol > 0 && ie->step_gtol < PETSC_MAX_REAL) PetscCall(PetscSNPrintf(step_rule, sizeof(step_rule), " or |dx| < %g with |g| <= %g", (double)ie->step_atol, (double)ie->step_gtol));
      else if (ie->step_atol > 0) PetscCall(PetscSNPrintf(step_rule, sizeof(step_rule), " or |dx| < %g", (double)ie->step_atol));
      if (atol0 > 0 || rtol0 > 0) PetscCall(PetscSNPrintf(integ->tolerance, sizeof(integ->tolerance), "-snes_type %s stopped at -snes_max_it %" PetscInt_FMT " before |g| <= max(%g, %g |g0|)%s (raise -snes_max_it; for a fixed count set -snes_rtol 0 -snes_atol 0, or -snes_pd_fixed with pd)", type, maxit0, (double)atol0, (double)rtol0, step_rule));
      else /* -snes_rtol 0 -snes_atol 0 already: the step rule alone ends a solve before the count */
        PetscCall(PetscSNPrintf(integ->tolerance, sizeof(integ->tolerance), "-snes_type %s stopped at -snes_max_it %" PetscInt_FMT " before%s (raise -snes_max_it or -msim_step_atol)", type, maxit0, step_rule + 3));
    }
  }
  else if (reason < 0) {
    integ->failed = PETSC_TRUE;
    /* a PETSc search (bt) that failed on a direction the pre-check had cut: the stall above, but
       on a cut direction still longer than -snes_stol |x| */
    if (reason == SNES_DIVERGED_LINE_SEARCH && ie->ls_cut < 1) PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-snes_type %s: %s on a direction cut to %g of Newton's by a contact barrier's largest feasible step: elements locked against each other, crossing or touching at the start?)", type, SNESConvergedReasons[reason], (double)ie->ls_cut));
    else PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-snes_type %s: %s)", type, SNESConvergedReasons[reason]));
  }
  if (PetscIsInfOrNanReal(integ->residual)) integ->failed = PETSC_TRUE;
  if (!integ->failed && ie->imp->sys->tets.ntet && ie->imp->sys->tets.kappa > 0) {
    /* the inversion barrier's promise, whatever the solver: its feasible set is kept by the
       searches that ask max_step (PD's global step, the energy line search, ntr), not by every
       SNES type (ksponly, PETSc's qn or ngmres take whole steps); a result with an inverted tet
       fails the step instead of being written */
    PetscInt bad;
    PetscCall(MSimSystemVolumeCountInverted(ie->imp->sys, ie->imp->step.tx, X, &bad));
    if (bad) {
      integ->failed = PETSC_TRUE;
      PetscCall(PetscSNPrintf(integ->failure, sizeof(integ->failure), " (-snes_type %s: its result has %" PetscInt_FMT " inverted tet(s), where the inversion barrier of -msim_volume is infinite: a solver that keeps its feasible set, e.g. newtonls or pd)", type, bad));
    }
  }
  PetscCall(MSimImplicitEndStep(ie->imp, X, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_Implicit(MSimIntegrator integ, PetscViewer viewer)
{
  ImplicitData *ie = (ImplicitData *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(PetscViewerASCIIPrintf(viewer, "steps whose solve stopped before its tolerance (-snes_max_it, or a line search stalled at roundoff): %" PetscInt_FMT "\n", integ->unconverged_steps));
  if (ie->inertia_correction) PetscCall(PetscViewerASCIIPrintf(viewer, "inertia correction: %" PetscInt_FMT " Newton iterations factored H + delta M (delta up to %g), %" PetscInt_FMT " factorizations beyond one per iteration\n", ie->ic.shifted, (double)ie->ic.delta_max, ie->ic.extra));
  if (ie->inertia && ie->check_saddle) PetscCall(PetscViewerASCIIPrintf(viewer, "steps converged to a saddle point of Phi (negative pivots in the exact Hessian's LDL^T): %" PetscInt_FMT ", at most %" PetscInt_FMT " negative eigenvalues\n", integ->saddle_steps, integ->saddle_negative));
  if (ie->ls.descent) PetscCall(PetscViewerASCIIPrintf(viewer, "Newton directions of the exact Hessian replaced by the PSD-projected Hessian's: %" PetscInt_FMT "\n", ie->ls.nfallback));
  if (ie->imp) PetscCall(MSimImplicitView(ie->imp, viewer));
  if (ie->imp && ie->imp->A) {
    /* the count is of the global solve's PC set-ups, which are numeric factorizations where the
       PC factors (a multigrid's set-up, e.g. -pd_pc_type gamg, is not one) */
    PC        pc;
    PCType    type;
    PetscBool factors = PETSC_TRUE;
    if (ie->imp->pdksp) {
      PetscCall(KSPGetPC(ie->imp->pdksp, &pc));
      PetscCall(PCGetType(pc, &type));
      PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &factors, PCLU, PCCHOLESKY, PCILU, PCICC, "msimllt", PCBJACOBI, PCASM, ""));
    }
    if (factors) PetscCall(PetscViewerASCIIPrintf(viewer, "projective dynamics: %" PetscInt_FMT " numeric factorization(s) of the %" PetscInt_FMT " x %" PetscInt_FMT " PD matrix\n", ie->imp->nfactor, ie->imp->sys->nfree, ie->imp->sys->nfree));
    else PetscCall(PetscViewerASCIIPrintf(viewer, "projective dynamics: %" PetscInt_FMT " set-up(s) of the global solve's -pd_pc_type %s on the %" PetscInt_FMT " x %" PetscInt_FMT " PD matrix (no factorization)\n", ie->imp->nfactor, type, ie->imp->sys->nfree, ie->imp->sys->nfree));
  }
  if (ie->snes) PetscCall(SNESView(ie->snes, viewer));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Implicit(MSimIntegrator integ)
{
  ImplicitData *ie = (ImplicitData *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimDestroy(&ie->snes, &ie->J, &ie->G, &ie->vi_step));
  PetscCall(MSimImplicitDestroy(&ie->imp));
  PetscCall(MSimConvergenceMonitorDestroy(&ie->conv));
  PetscCall(MSimContactBoundsDestroy(&ie->bounds));
  PetscCall(PetscFree(integ->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SetFromOptions_Implicit(MSimIntegrator integ)
{
  ImplicitData *ie = (ImplicitData *)integ->data;
  PetscFunctionBeginUser;
  PetscCall(MSimConvergenceMonitorCreate(integ->sys, &ie->conv));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode OpenFiles_Implicit(MSimIntegrator integ)
{
  ImplicitData *ie = (ImplicitData *)integ->data;

  PetscFunctionBeginUser;
  PetscCall(MSimConvergenceMonitorOpen(ie->conv, integ->first_step));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the scheme's history, for checkpoints, then v_{n-1} where the first iterate extrapolates with
   it (-msim_implicit_guess extrapolate, filtered); a checkpoint written with the other guess has another
   count, so a restart that toggles the option starts both up afresh */
static PetscErrorCode GetHistory_Implicit(MSimIntegrator integ, PetscInt *n, Vec **history)
{
  ImplicitData      *ie     = (ImplicitData *)integ->data;
  MSimImplicitScheme scheme = ie->imp->scheme;

  PetscFunctionBeginUser;
  *n = 0;
  for (PetscInt k = 0; k < scheme->nhistory; k++) ie->history[(*n)++] = scheme->work[k];
  if (ie->imp->Vprev) ie->history[(*n)++] = ie->imp->Vprev;
  for (PetscInt k = 0, nt = 0; k < ie->imp->nterms; k++) {
    MSimImplicitTerm term = ie->imp->terms[k];
    if (!term->ops.get_history) continue;
    PetscCheck(nt++ < MSIM_MAX_TERM_HISTORY, PETSC_COMM_SELF, PETSC_ERR_PLIB, "more than %d terms with history", MSIM_MAX_TERM_HISTORY);
    PetscCall(term->ops.get_history(term, &ie->history[(*n)++]));
  }
  *history = *n ? ie->history : NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode HistoryLoaded_Implicit(MSimIntegrator integ)
{
  ImplicitData *ie = (ImplicitData *)integ->data;

  PetscFunctionBeginUser;
  ie->history_loaded             = PETSC_TRUE;
  ie->imp->scheme->history_valid = PETSC_TRUE;
  if (ie->imp->scheme->history_at_h && integ->restart_dt != integ->dt) { /* BDF2's x_{n-1}, v_{n-1} are one old step back */
    ie->imp->scheme->history_valid = PETSC_FALSE;
    PetscCall(PetscFPrintf(integ->comm, PETSC_STDERR, "msim: warning: -msim_restart with -msim_dt %g, the checkpoint's %g: %s's history is one step of the checkpoint's back, so it starts up again (one first-order step) at the new step\n", (double)integ->dt, (double)integ->restart_dt, integ->type));
  }
  if (ie->imp->Vprev) ie->imp->vprev_valid = PETSC_TRUE;
  for (PetscInt k = 0; k < ie->imp->nterms; k++)
    if (ie->imp->terms[k]->ops.history_loaded) PetscCall(ie->imp->terms[k]->ops.history_loaded(ie->imp->terms[k]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Each registered scheme is an integrator of the same name (-msim_integrator lists them). */
PetscErrorCode MSimIntegratorRegisterImplicit(void)
{
  const char **names;
  PetscInt     n;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitSchemeGetNames(&names, &n));
  for (PetscInt k = 0; k < n; k++) PetscCall(MSimIntegratorRegister(names[k], MSimIntegratorCreate_Implicit));
  PetscCall(PetscFree(names));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode CheckStart_Implicit(MSimIntegrator integ, PetscReal t, Vec X, const char *restart)
{
  ImplicitData *ie = (ImplicitData *)integ->data;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitCheckStart(ie->imp, t, X, restart));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimIntegratorOps ImplicitOps = {.setfromoptions = SetFromOptions_Implicit, .setup = Setup_Implicit, .step = Step_Implicit, .view = View_Implicit,
                                              .openfiles = OpenFiles_Implicit, .get_history = GetHistory_Implicit, .history_loaded = HistoryLoaded_Implicit, .check_start = CheckStart_Implicit, .destroy = Destroy_Implicit};

PetscErrorCode MSimIntegratorCreate_Implicit(MSimIntegrator integ)
{
  ImplicitData *ie;
  PetscFunctionBeginUser;
  PetscCall(PetscNew(&ie));
  ie->psd_fallback = PETSC_TRUE;
  ie->check_saddle = PETSC_TRUE;
  integ->data      = ie;
  integ->ops       = ImplicitOps;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitEulerGetProjectedFallbacks(MSimIntegrator integ, PetscInt *n)
{
  ImplicitData *ie = (ImplicitData *)integ->data;
  PetscFunctionBeginUser;
  *n = ie->ls.nfallback;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitEulerGetFactorizations(MSimIntegrator integ, PetscInt *n)
{
  ImplicitData *ie = (ImplicitData *)integ->data;
  PetscFunctionBeginUser;
  *n = ie->imp ? ie->imp->nfactor : 0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitEulerGetSNES(MSimIntegrator integ, SNES *snes)
{
  ImplicitData *ie = (ImplicitData *)integ->data;
  PetscFunctionBeginUser;
  *snes = ie->snes;
  PetscFunctionReturn(PETSC_SUCCESS);
}
