/* Projective dynamics pieces of the implicit step (Liu et al. 2013): Phi is the inertia term plus
   terms that are each a weighted sum of |A_s x - p_s|^2 minimised over their projections p_s
   (springs: |p| = L, and spring damping and drag folded in exactly, see terms/), so the x-step
   matrix A = M + the terms' weights is constant: factor once per h. */
#include <msim/implicit.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: whether guess is the local step's X unchanged */
#include <msim/solvers.h>                /* MSimMatMultInterleaved3 */
#include <cstring>
#include <vector>

/* the global step's feasibility work, counted in -log_view: max_step calls (with the step's vector
   passes around them), rejected steps whose length the bound set or tried to (PDRetryHalve), the
   bound tried in place of the check (PDProblemGlobal) and the halvings on Phi */
static PetscLogEvent PD_MaxStep = 0, PD_Bound = 0, PD_BoundCheck = 0, PD_Halving = 0;

/* The global step's moves, as data composed on the Vecs at their current state (PETSc's composed
   reals: void once the Vec changes), for the terms' passes that skip the vertices far from their
   barriers (terms/obstacles.cpp): on D, a bound on every vertex's |D_v| (set by a term's max_step,
   whose pass over D's vertices finds it); on an iterate the step overwrote in place, X0 - alpha D
   after X0 - alpha' D (or after X0 itself: alpha' = 0), the state it had before and a bound on
   every vertex's move from there, |alpha - alpha'| times D's. Without them the terms test every
   vertex. */
static PetscInt PD_MoveFrom = -1, PD_MoveBound = -1, PD_VertexBound = -1;

