/* The implicit problem (msim/implicit.h): Phi, g and the Hessian as the inertia term plus the
   registered energy terms; the scheme's y, x_n and velocity update. */
#include <msim/implicit.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/destroy.h>

PetscErrorCode MSimImplicitCreate(MSimSystem sys, MSimImplicit *imp)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitCreateWithScheme(sys, NULL, imp));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitDestroy(MSimImplicit *imp)
{
  PetscFunctionBeginUser;
  if (!*imp) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt k = 0; k < (*imp)->nterms; k++) {
    MSimImplicitTerm term = (*imp)->terms[k];
    if (term->ops.destroy) PetscCall(term->ops.destroy(term));
    delete term;
  }
  if ((*imp)->scheme) {
    if ((*imp)->scheme->ops.destroy) PetscCall((*imp)->scheme->ops.destroy((*imp)->scheme));
    for (PetscInt k = 0; k < (*imp)->scheme->nwork; k++) PetscCall(VecDestroy(&(*imp)->scheme->work[k]));
    delete (*imp)->scheme;
  }
  PetscCall(MSimDestroy(&(*imp)->Vprev, &(*imp)->Vstar, &(*imp)->Vwork, &(*imp)->guess_a, &(*imp)->guess_d));
  PetscCall(MSimDestroy(&(*imp)->Xn, &(*imp)->Y, &(*imp)->rhs, &(*imp)->A, &(*imp)->A3, &(*imp)->B, &(*imp)->Xd, &(*imp)->pdb, &(*imp)->pdx, &(*imp)->pdksp));
  PetscCall(MSimDestroy(&(*imp)->pd_px, &(*imp)->pd_x0, &(*imp)->pd_d));
  delete *imp;
  *imp = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitView(MSimImplicit imp, PetscViewer viewer)
{
  char terms[512] = "";

  PetscFunctionBeginUser;
  /* the terms that act: every registered term is in the problem, and one its scene does not use
     (no obstacle, no self-contact, no drag) set no op, or a diagonal of weight 0 (listed all,
     bunny_drop's view named drag and self-contact it has not) */
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm term = imp->terms[k];
    PetscBool        acts = (PetscBool)(term->ops.energy || term->ops.gradient);
    if (!acts && term->ops.diagonal) {
      PetscReal w;
      Vec       c;
      PetscCall(term->ops.diagonal(term, &w, &c));
      acts = (PetscBool)(w != 0);
    }
    if (!acts) continue;
    if (terms[0]) PetscCall(PetscStrlcat(terms, ", ", sizeof(terms)));
    PetscCall(PetscStrlcat(terms, term->type, sizeof(terms)));
  }
  PetscCall(PetscViewerASCIIPrintf(viewer, "implicit problem: scheme %s (beta %g), energy terms: %s\n", imp->scheme->type, (double)imp->scheme->beta, terms));
  if (imp->pdksp) { /* PD's global solve, chosen by the scene's size unless -pd_ksp_type / -pd_pc_type say */
    KSPType        ktype;
    PCType         ptype;
    MatSolverType  stype = NULL;
    PC             pc;
    PetscBool      factor;
    PetscCall(KSPGetType(imp->pdksp, &ktype));
    PetscCall(KSPGetPC(imp->pdksp, &pc));
    PetscCall(PCGetType(pc, &ptype));
    PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &factor, PCCHOLESKY, PCLU, ""));
    if (factor) PetscCall(PCFactorGetMatSolverType(pc, &stype));
    PetscCall(PetscViewerASCIIPrintf(viewer, "projective dynamics' global solve: -pd_ksp_type %s -pd_pc_type %s%s%s\n", ktype, ptype, stype ? " -pd_pc_factor_mat_solver_type " : "", stype ? stype : ""));
  }
  if (imp->scheme->ops.view) PetscCall(imp->scheme->ops.view(imp->scheme, viewer));
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.view) PetscCall(imp->terms[k]->ops.view(imp->terms[k], viewer));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSetPSD(MSimImplicit imp, PetscBool psd)
{
  PetscFunctionBeginUser;
  imp->psd = psd;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitGetNumTerms(MSimImplicit imp, PetscInt *n)
{
  PetscFunctionBeginUser;
  *n = imp->nterms;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitGetStepState(MSimImplicit imp, Vec *Xn, Vec *Y)
{
  PetscFunctionBeginUser;
  if (Xn) *Xn = imp->Xn;
  if (Y) *Y = imp->Y;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitStepUpdate(MSimImplicit imp)
{
  const PetscReal h = imp->h;

  PetscFunctionBeginUser;
  imp->step.h  = h;
  imp->step.h2 = imp->scheme->beta * h * h;
  imp->step.hd = imp->scheme->gamma * h;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitBeginStep(MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCheck(!imp->A || h == imp->h, imp->sys->comm, PETSC_ERR_ARG_WRONGSTATE, "the PD matrix was built for h = %g; a new h needs a new factorization", (double)imp->h);
  imp->t       = t;
  imp->h       = h;
  imp->step.t  = t;
  imp->pd_lits = 0;
  PetscCall(MSimImplicitStepUpdate(imp));
  PetscCall(imp->scheme->ops.begin_step(imp->scheme, imp, t, h, X, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The first iterate (-msim_implicit_guess). A solver stopped after a fixed count (PD-10) keeps
   part of its first iterate's error, so the guess matters there. constant_velocity: the unknown at
   v_{n+1} = v_n (x_n + h v_n; midpoint's x_m: x_n + h/2 v_n), an O(h^2) error (beta h^2 a).
   extrapolate: the scheme's own position relation (its predict op, which derives it) at the
   linearly extrapolated end velocity W = 2 v_n - v_{n-1} = v_n + h a_n + O(h^2): an O(h^3) error
   for smooth motion, none under a constant acceleration. Where v_{n-1} is unknown (the first step,
   a restart from a checkpoint without it) W = v_n + h a_e with a_e the constant external
   acceleration (gravity, the wind's drag): that first iterate is still exact in a free fall.
   v_{n-1} is the v_n that EndStep saw, carried by checkpoints after the scheme's history, so a
   restart repeats the run bit for bit. inertial: the scheme's y (for implicit Euler x_n + h v_n +
   h^2 a_e, its first step's extrapolation). Either way a barrier's feasibility pull-back follows.
   extrapolate is unstable with PD-10 on the undamped schemes (midpoint, Newmark: the 21 x 21 and
   benchmark cloths and the beam diverged within 15-30 steps): on a single linear mode of true
   stiffness k that PD sees as l >= k, PD-k leaves r = (1 - (1 + beta h^2 k)/(1 + beta h^2 l))^10
   of the first iterate's error, and the map (x_n, v_n, v_{n-1}) -> (x_{n+1}, v_{n+1}, v_n) then
   has spectral radius up to 1.41 for midpoint, 1.23 Newmark, 1.13 implicit Euler (r about 0.6-0.8,
   beta h^2 l about 1e5: stiff modes PD converges slowly; constant_velocity: 1 for all three).
   filtered extrapolates with A^-1 M (v_n - v_{n-1}), A = M + beta h^2 L the PD matrix: a mode's
   extrapolation is scaled by 1/(1 + beta h^2 l), so smooth motion (beta h^2 l << 1) keeps its
   O(h^3) first iterate (and a rigid free fall, L 1 = 0, its exact one) while the modes PD
   converges slowly are hardly extrapolated: spectral radius 1 for implicit Euler and Newmark,
   1.012 for midpoint in the same model. It costs one PD solve a step (and the PD factor, once,
   for solvers that do not use it). */
PetscErrorCode MSimImplicitGuess(MSimImplicit imp, Vec V, Vec X)
{
  PetscBool feasible = PETSC_TRUE;

  PetscFunctionBeginUser;
  if (imp->guess_type == MSIM_GUESS_EXTRAPOLATE || imp->guess_type == MSIM_GUESS_FILTERED) {
    if (!imp->vprev_valid) { /* W = v_n + h a_e */
      PetscCall(VecCopy(V, imp->Vstar));
      PetscCall(MSimImplicitAddExternalAcceleration(imp, imp->h, imp->Vstar));
    } else if (imp->guess_type == MSIM_GUESS_EXTRAPOLATE) PetscCall(VecAXPBYPCZ(imp->Vstar, 2.0, -1.0, 0.0, V, imp->Vprev));
    else { /* W = v_n + A^-1 M (v_n - v_{n-1}) */
      PetscCall(VecWAXPY(imp->Vwork, -1.0, imp->Vprev, V));
      PetscCall(VecPointwiseMult(imp->Vwork, imp->Vwork, imp->sys->mass));
      PetscCall(MSimImplicitPDSolve(imp, imp->Vwork, NULL, imp->Vstar));
      PetscCall(VecAXPY(imp->Vstar, 1.0, V));
    }
    PetscCall(imp->scheme->ops.predict(imp->scheme, imp, V, imp->Vstar, X));
  } else if (imp->guess_type == MSIM_GUESS_INERTIAL) PetscCall(VecCopy(imp->Y, X));
  else PetscCall(VecAXPY(X, imp->scheme->guess * imp->h, V));
  /* a term with a feasible set (contact barriers) needs a first iterate inside it: the guess is
     pulled back towards x_n, which is feasible, as far as the terms' max_step says */
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.max_step) feasible = PETSC_FALSE;
  if (!feasible) { /* towards x_n, or a feasible start a term makes from it (moving obstacles) */
    PetscReal alpha;
    /* work Vecs made once, freed with imp (two VecDuplicates a step, each zeroing its array, were
       0.5 M instructions of a PD-10 step of the 101 x 101 drape on the ball); kept in imp, not
       composed on x_n, whose duplicates would carry them */
    if (!imp->guess_a) {
      PetscCall(VecDuplicate(imp->Xn, &imp->guess_a));
      PetscCall(VecDuplicate(imp->Xn, &imp->guess_d));
    }
    Vec A = imp->guess_a, D = imp->guess_d;
    PetscCall(VecCopy(imp->Xn, A));
    for (PetscInt k = 0; k < imp->nterms; k++)
      if (imp->terms[k]->ops.feasible_start) PetscCall(imp->terms[k]->ops.feasible_start(imp->terms[k], A));
    for (PetscInt k = 0; k < imp->nterms; k++) /* each vertex back on its own first (obstacles) */
      if (imp->terms[k]->ops.clamp) PetscCall(imp->terms[k]->ops.clamp(imp->terms[k], A, X));
    PetscCall(VecWAXPY(D, -1.0, X, A)); /* X = A - D */
    PetscCall(MSimImplicitMaxStep(imp, A, D, &alpha));
    if (alpha < 1) PetscCall(VecWAXPY(X, -alpha, D, A));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitEndStep(MSimImplicit imp, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  if (imp->Vprev) { /* V still holds v_n: the next step's v_{n-1} */
    PetscCall(VecCopy(V, imp->Vprev));
    imp->vprev_valid = PETSC_TRUE;
  }
  PetscCall(imp->scheme->ops.end_step(imp->scheme, imp, X, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitAddExternalAcceleration(MSimImplicit imp, PetscReal s, Vec Y)
{
  MSimSystem         sys = imp->sys;
  PetscScalar       *y;
  const PetscScalar *m;

  PetscFunctionBeginUser;
  PetscCall(VecGetArray(Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) y[i] += s * (sys->gravity[i % 3] + sys->drag * sys->wind[i % 3] / m[i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArray(Y, &y));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSetReference(MSimImplicit imp, Vec xref, PetscReal tref, PetscReal tx)
{
  PetscFunctionBeginUser;
  imp->step.xref = xref;
  imp->step.tref = tref;
  imp->step.tx   = tx;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitDiagonalWeight(MSimImplicit imp, PetscReal *w)
{
  PetscFunctionBeginUser;
  *w = 0;
  for (PetscInt k = 0; k < imp->nterms; k++) {
    PetscReal wk;
    Vec       C;
    if (!imp->terms[k]->ops.diagonal) continue;
    PetscCall(imp->terms[k]->ops.diagonal(imp->terms[k], &wk, &C));
    *w += wk;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The quadratic terms w/2 |x - c|^2 that ride on the inertia pass: the first one's (w, c) fused
   into that pass (w = 0 and c = y without one); *next is the index to continue from. */
static PetscErrorCode FirstDiagonal(MSimImplicit imp, PetscReal *w, Vec *c, PetscInt *next)
{
  PetscFunctionBeginUser;
  *w    = 0;
  *c    = imp->Y;
  *next = imp->nterms;
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.diagonal) {
      PetscCall(imp->terms[k]->ops.diagonal(imp->terms[k], w, c));
      *next = k + 1;
      break;
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* f(i, w, c) for every diagonal term after the fused one (each has its own pass) */
template <class F>
static PetscErrorCode ForEachExtraDiagonal(MSimImplicit imp, PetscInt from, F &&f)
{
  PetscFunctionBeginUser;
  for (PetscInt k = from; k < imp->nterms; k++) {
    PetscReal          w;
    Vec                C;
    const PetscScalar *c;
    if (!imp->terms[k]->ops.diagonal) continue;
    PetscCall(imp->terms[k]->ops.diagonal(imp->terms[k], &w, &C));
    PetscCall(VecGetArrayRead(C, &c));
    for (PetscInt i = 0; i < 3 * imp->sys->nown; i++) f(i, w, c);
    PetscCall(VecRestoreArrayRead(C, &c));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* g = M (x - y) + the diagonal terms w (x - c), owned rows */
static PetscErrorCode InertiaResidual(MSimImplicit imp, Vec X, Vec G)
{
  MSimSystem         sys = imp->sys;
  const PetscScalar *xg, *cg, *y, *m;
  PetscScalar       *g;
  PetscReal          w;
  Vec                C;
  PetscInt           next;

  PetscFunctionBeginUser;
  PetscCall(FirstDiagonal(imp, &w, &C, &next));
  PetscCall(VecGetArrayWrite(G, &g));
  PetscCall(VecGetArrayRead(X, &xg));
  PetscCall(VecGetArrayRead(C, &cg));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) g[i] = m[i] * (xg[i] - y[i]) + w * (xg[i] - cg[i]);
  PetscCall(ForEachExtraDiagonal(imp, next, [&](PetscInt i, PetscReal wk, const PetscScalar *c) { g[i] += wk * (xg[i] - c[i]); }));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(C, &cg));
  PetscCall(VecRestoreArrayRead(X, &xg));
  PetscCall(VecRestoreArrayWrite(G, &g));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitResidual(MSimImplicit imp, Vec X, Vec G)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Residual, X, G, 0, 0));
  PetscCall(InertiaResidual(imp, X, G));
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm term = imp->terms[k];
    if (imp->scheme->no_objective) {
      if (term->ops.discrete_gradient) PetscCall(term->ops.discrete_gradient(term, X, G));
    } else if (term->ops.gradient) PetscCall(term->ops.gradient(term, X, G));
  }
  PetscCall(PetscLogEventEnd(MSIM_Residual, X, G, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* 1/2 |x - y|_M^2 + the diagonal terms, this rank's part */
static PetscErrorCode InertiaEnergy(MSimImplicit imp, Vec X, PetscReal *e)
{
  MSimSystem         sys = imp->sys;
  const PetscScalar *xg, *cg, *y, *m;
  PetscReal          w, local = 0;
  Vec                C;
  PetscInt           next;

  PetscFunctionBeginUser;
  PetscCall(FirstDiagonal(imp, &w, &C, &next));
  PetscCall(VecGetArrayRead(X, &xg));
  PetscCall(VecGetArrayRead(C, &cg));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) local += 0.5 * m[i] * (xg[i] - y[i]) * (xg[i] - y[i]) + 0.5 * w * (xg[i] - cg[i]) * (xg[i] - cg[i]);
  PetscCall(ForEachExtraDiagonal(imp, next, [&](PetscInt i, PetscReal wk, const PetscScalar *c) { local += 0.5 * wk * (xg[i] - c[i]) * (xg[i] - c[i]); }));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(C, &cg));
  PetscCall(VecRestoreArrayRead(X, &xg));
  *e += local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitObjective(MSimImplicit imp, Vec X, PetscReal *phi)
{
  PetscReal local = 0;

  PetscFunctionBeginUser;
  PetscCheck(!imp->scheme->no_objective, imp->sys->comm, PETSC_ERR_SUP, "-msim_integrator %s has no objective to minimize: %s", imp->scheme->type, imp->scheme->no_objective);
  PetscCall(PetscLogEventBegin(MSIM_Energy, X, 0, 0, 0));
  PetscCall(InertiaEnergy(imp, X, &local));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, imp->sys->comm));
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.energy) PetscCall(imp->terms[k]->ops.energy(imp->terms[k], X, &local));
  *phi = local;
  PetscCall(PetscLogEventEnd(MSIM_Energy, X, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitJacobian(MSimImplicit imp, Vec X, Mat J)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitJacobianShifted(imp, X, 0.0, J));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* (1 + delta) M + the diagonal terms' w I + the terms' blocks: one pass of the system's assembly
   with every term's coefficients, then the terms with blocks of their own (a scheme with no
   objective: M and the diagonal terms, then each term's discrete_jacobian) */
PetscErrorCode MSimImplicitJacobianShifted(MSimImplicit imp, Vec X, PetscReal delta, Mat J)
{
  MSimMatrixCoefficients c = {imp->step.tx, X, 1.0 + delta, 0.0, 0.0, imp->psd, imp->step.tref, NULL, 0.0};
  const PetscBool        discrete = (PetscBool)(imp->scheme->no_objective != NULL);

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitDiagonalWeight(imp, &c.diagonal));
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm term = imp->terms[k];
    if (!term->ops.diagonal && term->ops.hessian_coefficients && !discrete) PetscCall(term->ops.hessian_coefficients(term, X, imp->psd, &c));
  }
  PetscCall(MSimSystemAssembleMatrix(imp->sys, &c, J));
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm term = imp->terms[k];
    if (discrete) {
      if (term->ops.discrete_jacobian) PetscCall(term->ops.discrete_jacobian(term, X, J));
    } else if (term->ops.hessian) PetscCall(term->ops.hessian(term, X, imp->psd, J));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitCheckStart(MSimImplicit imp, PetscReal t, Vec X, const char *restart)
{
  PetscFunctionBeginUser;
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.check_start) PetscCall(imp->terms[k]->ops.check_start(imp->terms[k], t, X, restart));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitMaxStep(MSimImplicit imp, Vec X, Vec Y, PetscReal *alpha)
{
  PetscFunctionBeginUser;
  *alpha = 1;
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.max_step) PetscCall(imp->terms[k]->ops.max_step(imp->terms[k], X, Y, alpha));
  PetscFunctionReturn(PETSC_SUCCESS);
}
