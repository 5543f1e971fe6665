/* Projective dynamics pieces of the implicit step (Liu et al. 2013), with spring damping and drag
   folded in exactly: Phi = 1/2|x-y|_M^2 + sum_s [h^2 k_s/2 |A_s x - d_s|^2 + h kd/2 |A_s x - e_s|^2]
   + h c/2 |x - x_n|^2, minimised over the projections d_s (|d_s| = L_s) and e_s (A_s x_n plus any
   vector normal to the spring's axis at x_n), which reproduces Phi of msim/implicit.h. The
   x-step matrix A = M + h c I + sum_s (h^2 k_s + h kd) L_s is constant: factor once per h. */
#include <msim/implicit.h>
#include <msim/kernels.hpp>
#include <msim/spring_sweep.h>

using msim::Vec3;
typedef Eigen::Map<const Vec3> CMap3;
typedef Eigen::Map<Vec3>       Map3;

PetscErrorCode MSimImplicitPDSetUp(MSimImplicit imp)
{
  MSimSystem         sys = imp->sys;
  const PetscInt     nfl = sys->nown + sys->nghost;
  const PetscReal    h   = imp->h;
  const PetscScalar *m;
  std::vector<PetscInt> dnz, onz;
  PC                 pc;

  PetscFunctionBeginUser;
  if (imp->A) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_PDSetUp, 0, 0, 0, 0));
  PetscCall(MSimSystemGraphPreallocation(sys, dnz, onz)); /* the scalar graph Laplacian's pattern */
  PetscCall(MatCreateAIJ(sys->comm, sys->nown, sys->nown, sys->nfree, sys->nfree, 0, dnz.data(), 0, onz.data(), &imp->A));
  PetscCall(MatSetOption(imp->A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(imp->A, MAT_SPD, PETSC_TRUE));
  PetscErrorCode ierr = 0;
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal) {
    const PetscReal   w  = h * h * k + h * sys->damping;
    const bool        fi = i < nfl, fj = j < nfl;
    const PetscInt    gi = fi ? sys->local_to_global[i] : -1, gj = fj ? sys->local_to_global[j] : -1;
    const PetscScalar wn = -w;
    if (ierr) return;
    if (fi) ierr = MatSetValue(imp->A, gi, gi, w, ADD_VALUES);
    if (fj && !ierr) ierr = MatSetValue(imp->A, gj, gj, w, ADD_VALUES);
    if (fi && fj && !ierr) ierr = MatSetValue(imp->A, gi, gj, wn, ADD_VALUES);
    if (fi && fj && !ierr) ierr = MatSetValue(imp->A, gj, gi, wn, ADD_VALUES);
  });
  PetscCall(ierr);
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < sys->nown; i++) PetscCall(MatSetValue(imp->A, sys->rstart + i, sys->rstart + i, m[3 * i] + h * sys->drag, ADD_VALUES));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(MatAssemblyBegin(imp->A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(imp->A, MAT_FINAL_ASSEMBLY));

  /* The global step's solver, unless -pd_ksp_type / -pd_pc_type choose one (measured in
     runs/scaling/README.md):
     - msimllt (msim's factor: one sweep for x, y and z together), for cloths, chains and surfaces
       while the interface rows it keeps dense on every rank stay few (at most 4000: 128 MB);
     - MUMPS's Cholesky for solids up to 10^5 free vertices: msimllt's serial factor of a 3-D mesh
       fills in far more (9.6 s against MUMPS's 0.8 s for 30,000 vertices);
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
    if (sys->cell_size != 4 && (sys->size == 1 || interface <= 4000)) {
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

/* One spring through the local slots (xloc: ghost and fixed slots filled; the owned rows of x and
   rhs are the Vec arrays xo and ro; ghost contributions go to floc, or nowhere when fl is NULL):
   the PD projection, the damping term with the spring axes of x_n (xn, all slots, or NULL), and
   the coupling to fixed ends. */
static inline void PDSpringSlots(MSimImplicit imp, PetscInt i, PetscInt j, PetscReal k, PetscReal L, const PetscScalar *xo, const PetscScalar *xl, const PetscScalar *xn, PetscScalar *ro, PetscScalar *fl, PetscReal *energy)
{
  MSimSystem      sys = imp->sys;
  const PetscInt  nfl = sys->nown + sys->nghost, nown = sys->nown;
  const PetscReal h = imp->h, hkd = h * sys->damping;
  const Vec3      xi = CMap3((i < nown ? xo : xl) + 3 * i), xj = CMap3((j < nown ? xo : xl) + 3 * j);
  const PetscReal w1 = h * h * k;
  Vec3            p  = w1 * msim::SpringProjection(xi, xj, L);
  if (energy) *energy += h * h * msim::SpringEnergy(xi, xj, k, L);
  if (xn) {
    const Vec3 dn = CMap3(xn + 3 * i) - CMap3(xn + 3 * j), n = dn.normalized(), u = xi - xj - dn;
    p += hkd * (dn + u - n.dot(u) * n);
    if (energy) *energy += 0.5 * hkd * n.dot(u) * n.dot(u);
  }
  /* a fixed end moves its coupling term to the right-hand side */
  const PetscReal w = w1 + (xn ? hkd : 0.0);
  if (j >= nfl) p += w * xj;
  if (i >= nfl) p -= w * xi;
  if (i < nown) Map3(ro + 3 * i) += p;
  else if (fl) Map3(fl + 3 * i) += p;
  if (j < nown) Map3(ro + 3 * j) -= p;
  else if (fl) Map3(fl + 3 * j) -= p;
}

/* rhs = M y + h c x_n + sum_s A_s^T (w1 d_s + w2 e_s) + coupling to fixed ends, at X; with phi,
   also Phi(X) (the projections are optimal, so the PD energy equals Phi). Without spring damping
   the springs with both ends owned go through the vectorized sweep (c = h^2 k L/l along each
   spring) straight into rhs's array while the ghost positions travel. */
PetscErrorCode MSimImplicitPDRHS(MSimImplicit imp, Vec X, Vec rhs, PetscReal *phi)
{
  MSimSystem         sys = imp->sys;
  const MSimSprings &sp  = sys->springs;
  const PetscReal    h = imp->h, hc = h * sys->drag;
  const PetscBool    damped = (PetscBool)(sys->damping > 0);
  const PetscScalar *x, *xl, *xn = NULL, *y, *m, *xng;
  PetscScalar       *r, *fl;
  PetscReal          energy = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_PDLocal, X, rhs, 0, 0));
  if (damped) {
    PetscCall(MSimSystemGlobalToLocal(sys, imp->t + h, X, sys->xloc));
    PetscCall(MSimSystemGlobalToLocal(sys, imp->t, imp->Xn, sys->vloc));
    PetscCall(VecGetArrayRead(sys->vloc, &xn));
  } else PetscCall(MSimSystemGhostsBegin(sys, X, sys->xloc));
  /* the vertex terms */
  PetscCall(VecGetArrayWrite(rhs, &r));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  PetscCall(VecGetArrayRead(imp->Xn, &xng));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) r[i] = m[i] * y[i] + hc * xng[i];
  if (phi)
    for (PetscInt i = 0; i < 3 * sys->nown; i++) energy += 0.5 * m[i] * (x[i] - y[i]) * (x[i] - y[i]) + 0.5 * hc * (x[i] - xng[i]) * (x[i] - xng[i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Xn, &xng));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  /* the springs: without damping, the owned ones through the vectorized sweeps while the ghost
     positions travel, then those with a ghost or fixed end; with damping, all through the slots */
  if (!damped) {
    PetscReal es = 0;
    MSimSpringSweepSlices(&sp.slices, &sys->sweep, x, r, NULL, NULL, 0.0, h * h, phi ? &es : NULL);
    MSimSpringSweep(sp.ninner, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x, r, 0.0, h * h, phi ? &es : NULL);
    energy += h * h * es;
    PetscCall(VecRestoreArrayRead(X, &x));
    PetscCall(MSimSystemGhostsEnd(sys, imp->t + h, X, sys->xloc));
    PetscCall(VecGetArrayRead(X, &x));
  }
  PetscCall(VecGetArrayRead(sys->xloc, &xl));
  {
    PetscReal *e = phi ? &energy : NULL;
    if (damped) {
      PetscCall(VecGetArray(sys->floc, &fl));
      PetscCall(PetscArrayzero(fl + 3 * sys->nown, 3 * (sys->nloc - sys->nown)));
      MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) { PDSpringSlots(imp, i, j, k, L, x, xl, xn, r, fl, e); });
      PetscCall(VecRestoreArray(sys->floc, &fl));
    } else {
      /* each adds to its owned end only; the halo's energy is its owners' */
      for (PetscInt s = sp.ninner; s < sp.n; s++) PDSpringSlots(imp, sp.i[s], sp.j[s], sp.k[s], sp.L[s], x, xl, NULL, r, NULL, e);
      for (size_t s = 0; s < sp.hi.size(); s++) PDSpringSlots(imp, sp.hi[s], sp.hj[s], sp.hk[s], sp.hL[s], x, xl, NULL, r, NULL, NULL);
    }
  }
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(VecRestoreArrayWrite(rhs, &r));
  if (xn) PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
  if (damped && sys->size > 1) PetscCall(MSimSystemGhostsAdd(sys, sys->floc, rhs)); /* collective */
  if (phi) PetscCall(MPIU_Allreduce(&energy, phi, 1, MPIU_REAL, MPIU_SUM, sys->comm));
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
   test every iteration): PETSc's MAIJ applies A to the interleaved x, y and z in one pass, where
   three strided gathers, MatMults and scatters took a fifth of an L-BFGS iteration. */
static PetscErrorCode PDShellMult(Mat J, Vec x, Vec y)
{
  MSimImplicit imp;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(J, &imp));
  if (!imp->A3) PetscCall(MatCreateMAIJ(imp->A, 3, &imp->A3));
  PetscCall(MatMult(imp->A3, x, y));
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
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCSHELL));
  PetscCall(PCShellSetContext(pc, imp));
  PetscCall(PCShellSetApply(pc, PDShellPCApply));
  PetscCall(PCShellSetName(pc, "msim projective-dynamics factor (M + h c I + h^2 L + h kd L) kron I3"));
  PetscFunctionReturn(PETSC_SUCCESS);
}