static PetscErrorCode PDComposedReal(Vec V, PetscInt id, PetscReal *value, PetscBool *has)
{
  PetscFunctionBeginUser;
  *has = PETSC_FALSE;
  /* PETSc's getter does not check that V's composed arrays reach the id (made before it was registered) */
  if (id >= 0 && ((PetscObject)V)->real_idmax > id) PetscCall(PetscObjectComposedDataGetReal((PetscObject)V, id, *value, *has));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitPDSetVertexBound(Vec D, PetscReal bound)
{
  PetscFunctionBeginUser;
  if (PD_VertexBound >= 0) PetscCall(PetscObjectComposedDataSetReal((PetscObject)D, PD_VertexBound, bound));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitPDMoveBound(Vec X, PetscObjectState *from, PetscReal *bound, PetscBool *has)
{
  PetscReal f = 0;
  PetscBool hf;

  PetscFunctionBeginUser;
  PetscCall(PDComposedReal(X, PD_MoveFrom, &f, &hf));
  PetscCall(PDComposedReal(X, PD_MoveBound, bound, has));
  *has  = (PetscBool)(*has && hf);
  *from = (PetscObjectState)f; /* exact: states are counts far below 2^53 */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* X (written in place: from is its state before) = X0 - alpha D, where it was X0 - prev D */
static PetscErrorCode PDMarkMove(Vec X, PetscObjectState from, Vec D, PetscReal alpha, PetscReal prev)
{
  PetscReal vb;
  PetscBool has;

  PetscFunctionBeginUser;
  PetscCall(PDComposedReal(D, PD_VertexBound, &vb, &has));
  if (!has) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscObjectComposedDataSetReal((PetscObject)X, PD_MoveFrom, (PetscReal)from));
  PetscCall(PetscObjectComposedDataSetReal((PetscObject)X, PD_MoveBound, PetscAbsReal(alpha - prev) * vb));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A's diagonal from the weights of the terms that follow the state (pd_reweight: the obstacles,
   whose pd_matrix adds diagonal entries only): diag(A) = the fixed part's diagonal (kept with A at
   its assembly) + their weights, so that a reweight costs O(n) instead of the springs' assembly
   (MatSetValues per spring: a quarter of a refactorization of the 101 x 101 cloth in valgrind
   instructions, runs/contact/README.md). The same sums in the same order at set-up, at a reweight
   and after a restart, so a restart repeats A bit for bit. */
static PetscErrorCode PDSetStateWeights(MSimImplicit imp)
{
  Vec base;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectQuery((PetscObject)imp->A, "MSimPDFixedDiagonal", (PetscObject *)&base));
  PetscCall(MatDiagonalSet(imp->A, base, INSERT_VALUES));
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm term = imp->terms[k];
    if (!term->ops.diagonal && term->ops.pd_matrix && term->ops.pd_reweight) PetscCall(term->ops.pd_matrix(term, imp->A));
  }
  PetscCall(MatAssemblyBegin(imp->A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(imp->A, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A = M + the diagonal terms' weights I + the other terms' PD weights, assembled once; the
   weights that follow the state are set on the diagonal by PDSetStateWeights */
static PetscErrorCode PDAssemble(MSimImplicit imp)
{
  MSimSystem         sys = imp->sys;
  const PetscScalar *m;
  std::vector<PetscInt> dnz, onz;
  PetscReal          diag; /* the diagonal terms' weights */
  Vec                base;

  PetscFunctionBeginUser;
  PetscCheck(!imp->A, sys->comm, PETSC_ERR_PLIB, "PD's matrix is assembled once");
  PetscCall(MSimSystemGraphPreallocation(sys, dnz, onz)); /* the scalar graph Laplacian's pattern */
  PetscCall(MatCreateAIJ(sys->comm, sys->nown, sys->nown, sys->nfree, sys->nfree, 0, dnz.data(), 0, onz.data(), &imp->A));
  PetscCall(MatSetOption(imp->A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(imp->A, MAT_SPD, PETSC_TRUE));
  PetscCall(MSimImplicitDiagonalWeight(imp, &diag));
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm term = imp->terms[k];
    if (!term->ops.diagonal && term->ops.pd_matrix && !term->ops.pd_reweight) PetscCall(term->ops.pd_matrix(term, imp->A));
  }
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < sys->nown; i++) PetscCall(MatSetValue(imp->A, sys->rstart + i, sys->rstart + i, m[3 * i] + diag, ADD_VALUES));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(MatAssemblyBegin(imp->A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(imp->A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatCreateVecs(imp->A, &base, NULL));
  PetscCall(MatGetDiagonal(imp->A, base));
  PetscCall(PetscObjectCompose((PetscObject)imp->A, "MSimPDFixedDiagonal", (PetscObject)base)); /* freed with A */
  PetscCall(VecDestroy(&base));
  PetscCall(PDSetStateWeights(imp));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDDefaultSolver(MSimImplicit imp)
{
  MSimSystem sys = imp->sys;
  PC         pc;

  PetscFunctionBeginUser;
  /* The global step's solver, unless -pd_ksp_type / -pd_pc_type choose one (measured in
     runs/scaling/README.md):
     - msimllt (msim's factor: one sweep for x, y and z together), for cloths, chains and surfaces,
       and for solids up to 10^4 free vertices, while the interface rows it keeps dense on every
       rank stay few (at most 4000: 128 MB). On small solids it beats MUMPS and repeats bit for bit
       at several ranks, which MUMPS does not (the bunny, 2,527 vertices, 20 steps of bunny_drop:
       1.39 against 2.54 s at 1 rank, 1.10 against 2.74 s at 2; a tet box of 7,936 vertices:
       factor 0.16 against 0.14 s, 50 solves 0.21 against 0.37 s);
     - MUMPS's Cholesky for larger solids up to 10^5 free vertices: msimllt's serial factor of a
       3-D mesh fills in far more (18,081 vertices: 0.93 against 0.54 s; 30,000: 9.6 against 0.8 s);
     - CG + GAMG beyond: on a 2-million-spring solid it takes 0.44 s per PD iteration against
       MUMPS's 0.52 (0.24 against 0.42 on two ranks) in a fifth of the memory and without the
       18-s factorization. */
  PetscCall(KSPCreate(sys->comm, &imp->pdksp));
  PetscCall(KSPSetOptionsPrefix(imp->pdksp, "pd_"));
  PetscCall(KSPSetOperators(imp->pdksp, imp->A, imp->A));
  PetscCall(KSPGetPC(imp->pdksp, &pc));
  {
    PetscInt interface = sys->nghost;
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &interface, 1, MPIU_INT, MPI_SUM, sys->comm));
    if ((sys->cell_size != 4 || sys->nfree <= 10000) && (sys->size == 1 || interface <= 4000)) {
      PetscCall(KSPSetType(imp->pdksp, KSPPREONLY));
      PetscCall(PCSetType(pc, PCMSIMLLT));
    } else if (sys->nfree <= 100000) {
      PetscCall(KSPSetType(imp->pdksp, KSPPREONLY));
      PetscCall(PCSetType(pc, PCCHOLESKY));
      PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
    } else {
      PetscCall(KSPSetType(imp->pdksp, KSPCG));
      PetscCall(PCSetType(pc, PCGAMG));
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitPDSetUp(MSimImplicit imp)
{
  MSimSystem sys = imp->sys;
  PC         pc;

  PetscFunctionBeginUser;
  if (imp->A) PetscFunctionReturn(PETSC_SUCCESS);
  if (!PD_MaxStep) {
    PetscCall(PetscLogEventRegister("MSimPDMaxStep", MSIM_CLASSID, &PD_MaxStep));
    PetscCall(PetscLogEventRegister("MSimPDBound", MSIM_CLASSID, &PD_Bound));
    PetscCall(PetscLogEventRegister("MSimPDBoundCheck", MSIM_CLASSID, &PD_BoundCheck));
    PetscCall(PetscLogEventRegister("MSimPDHalving", MSIM_CLASSID, &PD_Halving));
    PetscCall(PetscObjectComposedDataRegister(&PD_MoveFrom));
    PetscCall(PetscObjectComposedDataRegister(&PD_MoveBound));
    PetscCall(PetscObjectComposedDataRegister(&PD_VertexBound));
  }
  PetscCall(PetscLogEventBegin(MSIM_PDSetUp, 0, 0, 0, 0));
  PetscCall(MSimImplicitStepUpdate(imp));
  PetscCall(PDAssemble(imp));
  PetscCall(PDDefaultSolver(imp));
  PetscCall(KSPGetPC(imp->pdksp, &pc));
  PetscCall(KSPSetFromOptions(imp->pdksp));
  {
    /* preonly with msimllt: the solve reads the rhs Vec's interleaved x, y, z directly */
    KSPType   kt;
    PetscBool pre, llt;
    PetscCall(KSPGetType(imp->pdksp, &kt));
    PetscCall(PetscStrcmp(kt, KSPPREONLY, &pre));
    PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCMSIMLLT, &llt));
    imp->pd_direct    = (PetscBool)(pre && llt);
    imp->pd_iterative = (PetscBool)!pre;
  }
  if (imp->pd_iterative) {
    /* A Krylov global step (e.g. -pd_ksp_type cg -pd_pc_type gamg, where a factor would not fit)
       solves for positions, so a tolerance relative to |rhs| ~ |M x| would leave errors of rtol
       times the scene's coordinates in every step (at the default 1e-5 the 21 x 21 cloth gained
       100x its kinetic energy). Starting from the caller's guess (PD's current iterate) and
       measuring the tolerance against that guess's residual makes each solve reduce PD's
       correction instead, and the iteration keeps PD's fixed point. */
    PetscErrorCode (*test)(KSP, PetscInt, PetscReal, KSPConvergedReason *, void *);
    void *cctx;
    PetscErrorCode (*destroy)(void *);
    PetscCall(KSPSetInitialGuessNonzero(imp->pdksp, PETSC_TRUE));
    PetscCall(KSPGetConvergenceTest(imp->pdksp, &test, &cctx, &destroy));
    if (test == KSPConvergedDefault) PetscCall(KSPConvergedDefaultSetUIRNorm(imp->pdksp));
    PetscCall(MatCreateVecs(imp->A, &imp->pdx, &imp->pdb));
  }
  {
    PetscInt before, after;
    PetscCall(MSimFactorizationCount(&before));
    PetscCall(MSimCheckFactorAvailable(imp->pdksp, imp->A));
    PetscCall(KSPSetUp(imp->pdksp));
    PetscCall(MSimFactorizationCount(&after));
    imp->nfactor += after - before;
  }
  PetscCall(MatCreateDense(sys->comm, sys->nown, PETSC_DECIDE, sys->nfree, 3, NULL, &imp->B));
  PetscCall(MatCreateDense(sys->comm, sys->nown, PETSC_DECIDE, sys->nfree, 3, NULL, &imp->Xd));
  PetscCall(VecDuplicate(sys->X0, &imp->rhs));
  PetscCall(PetscLogEventEnd(MSIM_PDSetUp, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Terms whose PD weights follow the state (contact) update them before a local step; where any
   changed on any rank (one reduction of a flag), A's diagonal is reset and A refactored, so the factor
   stays the same as long as the contact set does. */
static PetscErrorCode PDReweight(MSimImplicit imp, Vec X)
{
  PetscBool any = PETSC_FALSE, changed = PETSC_FALSE;

  PetscFunctionBeginUser;
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.pd_reweight) {
      any = PETSC_TRUE;
      PetscCall(imp->terms[k]->ops.pd_reweight(imp->terms[k], X, &changed));
    }
  if (!any || !imp->A) PetscFunctionReturn(PETSC_SUCCESS); /* without A yet, SetUp assembles the weights */
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &changed, 1, MPIU_BOOL, MPI_LOR, imp->sys->comm));
  if (!changed) PetscFunctionReturn(PETSC_SUCCESS);
  {
    PC       pc;
    PetscInt before, after;
    PetscCall(PDSetStateWeights(imp));
    PetscCall(KSPGetPC(imp->pdksp, &pc));
    PetscCall(MSimFactorizationCount(&before));
    PetscCall(PCSetUp(pc));
    PetscCall(MSimFactorizationCount(&after));
    imp->nfactor += after - before;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Newton-CG with the PD factor as its preconditioner (-msim_contact_pc_pd_weight): the obstacles'
   Hessian passes each Jacobian's X here, so that the factor takes the barrier's weights there and
   is refactored by the same rule as PD's own (-msim_contact_pd_refactor) */
PetscErrorCode MSimImplicitPDReweight(MSimImplicit imp, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(PDReweight(imp, X));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitPDLocalBegin(MSimImplicit imp, Vec X, PetscReal *w, Vec *C, PetscInt *next)
{
  PetscFunctionBeginUser;
  *w    = 0;
  *C    = imp->Y;
  *next = imp->nterms;
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.pd_begin) PetscCall(imp->terms[k]->ops.pd_begin(imp->terms[k], X));
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.diagonal) {
      PetscCall(imp->terms[k]->ops.diagonal(imp->terms[k], w, C));
      *next = k + 1;
      break;
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The inertia pass's Phi, sum over i of m_i/2 (x_i - y_i)^2 + w/2 (x_i - c_i)^2 in the order of i
   (the deferred check compares it with the last local step's; a free step does not sum it): the
   terms in blocks that the compiler vectorizes, then added one by one as before. The same
   expression per term and the same order, so the same sum (the loop that summed each term as it
   computed it, which the vectorizer cannot reorder, was 3.4 M instructions of a 123 M PD-10 step of
   the 101 x 101 drape, runs/contact/README.md). */
static PetscReal InertiaEnergy(PetscInt n, const PetscScalar *x, const PetscScalar *y, const PetscScalar *c, const PetscScalar *m, PetscReal w)
{
  PetscReal energy = 0, t[256];

  for (PetscInt i0 = 0; i0 < n; i0 += 256) {
    const PetscInt len = PetscMin(256, n - i0);
    const PetscScalar *__restrict xb = x + i0, *__restrict yb = y + i0, *__restrict cb = c + i0, *__restrict mb = m + i0;
    for (PetscInt j = 0; j < len; j++) t[j] = 0.5 * mb[j] * (xb[j] - yb[j]) * (xb[j] - yb[j]) + 0.5 * w * (xb[j] - cb[j]) * (xb[j] - cb[j]);
    for (PetscInt j = 0; j < len; j++) energy += t[j];
  }
  return energy;
}

/* rhs = M y + the diagonal terms' w c + the other terms' local steps at X; with phi, also Phi(X)
   (the projections are optimal, so the PD energy equals Phi). The terms start what they need
   (the ghost exchange) before the inertia pass, so it travels meanwhile. */
PetscErrorCode MSimImplicitPDRHS(MSimImplicit imp, Vec X, Vec rhs, PetscReal *phi)
{
  MSimSystem         sys = imp->sys;
  const PetscScalar *x, *y, *m, *cg;
  PetscScalar       *r;
  PetscReal          energy = 0, w = 0;
  Vec                C = imp->Y;

  PetscFunctionBeginUser;
  PetscCall(PDReweight(imp, X));
  PetscCall(PetscLogEventBegin(MSIM_PDLocal, X, rhs, 0, 0));
  /* the inertia pass with the first diagonal term fused (the only one so far) */
  PetscInt next;
  PetscCall(MSimImplicitPDLocalBegin(imp, X, &w, &C, &next));
  PetscCall(VecGetArrayWrite(rhs, &r));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  const Vec C0 = C;
  PetscCall(VecGetArrayRead(C0, &cg));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) r[i] = m[i] * y[i] + w * cg[i];
  if (phi) energy = InertiaEnergy(3 * sys->nown, x, y, cg, m, w);
  for (PetscInt k = next; k < imp->nterms; k++) {
    const PetscScalar *c;
    if (!imp->terms[k]->ops.diagonal) continue;
    PetscCall(imp->terms[k]->ops.diagonal(imp->terms[k], &w, &C));
    PetscCall(VecGetArrayRead(C, &c));
    for (PetscInt i = 0; i < 3 * sys->nown; i++) r[i] += w * c[i];
    if (phi)
      for (PetscInt i = 0; i < 3 * sys->nown; i++) energy += 0.5 * w * (x[i] - c[i]) * (x[i] - c[i]);
    PetscCall(VecRestoreArrayRead(C, &c));
  }
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(C0, &cg));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(VecRestoreArrayWrite(rhs, &r));
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.pd_rhs) PetscCall(imp->terms[k]->ops.pd_rhs(imp->terms[k], X, rhs, phi ? &energy : NULL));
  if (phi) PetscCall(MPIU_Allreduce(&energy, phi, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  imp->pd_phi_id = 0;
  if (phi) {
    imp->pd_phi = *phi;
    PetscCall(PetscObjectGetId((PetscObject)X, &imp->pd_phi_id));
    PetscCall(PetscObjectStateGet((PetscObject)X, &imp->pd_phi_state));
  }
  PetscCall(PetscLogEventEnd(MSIM_PDLocal, X, rhs, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Krylov global step: the x, y and z columns one after another, each from its column of guess. */
static PetscErrorCode PDSolveIterative(MSimImplicit imp, Vec rhs, Vec guess, Vec X)
{
  PetscFunctionBeginUser;
  for (PetscInt c = 0; c < 3; c++) {
    KSPConvergedReason reason;
    PetscInt           its;
    KSPType            type;
    PetscCall(VecStrideGather(rhs, c, imp->pdb, INSERT_VALUES));
    if (guess) PetscCall(VecStrideGather(guess, c, imp->pdx, INSERT_VALUES));
    else PetscCall(VecZeroEntries(imp->pdx));
    PetscCall(KSPSolve(imp->pdksp, imp->pdb, imp->pdx));
    PetscCall(KSPGetConvergedReason(imp->pdksp, &reason));
    PetscCall(KSPGetIterationNumber(imp->pdksp, &its));
    PetscCall(KSPGetType(imp->pdksp, &type));
    PetscCheck(reason >= 0, PetscObjectComm((PetscObject)imp->pdksp), PETSC_ERR_NOT_CONVERGED, "the PD global step's linear solve (-pd_ksp_type %s) did not converge: %s after %" PetscInt_FMT " iterations", type, KSPConvergedReasons[reason], its);
    imp->pd_lits += its;
    PetscCall(VecStrideScatter(imp->pdx, c, X, INSERT_VALUES));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A X = rhs: with a factor, the x, y and z columns in one sweep (msimllt) or one KSPMatSolve. */
PetscErrorCode MSimImplicitPDSolve(MSimImplicit imp, Vec rhs, Vec guess, Vec X)
{
  MSimSystem         sys = imp->sys;
  const PetscInt     n   = sys->nown;
  const PetscScalar *r;
  PetscScalar       *b, *x;
  PetscInt           ldb, ldx;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDSetUp(imp));
  PetscCall(PetscLogEventBegin(MSIM_PDGlobal, rhs, X, 0, 0));
  if (imp->pd_direct) {
    PC       pc;
    PetscInt before, after;
    PetscCall(KSPGetPC(imp->pdksp, &pc));
    PetscCall(VecGetArrayRead(rhs, &r));
    PetscCall(VecGetArrayWrite(X, &x));
    PetscCall(MSimFactorizationCount(&before));
    PetscCall(PCMSimLLTSolveInterleaved(pc, 3, r, x));
    PetscCall(MSimFactorizationCount(&after));
    imp->nfactor += after - before;
    PetscCall(VecRestoreArrayWrite(X, &x));
    PetscCall(VecRestoreArrayRead(rhs, &r));
    PetscCall(PetscLogEventEnd(MSIM_PDGlobal, rhs, X, 0, 0));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (imp->pd_iterative) {
    PetscCall(PDSolveIterative(imp, rhs, guess, X));
    PetscCall(PetscLogEventEnd(MSIM_PDGlobal, rhs, X, 0, 0));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MatDenseGetLDA(imp->B, &ldb));
  PetscCall(VecGetArrayRead(rhs, &r));
  PetscCall(MatDenseGetArrayWrite(imp->B, &b));
  for (PetscInt i = 0; i < n; i++)
    for (int c = 0; c < 3; c++) b[c * ldb + i] = r[3 * i + c];
  PetscCall(MatDenseRestoreArrayWrite(imp->B, &b));
  PetscCall(VecRestoreArrayRead(rhs, &r));
  {
    /* count numeric factorizations done inside this solve (PETSc's own log counters, which
       MSimInitialize switches on) */
    PetscInt before, after;
    PetscCall(MSimFactorizationCount(&before));
    PetscCall(KSPMatSolve(imp->pdksp, imp->B, imp->Xd));
    PetscCall(MSimFactorizationCount(&after));
    imp->nfactor += after - before;
  }
  PetscCall(MatDenseGetLDA(imp->Xd, &ldx));
  PetscCall(MatDenseGetArrayRead(imp->Xd, (const PetscScalar **)&x));
  {
    PetscScalar *xo;
    PetscCall(VecGetArray(X, &xo));
    for (PetscInt i = 0; i < n; i++)
      for (int c = 0; c < 3; c++) xo[3 * i + c] = x[c * ldx + i];
    PetscCall(VecRestoreArray(X, &xo));
  }
  PetscCall(MatDenseRestoreArrayRead(imp->Xd, (const PetscScalar **)&x));
  PetscCall(PetscLogEventEnd(MSIM_PDGlobal, rhs, X, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* (A kron I3) x, for the shell Jacobian of L-BFGS (PETSc's QN multiplies by it in Powell's restart
   test every iteration): A applied to the interleaved x, y and z in one pass (MSimMatMultInterleaved3: one loop on one rank, PETSc's MAIJ on several), where
   three strided gathers, MatMults and scatters took a fifth of an L-BFGS iteration. */
static PetscErrorCode PDShellMult(Mat J, Vec x, Vec y)
{
  MSimImplicit imp;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(J, &imp));
  PetscCall(MSimMatMultInterleaved3(imp->A, &imp->A3, x, NULL, y));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitPDCreateShell(MSimImplicit imp, Mat *J)
{
  MSimSystem sys = imp->sys;
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDSetUp(imp));
  PetscCall(MatCreateShell(sys->comm, 3 * sys->nown, 3 * sys->nown, 3 * sys->nfree, 3 * sys->nfree, imp, J));
  PetscCall(MatShellSetOperation(*J, MATOP_MULT, (void (*)(void))PDShellMult));
  PetscCall(MatSetBlockSize(*J, 3));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDShellPCApply(PC pc, Vec r, Vec x)
{
  MSimImplicit imp;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &imp));
  PetscCall(MSimImplicitPDSolve(imp, r, NULL, x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The constant PD factor as a preconditioner (L-BFGS initial Hessian, or CG for Newton). */
PetscErrorCode MSimImplicitPDSetPC(MSimImplicit imp, KSP ksp)
{
  PC pc;
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDSetUp(imp));
  imp->pd_pc = PETSC_TRUE;
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCSHELL));
  PetscCall(PCShellSetContext(pc, imp));
  PetscCall(PCShellSetApply(pc, PDShellPCApply));
  PetscCall(PCShellSetName(pc, "msim projective-dynamics factor (M + h c I + h^2 L + h kd L) kron I3"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Whether PD may bound Phi along its global step from the lagged terms alone (PDBound): with a
   factor (an exact solve), every term either a projection (the springs: their local step is
   Phi's), a diagonal quadratic, a term that gives its own gap (pd_gap: the obstacles, the tets'
   barrier alone), or friction, whose right-hand side is its gradient with no weight in A (its gap
   from its energy and gradient ops). Any other term (self-contact, Teschner's volume term) keeps
   the halving on Phi. *cheap: every lagged term gives pd_gap, so the bound costs its product with A
   and the terms' vertices or tets within reach, where friction's gap costs three of its passes. */
static PetscErrorCode PDBoundAvailable(MSimImplicit imp, PetscBool *ok, PetscBool *cheap)
{
  PetscBool gap = PETSC_FALSE;

  PetscFunctionBeginUser;
  *ok    = PETSC_FALSE;
  *cheap = PETSC_TRUE;
  if (imp->pd_iterative) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm t = imp->terms[k];
    if (t->ops.pd_gap) gap = PETSC_TRUE;
    else if (t->ops.diagonal || (!t->ops.pd_rhs && !t->ops.energy) || !std::strcmp(t->type, MSIMTERMSPRINGS)) continue; /* no ops: not active */
    else if (!std::strcmp(t->type, "friction") && t->ops.energy && t->ops.gradient) *cheap = PETSC_FALSE;
    else PetscFunctionReturn(PETSC_SUCCESS);
  }
  *ok = gap;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The bound on Phi along the global step, without evaluating Phi. X1 = A^-1 rhs minimizes the
   quadratic S(X) = the springs' projections at X0 (and the diagonal terms) + each lagged term's
   model at X0 (E(X0) + grad E(X0).(X - X0) + sum_v w_v/2 |x_v - x0_v|^2, w_v its weights in A);
   S(X0) = Phi(X0), and along X0 - alpha D (D = X0 - X1) S = Phi(X0) - (alpha - alpha^2/2) D^T A D.
   The springs' Phi at X is at most their projections' energy at X (the projections are optimal
   only at X0), so Phi(X0 - alpha D) <= Phi(X0) - (alpha - alpha^2/2) D^T A D + gap(alpha), gap the
   lagged terms' excess over their models (pd_gap: only the vertices within reach of an obstacle,
   the tets within reach of the barrier), and any alpha with gap(alpha) <= (alpha - alpha^2/2)
   D^T A D lowers Phi: no pass over the springs, no local step at a rejected point. The model is
   the right-hand side's at X0, so the bound is used only where the local step was taken at X0 as
   it is now (`cached` in PDProblemGlobal). One PDBound per global step: D^T A D (the one product
   with A) and friction's energy and slope at X0 are taken once, by PDBoundBegin, for the check
   that the bound may leave out and for the retry it may size. */
struct PDBound {
  PetscBool              begun = PETSC_FALSE, ok = PETSC_FALSE; /* ok: available, D^T A D > 0 */
  PetscBool              have_f0 = PETSC_FALSE;
  PetscReal              dad = 0, f0 = 0; /* D^T A D, the excess at the step's alpha0 */
  Vec                    W = NULL, Xa = NULL; /* work: A D or a gradient, and X0 - alpha D */
  std::vector<PetscInt>  lag; /* friction: its gap from its energy and gradient */
  std::vector<PetscReal> e0, slope;
  PetscInt               evals = 0;
};

static PetscErrorCode PDBoundBegin(MSimImplicit imp, Vec X0, Vec D, PDBound *b)
{
  PetscBool ok, cheap;

  PetscFunctionBeginUser;
  if (b->begun) PetscFunctionReturn(PETSC_SUCCESS);
  b->begun = PETSC_TRUE;
  PetscCall(PDBoundAvailable(imp, &ok, &cheap));
  if (!ok) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscObjectQuery((PetscObject)D, "MSimPDBoundWork", (PetscObject *)&b->W));
  PetscCall(PetscObjectQuery((PetscObject)D, "MSimPDBoundX", (PetscObject *)&b->Xa));
  if (!b->W) { /* made once, freed with D */
    Vec W, Xa;
    PetscCall(VecDuplicate(D, &W));
    PetscCall(VecDuplicate(D, &Xa));
    PetscCall(PetscObjectCompose((PetscObject)D, "MSimPDBoundWork", (PetscObject)W));
    PetscCall(PetscObjectCompose((PetscObject)D, "MSimPDBoundX", (PetscObject)Xa));
    PetscCall(VecDestroy(&W));
    PetscCall(VecDestroy(&Xa));
    PetscCall(PetscObjectQuery((PetscObject)D, "MSimPDBoundWork", (PetscObject *)&b->W));
    PetscCall(PetscObjectQuery((PetscObject)D, "MSimPDBoundX", (PetscObject *)&b->Xa));
  }
  PetscCall(MSimMatMultInterleaved3(imp->A, &imp->A3, D, NULL, b->W));
  PetscCall(VecDot(D, b->W, &b->dad));
  for (PetscInt k = 0; k < imp->nterms; k++) {
    MSimImplicitTerm t = imp->terms[k];
    PetscReal        e = 0, s;
    if (t->ops.pd_gap || t->ops.diagonal || (!t->ops.pd_rhs && !t->ops.energy) || !std::strcmp(t->type, MSIMTERMSPRINGS)) continue;
    PetscCall(t->ops.energy(t, X0, &e));
    PetscCall(VecZeroEntries(b->W));
    PetscCall(t->ops.gradient(t, X0, b->W));
    PetscCall(VecDot(b->W, D, &s));
    b->lag.push_back(k);
    b->e0.push_back(e);
    b->slope.push_back(s);
  }
  b->ok = (PetscBool)(b->dad > 0 && PetscIsNormalReal(b->dad));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* f[j] = gap(a[j]) - (a[j] - a[j]^2/2) D^T A D: <= 0 proves Phi(X0 - a[j] D) <= Phi(X0) */
static PetscErrorCode PDBoundExcess(MSimImplicit imp, PDBound *b, Vec X0, Vec D, PetscInt n, const PetscReal *a, PetscReal *f)
{
  PetscFunctionBeginUser;
  b->evals += n;
  for (PetscInt j = 0; j < n; j++) f[j] = 0;
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.pd_gap) PetscCall(imp->terms[k]->ops.pd_gap(imp->terms[k], X0, D, n, a, f));
  for (size_t l = 0; l < b->lag.size(); l++)
    for (PetscInt j = 0; j < n; j++) {
      PetscReal e = 0;
      PetscCall(VecWAXPY(b->Xa, -a[j], D, X0));
      PetscCall(imp->terms[b->lag[l]]->ops.energy(imp->terms[b->lag[l]], b->Xa, &e));
      f[j] += e - b->e0[l] + a[j] * b->slope[l];
    }
  for (PetscInt j = 0; j < n; j++) f[j] -= (a[j] - 0.5 * a[j] * a[j]) * b->dad;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* whether the bound proves that Phi does not rise at X0 - alpha0 D, the step as it stands */
static PetscErrorCode PDBoundPasses(MSimImplicit imp, PDBound *b, Vec X0, Vec D, PetscReal alpha0, PetscBool *pass)
{
  PetscFunctionBeginUser;
  *pass = PETSC_FALSE;
  PetscCall(PDBoundBegin(imp, X0, D, b));
  if (!b->ok) PetscFunctionReturn(PETSC_SUCCESS);
  if (!b->have_f0) {
    PetscCall(PDBoundExcess(imp, b, X0, D, 1, &alpha0, &b->f0));
    b->have_f0 = PETSC_TRUE;
  }
  *pass = (PetscBool)(b->f0 <= 0);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A step below alpha0, where the bound fails at alpha0: alpha0 / 2^j (j <= 12) in one batch, then
   one secant step between the last failing and the first passing alpha. The bound is conservative
   (it drops the springs' reprojection), so the alpha it accepts may be shorter than the halving on
   Phi would take; found is false when none passes (the caller halves on Phi). */
static PetscErrorCode PDBoundShorten(MSimImplicit imp, PDBound *b, Vec X0, Vec D, PetscReal alpha0, PetscReal *acc, PetscBool *found)
{
  const PetscInt nj = 12;
  PetscReal      a[nj], f[nj];

  PetscFunctionBeginUser;
  *found = PETSC_FALSE;
  *acc   = alpha0;
  if (!b->ok || !b->have_f0) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt j = 0; j < nj; j++) a[j] = alpha0 * PetscPowReal(0.5, (PetscReal)(j + 1));
  PetscCall(PDBoundExcess(imp, b, X0, D, nj, a, f));
  for (PetscInt j = 0; j < nj && !*found; j++)
    if (f[j] <= 0) {
      /* the secant root of the excess between the failing alpha above and this one, 0.9 of the
         way from this one: kept if it passes */
      const PetscReal ahi = j ? a[j - 1] : alpha0, fhi = j ? f[j - 1] : b->f0;
      *found = PETSC_TRUE;
      *acc   = a[j];
      if (PetscIsNormalReal(fhi)) {
        PetscReal as = a[j] + 0.9 * (ahi - a[j]) * (-f[j]) / (fhi - f[j]), fs;
        if (as > a[j] && as < ahi) {
          PetscCall(PDBoundExcess(imp, b, X0, D, 1, &as, &fs));
          if (fs <= 0) *acc = as;
        }
      }
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -info: the bound's decision, and for a step it accepted Phi at both ends evaluated in full, as
   evidence that the bound held (tests/contact_pd_refactor.py reads this line) */
static PetscErrorCode PDBoundInfo(MSimImplicit imp, PDBound *b, Vec X0, Vec X, PetscReal alpha0, PetscReal acc, PetscBool found, const char *what)
{
  PetscBool info;
  PetscReal p0 = 0, p1 = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscInfoEnabled(VEC_CLASSID, &info));
  if (!info) PetscFunctionReturn(PETSC_SUCCESS);
  if (found) {
    PetscCall(MSimImplicitObjective(imp, X0, &p0));
    PetscCall(MSimImplicitObjective(imp, X, &p1));
  }
  PetscCall(PetscInfo(X0, "pd bound: alpha0 %g accepted %g (%s), %s, D^T A D %g, %" PetscInt_FMT " evaluations, Phi %.17g -> %.17g\n", (double)alpha0, (double)acc, found ? "found" : "none: halving on Phi", what, (double)b->dad, b->evals, (double)p0, (double)p1));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* How far a measured Phi may rise at X0 - alpha D and still count as not rising: the roundoff of
   the global step itself. The bound takes X1 = A^-1 rhs as exact; a computed X1 has a residual r =
   A X1 - rhs of about eps |A| |X1| (a backward-stable solve), which moves the model along the step
   by alpha D^T r, at most alpha |D|_1 eps |A|_inf |X0|_inf. Where PD has converged to roundoff (a
   free fall: x = y solves the step, Phi ~ 1e-27 J, each iterate moves by the solve's 1e-15 m)
   that is the size of Phi's changes, up and down, and the bound passes while Phi is measured to
   rise by about D^T A D (the 101 x 101 drape's first steps: 1.9e-27 J); in a step that moves, it
   is eps |X0| |A D| against a decrease of D^T A D. Plus MSIM_PHI_ROUNDOFF |Phi| (solvers.h), the
   evaluation's own, as PD + L-BFGS's line search takes it. No constant on the solve's term: on
   that drape it is 100 to 1500 times the rises measured. */
static PetscErrorCode PDPhiRoundoff(MSimImplicit imp, Vec X0, Vec D, PetscReal alpha, PetscReal phi0, PetscReal *tol)
{
  PetscReal d1, xinf, ainf;

  PetscFunctionBeginUser;
  PetscCall(VecNorm(D, NORM_1, &d1));
  PetscCall(VecNorm(X0, NORM_INFINITY, &xinf));
  PetscCall(MatNorm(imp->A, NORM_INFINITY, &ainf));
  *tol = MSIM_PHI_ROUNDOFF * PetscAbsReal(phi0) + PETSC_MACHINE_EPSILON * alpha * d1 * ainf * xinf;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Phi at X for the check's loop (PDRetryHalve): *phi = Phi(X); with phi NULL, X is an accepted
   step whose Phi is not needed, and the caller's state follows it (the deferred check: the local
   step at X, which the next global step reads) */
typedef PetscErrorCode (*PDPhiAt)(MSimImplicit imp, void *ctx, Vec X, PetscReal *phi);

/* The global step's check once Phi(X), X = X0 - alpha D, is known to be phi, against phi0 =
   Phi(X0) summed the same way: one loop for the check done at once (PDHalve, Phi by
   MSimImplicitObjective) and the deferred one (PDProblemRHS, Phi from the next local step), Phi at
   a retried X by phi_at. A rise is answered by the bound where it applies (b not NULL): where it
   fails at alpha, its longest shorter step that provably lowers Phi, with no Phi evaluation there.
   Where it passes at alpha although Phi was measured to rise there, the bound and the measure
   disagree: a rise within Phi's roundoff (PDPhiRoundoff; the free fall's) is taken as no rise and
   alpha kept, a larger one means the bound does not model some term and it is not trusted
   (halving on Phi, -info says so). Without the bound, or where it finds nothing: halving on Phi
   until it does not rise (at most 30 times). */
static PetscErrorCode PDRetryHalve(MSimImplicit imp, PDBound *b, Vec X0, Vec D, PetscReal alpha, PetscReal phi0, PetscReal phi, Vec X, PDPhiAt phi_at, void *ctx)
{
  PetscFunctionBeginUser;
  imp->pd_rejected = (PetscBool)!(phi <= phi0);
  if (imp->pd_rejected && b) {
    PetscBool ok, cheap;
    PetscCall(PDBoundAvailable(imp, &ok, &cheap));
    if (!ok) b = NULL;
  }
  if (imp->pd_rejected && b) {
    PetscBool pass, found = PETSC_FALSE;
    PetscReal acc = alpha;
    PetscCall(PetscLogEventBegin(PD_Bound, 0, 0, 0, 0));
    PetscCall(PDBoundPasses(imp, b, X0, D, alpha, &pass));
    if (pass) {
      PetscReal tol;
      PetscCall(PDPhiRoundoff(imp, X0, D, alpha, phi0, &tol));
      found = (PetscBool)(phi - phi0 <= tol);
      PetscCall(PetscInfo(X0, "pd bound: passes at alpha0 %g where Phi was measured to rise by %g (roundoff tolerance %g): %s\n", (double)alpha, (double)(phi - phi0), (double)tol, found ? "roundoff, alpha0 kept" : "the bound does not hold, halving on Phi"));
    } else if (b->ok) {
      PetscCall(PDBoundShorten(imp, b, X0, D, alpha, &acc, &found));
      if (found) {
        PetscObjectState from;
        PetscCall(PetscObjectStateGet((PetscObject)X, &from));
        PetscCall(VecWAXPY(X, -acc, D, X0));
        PetscCall(PDMarkMove(X, from, D, acc, alpha));
      }
    }
    if (b->ok) PetscCall(PDBoundInfo(imp, b, X0, X, alpha, acc, found, "rejected step"));
    PetscCall(PetscLogEventEnd(PD_Bound, 0, 0, 0, 0));
    if (found) {
      imp->pd_rejected = PETSC_FALSE; /* a rejection costs no halving now: keep deferring */
      if (acc != alpha) PetscCall(phi_at(imp, ctx, X, NULL));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
  }
  for (PetscInt it = 0; it < 30 && !(phi <= phi0); it++) {
    PetscCall(PetscLogEventBegin(PD_Halving, 0, 0, 0, 0));
    PetscObjectState from;
    PetscCall(PetscObjectStateGet((PetscObject)X, &from));
    alpha *= 0.5;
    PetscCall(VecWAXPY(X, -alpha, D, X0));
    PetscCall(PDMarkMove(X, from, D, alpha, 2 * alpha));
    PetscCall(phi_at(imp, ctx, X, &phi));
    PetscCall(PetscLogEventEnd(PD_Halving, 0, 0, 0, 0));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDObjectiveAt(MSimImplicit imp, void *, Vec X, PetscReal *phi)
{
  PetscFunctionBeginUser;
  if (phi) PetscCall(MSimImplicitObjective(imp, X, phi));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The global step's check done at once, at X = X0 - alpha D: Phi(X) by MSimImplicitObjective
   against phi0 (Phi(x_k); cached: the local step's sum), then PDRetryHalve. b: the step's bound
   (NULL: none) */
static PetscErrorCode PDHalve(MSimImplicit imp, PDBound *b, Vec X0, Vec D, PetscReal alpha, PetscBool cached, PetscReal phi0, Vec X)
{
  PetscReal phi;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitObjective(imp, X, &phi));
  /* the local step sums Phi in another order than MSimImplicitObjective: where the two differ
     by roundoff near convergence, a cached Phi(x_k) a few ulp low would make every halving
     fail; compare like with like before halving */
  if (cached && !(phi <= phi0)) PetscCall(MSimImplicitObjective(imp, X0, &phi0));
  PetscCall(PDRetryHalve(imp, cached ? b : NULL, X0, D, alpha, phi0, phi, X, PDObjectiveAt, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A deferred check still pending (the solver's last iterate, or an X that the next local step
   does not get): done at once, if the iterate is as the global step left it */
static PetscErrorCode PDCheckResolve(MSimImplicit imp)
{
  PetscObjectState state;

  PetscFunctionBeginUser;
  if (!imp->pd_pending) PetscFunctionReturn(PETSC_SUCCESS);
  imp->pd_pending = PETSC_FALSE;
  PetscCall(PetscObjectStateGet((PetscObject)imp->pd_px, &state));
  if (state == imp->pd_pstate) {
    PDBound b;
    PetscCall(PDHalve(imp, &b, imp->pd_x0, imp->pd_d, imp->pd_alpha, PETSC_TRUE, imp->pd_phi0, imp->pd_px));
  }
  PetscCall(VecDestroy(&imp->pd_px)); /* the reference taken by the global step */
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDProblemFinish(void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(PDCheckResolve((MSimImplicit)ctx));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the deferred check's Phi: the local step at X (into rhs, which the caller reads next) */
struct PDLocalAtCtx {
  Vec        rhs;
  PetscReal *phi;
};

static PetscErrorCode PDLocalAt(MSimImplicit imp, void *ctx, Vec X, PetscReal *phi)
{
  PDLocalAtCtx *c = (PDLocalAtCtx *)ctx;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDRHS(imp, X, c->rhs, c->phi));
  if (phi) *phi = *c->phi;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* whether a term keeps the iterates in a feasible set (its max_step: contact, inversion barriers) */
static PetscBool HasFeasibleSet(MSimImplicit imp)
{
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.max_step) return PETSC_TRUE;
  return PETSC_FALSE;
}

/* The first iterate no worse than x_n. PD's iterates never raise Phi from the first (the global
   step's check), so a step ends no worse than it starts; but the first iterate, the guess pulled
   back vertex by vertex from the obstacles (MSimImplicitGuess's clamp: 0.8 of each vertex's way
   to its hit), can start far above Phi(x_n): the vertices that would land within a step stop a
   fifth of their gap from the obstacle, deep in the barrier, moving at the speed they landed
   with. On the box table (PD-10, 21 x 21, a 10 cm drop, friction 0.3) the step after landing
   started at Phi 1.96e-3 against Phi(x_n) 3.38e-4, the next at 2.36e-3 against 3.89e-4 and ended
   at 4.99e-4, above Phi(x_n): KE + potential rose from -0.42 J to +0.22 J in two steps, energy a
   converged step cannot gain (runs/contact/README.md, seventh session (h5)). x_n (or, where a term
   has a feasible set, the step's feasible start made from it) is feasible, so where the first
   iterate's Phi (this local step's sum) is above Phi there the step starts from there instead, once per time step (at the first global step, with the local
   step redone at x_n, where a term has a feasible set). Phi(x_n) >= 1/2 |x_n - y|_M^2 where the terms' energies are >= 0
   (springs, barriers, friction, the diagonal terms; gravity is in y), so where the first iterate's
   Phi is below that no evaluation is needed (a free fall, most steps in flight; a term with a
   negative energy could only make the test miss a start). Plain PD at its first global step (in
   place, X == guess; with -snes_pd_fixed or to a tolerance, the same iterates); Anderson and
   L-BFGS without the fused gradient at their first local step, which asks for Phi, before their
   history holds the first iterate's data (PDProblemRHS); L-BFGS with the fused gradient at its
   first gradient (PDProblemGradient). PD to a tolerance measured its first residual at the
   guess: its relative tolerance stays relative to that. *moved: X is now the step's start, and
   the caller redoes its pass (local step or fused gradient) there. */
static PetscErrorCode PDStartNoWorse(MSimImplicit imp, Vec X, PetscBool *moved)
{
  MSimSystem         sys = imp->sys;
  const PetscScalar *xn, *y, *m;
  PetscReal          low, phin, phi = imp->pd_phi;
  PetscObjectState   ystate;

  PetscFunctionBeginUser;
  *moved = PETSC_FALSE;
  PetscCall(PetscObjectStateGet((PetscObject)imp->Y, &ystate));
  if (ystate == imp->pd_start_ystate) PetscFunctionReturn(PETSC_SUCCESS); /* compared already this time step */
  imp->pd_start_ystate = ystate;
  /* where a term has a feasible set, the step's feasible start (MSimImplicitGuess's: x_n carried as
     far as moving handles or obstacles need), not x_n itself, which their move can have left
     infeasible: from x_n plain PD let a sheet lifted by handles 15 mm a step pass through another
     resting 9.5 mm above it. The lower bound is the start's own (x_n's is none for it: a carried
     start's Phi can exceed a first iterate below x_n's bound) */
  Vec start = imp->guess_a ? imp->guess_a : imp->Xn;
  PetscCall(VecGetArrayRead(start, &xn));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  low = InertiaEnergy(3 * sys->nown, xn, y, y, m, 0);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(start, &xn));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &low, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  if (phi <= low) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimImplicitObjective(imp, start, &phin));
  if (!(phi > phin + MSIM_PHI_ROUNDOFF * PetscAbsReal(phin))) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscInfo(X, "pd: the first iterate's Phi %.17g is above Phi at the step's feasible start %.17g: the step starts from there\n", (double)phi, (double)phin));
  PetscCall(VecCopy(start, X));
  *moved = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDProblemRHS(void *ctx, Vec X, Vec rhs, PetscReal *phi)
{
  MSimImplicit imp = (MSimImplicit)ctx;
  PetscReal    own;
  const PetscBool asked = (PetscBool)(phi != NULL), feasible = HasFeasibleSet(imp);

  PetscFunctionBeginUser;
  /* with a feasible set the global step may check Phi from X: Phi(X) comes almost free with the
     local step's passes (kept in imp->pd_phi), where a separate evaluation costs every term's */
  if (feasible && !phi) phi = &own;
  if (imp->pd_pending) {
    PetscObjectState state;
    PetscCall(PetscObjectStateGet((PetscObject)X, &state));
    if (X == imp->pd_px && state == imp->pd_pstate) {
      /* the global step's deferred check, with Phi(X) from this local step's passes (phi is set:
         a check is pending only where a term has a feasible set) and phi0 from the last one's:
         like with like, as in PDHalve. A retried X gets its own local step. */
      PDBound          b;
      PDLocalAtCtx     c = {rhs, phi};
      PetscObjectState astate;
      imp->pd_pending = PETSC_FALSE;
      PetscCall(VecDestroy(&imp->pd_px)); /* the global step's reference; the caller's X lives on */
      PetscCall(MSimImplicitPDRHS(imp, X, rhs, phi));
      /* the bound models Phi along D with the A that D was solved with: a reweight in this local
         step (new contact weights) would make it claim too little, so it then halves on Phi */
      PetscCall(PetscObjectStateGet((PetscObject)imp->A, &astate));
      PetscCall(PDRetryHalve(imp, astate == imp->pd_astate ? &b : NULL, imp->pd_x0, imp->pd_d, imp->pd_alpha, imp->pd_phi0, *phi, X, PDLocalAt, &c));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(PDCheckResolve(imp));
  }
  PetscCall(MSimImplicitPDRHS(imp, X, rhs, phi));
  /* Anderson (and L-BFGS where it takes no fused gradient) asks for Phi at its first iterate
     before its history holds anything: that first local step of a time step is where its start
     is compared with x_n (plain PD, which asks for no Phi, is compared at its first global step,
     PDProblemGlobal). Without it Anderson started the bunny's landing step (examples/bunny_drop.opts,
     step 11) at Phi 1.405e-5 against Phi(x_n) 1.134e-5 and ended its 30 iterations at 1.164e-5,
     still above x_n: KE + potential rose from 0.071 J to 0.19 J, then 0.25 J */
  if (asked && feasible) {
    PetscBool moved;
    PetscCall(PDStartNoWorse(imp, X, &moved));
    if (moved) PetscCall(MSimImplicitPDRHS(imp, X, rhs, phi)); /* the local step at the start into the caller's rhs, Phi there cached */
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* L-BFGS's fused gradient (pd_gradient.cpp). Its first gradient of a time step, at the guess,
   is where its start is compared with x_n, as Anderson's first local step is (PDProblemRHS): its
   line search only compares an iterate with the current one, so a start above Phi(x_n) stays
   above it. Without it examples/bunny_drop.opts with -snes_pd_lbfgs 5 started its landing step
   (11) above Phi(x_n) and its energy rose from 0.071 J to 0.187 J, then 0.200 J. Where the
   gradient at the start cannot be fused (new contact weights changed A there), *done is false
   and the solver takes rhs and the product, PDProblemRHS's, as for any such solve. */
static PetscErrorCode PDProblemGradient(void *ctx, Vec X, Vec G, PetscReal *phi, PetscBool *done)
{
  MSimImplicit imp = (MSimImplicit)ctx;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDGradient(ctx, X, G, phi, done));
  if (*done && HasFeasibleSet(imp)) {
    PetscBool moved;
    PetscCall(PDStartNoWorse(imp, X, &moved));
    if (moved) PetscCall(MSimImplicitPDGradient(ctx, X, G, phi, done));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The global step's vector work with a feasible set, in two passes where VecAYPX, VecCopy and
   VecWAXPY took three of PETSc's scalar loops (6.6 M instructions of a 123 M PD-10 step of the
   101 x 101 drape, a free step being 76 M; runs/contact/README.md): D = x_k - D (D held A^-1 rhs)
   and X0 = x_k, then X = X0 - alpha D. The same roundings as those calls: x - y for VecAYPX's
   alpha = -1 and X0 - D for VecWAXPY's -alpha = -1 (no product, so no contraction can change
   them); another alpha (a step max_step shortened, rare) keeps VecWAXPY, whose product and sum
   a contracted loop here would round once instead of twice. */
static PetscErrorCode PDStepFrom(Vec guess, Vec D, Vec X0)
{
  const PetscScalar *x;
  PetscScalar       *d, *x0;
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(D, &n));
  PetscCall(VecGetArrayRead(guess, &x));
  PetscCall(VecGetArray(D, &d));
  PetscCall(VecGetArrayWrite(X0, &x0));
  {
    const PetscScalar *__restrict xr = x;
    PetscScalar *__restrict dr = d, *__restrict x0r = x0;
    for (PetscInt i = 0; i < n; i++) {
      const PetscScalar xi = xr[i];
      dr[i]                = xi - dr[i];
      x0r[i]               = xi;
    }
  }
  PetscCall(VecRestoreArrayWrite(X0, &x0));
  PetscCall(VecRestoreArray(D, &d));
  PetscCall(VecRestoreArrayRead(guess, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDStepTo(Vec X0, Vec D, PetscReal alpha, Vec X)
{
  const PetscScalar *x0, *d;
  PetscScalar       *x;
  PetscInt           n;

  PetscFunctionBeginUser;
  if (alpha != 1) {
    PetscCall(VecWAXPY(X, -alpha, D, X0));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArrayRead(X0, &x0));
  PetscCall(VecGetArrayRead(D, &d));
  PetscCall(VecGetArrayWrite(X, &x));
  {
    const PetscScalar *__restrict x0r = x0, *__restrict dr = d;
    PetscScalar *__restrict xr = x;
    for (PetscInt i = 0; i < n; i++) xr[i] = x0r[i] - dr[i];
  }
  PetscCall(VecRestoreArrayWrite(X, &x));
  PetscCall(VecRestoreArrayRead(D, &d));
  PetscCall(VecRestoreArrayRead(X0, &x0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The PD solver's global step from the current iterate guess; where a term has a feasible set
   (contact barriers, the tets' barrier), the step from guess is shortened by the terms' max_step
   so that PD's iterates stay inside it, and then checked: Phi must not rise along it. Three ways,
   cheapest first:
   - no check where no term's barrier is met along the step (pd_check);
   - the bound on Phi (PDBound), where it applies and costs less than the check: it proves that
     Phi does not rise without evaluating it (one product with A and the terms' elements within
     reach, against a pass of every term), and sizes the step where the check finds a rise;
   - the check, done now, or, where the solver allows it (defer_check) and Phi(guess) is the last
     local step's, by the next local step at X (PDProblemRHS), which sums Phi(X) anyway: the
     separate evaluation cost 9% of a PD step of the bunny with its volume barrier and most of
     contact's cost in PD on the cloth on the ball (runs/contact/README.md). After a check that
     halved the step the next is done at once: a deferred halving costs a local step, about 2.5
     MSimImplicitObjective passes, and rejections come in runs (the free 101 x 101 cloth on the
     ball halves in half its iterations).
   The bound goes first only where the check would cost an evaluation of Phi (not deferred) and
   every lagged term gives its own gap (PDBoundAvailable's cheap): a deferred check costs nothing
   where it passes, and friction's gap costs three of its passes, more than the check's one. */
static PetscErrorCode PDProblemGlobal(void *ctx, Vec rhs, Vec guess, Vec X)
{
  MSimImplicit    imp      = (MSimImplicit)ctx;
  const PetscBool feasible = HasFeasibleSet(imp);
  PetscBool       cached   = PETSC_FALSE;
  Vec             X0 = NULL, D = NULL;
  PetscReal       alpha;

  PetscFunctionBeginUser;
  PetscCall(PDCheckResolve(imp)); /* x_k is final before a step from it (the work Vecs are reused) */
  if (feasible && guess) {
    PetscObjectId    id;
    PetscObjectState state;
    PetscCall(PetscObjectGetId((PetscObject)guess, &id));
    PetscCall(PetscObjectStateGet((PetscObject)guess, &state));
    cached = (PetscBool)(imp->pd_phi_id && id == imp->pd_phi_id && state == imp->pd_phi_state); /* Phi(guess) known */
    if (cached && X == guess) { /* plain PD (the step in place), at its first global step of a time step */
      PetscBool moved;
      PetscReal phi;
      PetscCall(PDStartNoWorse(imp, X, &moved));
      if (moved) {
        PetscCall(MSimImplicitPDRHS(imp, X, rhs, &phi)); /* the local step at the start into the caller's rhs, Phi there cached */
        PetscCall(PetscObjectStateGet((PetscObject)guess, &state));
        cached = (PetscBool)(id == imp->pd_phi_id && state == imp->pd_phi_state);
      }
    }
    if (!imp->pd_x0) {
      PetscCall(VecDuplicate(guess, &imp->pd_x0));
      PetscCall(VecDuplicate(guess, &imp->pd_d));
    }
    X0 = imp->pd_x0;
    D  = imp->pd_d;
  }
  if (!X0) {
    PetscCall(MSimImplicitPDSolve(imp, rhs, guess, X));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* the solution into D and max_step from guess itself, still the local step's X (same id and
     state), whose distances the obstacles kept: D and x_k's copy in one pass, then X = x_k - alpha
     D (the event holds the passes too: the vector work a free step does not do) */
  PetscCall(MSimImplicitPDSolve(imp, rhs, guess, D));
  PetscCall(PetscObjectStateGet((PetscObject)imp->A, &imp->pd_astate));
  PetscCall(PetscLogEventBegin(PD_MaxStep, 0, 0, 0, 0));
  PetscCall(PDStepFrom(guess, D, X0));
  PetscCall(MSimImplicitMaxStep(imp, guess, D, &alpha));
  {
    PetscObjectState from;
    PetscCall(PetscObjectStateGet((PetscObject)X, &from));
    PetscCall(PDStepTo(X0, D, alpha, X));
    if (X == guess) PetscCall(PDMarkMove(X, from, D, alpha, 0)); /* from guess = X0 */
  }
  PetscCall(PetscLogEventEnd(PD_MaxStep, 0, 0, 0, 0));
  /* a term may say that its barrier is not met along this step (pd_check): no check for it */
  PetscBool check = (PetscBool)(alpha < 1);
  for (PetscInt k = 0; k < imp->nterms && !check; k++) {
    PetscBool needed = PETSC_TRUE;
    if (!imp->terms[k]->ops.max_step) continue;
    if (imp->terms[k]->ops.pd_check) PetscCall(imp->terms[k]->ops.pd_check(imp->terms[k], &needed));
    check = needed;
  }
  if (!check) PetscFunctionReturn(PETSC_SUCCESS);
  /* With the barrier's force lagged in the right-hand side, D = A^-1 g(x_k) (A x - rhs(x) is
     Phi's gradient), a descent direction but not a contraction where the barrier is stiffer
     than A: the step must not raise Phi. Phi(x_k): the local step's, when it was taken at guess
     as it is now. */
  const PetscBool defer = (PetscBool)(imp->pd.defer_check && cached && X == guess && !imp->pd_rejected);
  PDBound         b;
  if (cached && !defer) {
    PetscBool pass, ok, cheap;
    PetscCall(PDBoundAvailable(imp, &ok, &cheap));
    if (ok && cheap) {
      PetscCall(PetscLogEventBegin(PD_BoundCheck, 0, 0, 0, 0));
      PetscCall(PDBoundPasses(imp, &b, X0, D, alpha, &pass));
      if (pass) PetscCall(PDBoundInfo(imp, &b, X0, X, alpha, alpha, PETSC_TRUE, "check left out"));
      PetscCall(PetscLogEventEnd(PD_BoundCheck, 0, 0, 0, 0));
      if (pass) {
        imp->pd_rejected = PETSC_FALSE;
        PetscFunctionReturn(PETSC_SUCCESS);
      }
    }
  }
  if (defer) {
    imp->pd_pending = PETSC_TRUE;
    imp->pd_alpha   = alpha;
    imp->pd_phi0    = imp->pd_phi;
    PetscCall(PetscObjectReference((PetscObject)X));
    imp->pd_px = X;
    PetscCall(PetscObjectStateGet((PetscObject)X, &imp->pd_pstate));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  {
    PetscReal phi0 = 0;
    if (cached) phi0 = imp->pd_phi;
    else PetscCall(MSimImplicitObjective(imp, X0, &phi0));
    PetscCall(PDHalve(imp, &b, X0, D, alpha, cached, phi0, X));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* y = (A kron I3) x - b for PD + L-BFGS's gradient */
static PetscErrorCode PDProblemApply(void *ctx, Vec x, Vec b, Vec y)
{
  MSimImplicit imp = (MSimImplicit)ctx;
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDSetUp(imp));
  PetscCall(MSimMatMultInterleaved3(imp->A, &imp->A3, x, b, y));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDProblemMaxStep(void *ctx, Vec X, Vec D, PetscReal *alpha)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitMaxStep((MSimImplicit)ctx, X, D, alpha));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDProblemSetUp(void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitPDSetUp((MSimImplicit)ctx));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The PD steps travel with the DM, so the pd type also finds them as the NPC of another SNES. */
PetscErrorCode MSimImplicitPDCompose(MSimImplicit imp, DM dm)
{
  PetscContainer c;

  PetscFunctionBeginUser;
  imp->pd.rhs          = PDProblemRHS;
  imp->pd.global_solve = PDProblemGlobal;
  imp->pd.setup        = PDProblemSetUp;
  imp->pd.apply        = PDProblemApply;
  imp->pd.gradient     = PDProblemGradient;
  imp->pd.max_step     = PDProblemMaxStep;
  imp->pd.finish       = PDProblemFinish;
  imp->pd.defer_check  = PETSC_FALSE; /* SNESSolve_PD sets it where it may */
  imp->pd.ctx          = imp;
  PetscCall(PetscContainerCreate(imp->sys->comm, &c));
  PetscCall(PetscContainerSetPointer(c, &imp->pd));
  PetscCall(PetscObjectCompose((PetscObject)dm, "MSimPDProblem", (PetscObject)c));
  PetscCall(PetscContainerDestroy(&c));
  PetscFunctionReturn(PETSC_SUCCESS);
}
