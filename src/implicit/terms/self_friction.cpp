/* Coulomb friction between surfaces in self-contact (-msim_self_contact with -msim_friction mu > 0):
   IPC's lagged, smoothed dissipative potential (Li et al. 2020, sec. 5) on the self-contact term's
   point-triangle and edge-edge pairs. At the step's start x_n each pair within dhat gives, held
   fixed over the step (lagged): the closest points' weights w_k (r = sum_k w_k x_k joins them),
   the unit normal n = r / |r|, P = I - n n^T, and the normal force lambda = |dE/dd| / (beta h^2)
   of the barrier there (E = C b(d^2), so lambda = 2 C |b'(d^2)| d / (beta h^2)). Over the step the
   pair's relative tangential displacement is u = P sum_k w_k (x_k - x_k^n) (the closest points'
   relative slip; a fixed vertex moves v_fix (tx - t)), and
     D = beta h^2 mu lambda f0(|u|),  f0' = f1,  f1(y) = 2 y/eps - y^2/eps^2 (y < eps), 1 beyond,
   eps = eps_v h (-msim_friction_eps), as the obstacles' friction (terms/friction.cpp) does.
   Gradient g_k = beta h^2 mu lambda f1(y)/y w_k u. Hessian block (k, l) = beta h^2 mu lambda
   w_k w_l M, M = f1(y)/y P + (f1'(y) y - f1(y))/y^3 u u^T: M's eigenvalues are f1'(y) >= 0 along
   u, f1(y)/y > 0 across it in the tangent plane, 0 along n, and w w^T is PSD, so the 12 x 12
   block (w w^T) kron M is PSD as it is (no projection). Lagging makes D smooth in x within the
   step (its Hessian exact), the approximation IPC makes; the lag is redone when the step changes
   (its start time or beta h^2: every step, a retry with a smaller h). The pairs' free vertices are read from X - x_n by a scatter
   of this term's own, made at each lag (the self-contact surface's local numbering may be
   re-planned within a step), and the gradient goes back by its reverse (ADD_VALUES); the Hessian's
   rows that other ranks own go to them over that scatter's neighbours (MSimSelfHessian). PD: the
   gradient at the current iterate in the right-hand side, as the barrier's.
   Lagged at x_n alone, a step that lands has no friction (the pairs are beyond dhat at its start)
   and one that leaves keeps it: IPC's lag iterations (-msim_friction_lag_iterations N,
   -msim_friction_lag_rtol r, the options the obstacles' friction reads; op lag) solve the step
   again with the pairs, weights, normals and forces taken at its result (the handles at tx; the
   slip still measured from x_n), at most N solves, until the same pairs are within dhat and no
   pair's normal force changed by more than r of the largest. */
#include <msim/implicit.h>
#include <msim/contact.h>
#include <msim/self_contact.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>
#include <algorithm>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: the lag kept for x_n at its state */
#include <cmath>

typedef struct {
  PetscReal                        mu, eps_v;
  MSimImplicitTerm                 self;  /* the self-contact term whose pairs these are */
  /* the lag: the step it belongs to (its x_n, at its state, and times), and per pair its free
     vertices' slots in dl (-1: fixed) */
  PetscObjectId                    xn_id;
  PetscObjectState                 xn_state;
  PetscReal                        t, tx, h2;
  PetscBool                        lagged;
  std::vector<MSimSelfContactPair> pairs;
  std::vector<PetscInt>            slot;   /* 4 per pair */
  std::vector<PetscInt>            gfree;  /* the slots' global free numbers, sorted */
  VecScatter                       scatter; /* state Vec -> dl */
  Vec                              dl, D;  /* the slots' displacements; X - x_n */
  std::vector<PetscReal>           d, g;
  MSimSelfHessian                  hess;   /* the Hessian's rows to their owners (msim/self_contact.h) */
  /* the lag iterations: at most lag_max solves a step (lags taken so far), to lag_rtol; next: the
     pairs at a solve's result, the candidate lag */
  PetscInt                         lag_max, lags;
  PetscReal                        lag_rtol;
  std::vector<MSimSelfContactPair> next;
} FrictionData;

/* the scatter of the pairs' free vertices (fd->pairs, just taken) into dl */
static PetscErrorCode PlanPairs(MSimImplicit imp, FrictionData *fd)
{
  IS is;

  PetscFunctionBeginUser;
  fd->gfree.clear();
  for (const MSimSelfContactPair &p : fd->pairs)
    for (int k = 0; k < 4; k++)
      if (p.gnum[k] >= 0) fd->gfree.push_back(p.gnum[k]);
  std::sort(fd->gfree.begin(), fd->gfree.end());
  fd->gfree.erase(std::unique(fd->gfree.begin(), fd->gfree.end()), fd->gfree.end());
  fd->slot.resize(4 * fd->pairs.size());
  for (size_t q = 0; q < fd->pairs.size(); q++)
    for (int k = 0; k < 4; k++) {
      const PetscInt gn = fd->pairs[q].gnum[k];
      fd->slot[4 * q + k] = gn < 0 ? -1 : (PetscInt)(std::lower_bound(fd->gfree.begin(), fd->gfree.end(), gn) - fd->gfree.begin());
    }
  PetscCall(VecScatterDestroy(&fd->scatter));
  PetscCall(VecDestroy(&fd->dl));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, 3 * (PetscInt)fd->gfree.size(), &fd->dl));
  PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, (PetscInt)fd->gfree.size(), fd->gfree.data(), PETSC_COPY_VALUES, &is));
  PetscCall(VecScatterCreate(imp->Xn, is, fd->dl, NULL, &fd->scatter));
  PetscCall(ISDestroy(&is));
  if (!fd->D) PetscCall(VecDuplicate(imp->Xn, &fd->D));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Lag(MSimImplicitTerm term, FrictionData *fd)
{
  MSimImplicit imp = term->imp;

  PetscObjectId    id;
  PetscObjectState state;

  PetscFunctionBeginUser;
  /* kept while the step is the same: its x_n (a new step, or one solved again from another start,
     changes it) and its times (a retry with a smaller h) */
  PetscCall(PetscObjectGetId((PetscObject)imp->Xn, &id));
  PetscCall(PetscObjectStateGet((PetscObject)imp->Xn, &state));
  if (fd->lagged && id == fd->xn_id && state == fd->xn_state && imp->step.t == fd->t && imp->step.tx == fd->tx && imp->step.h2 == fd->h2) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimSelfContactGetPairs(fd->self, imp->step.t, imp->Xn, fd->pairs));
  PetscCall(PlanPairs(imp, fd));
  fd->xn_id    = id;
  fd->xn_state = state;
  fd->t        = imp->step.t;
  fd->tx       = imp->step.tx;
  fd->h2       = imp->step.h2;
  fd->lagged = PETSC_TRUE;
  fd->lags   = 0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* f(q, lambda, P, u, y) for every lagged pair q of this rank, at X: lambda its lagged normal force
   (N), P its lagged tangent projector, u its slip P sum_k w_k (x_k - x_k^n), y = |u| */
template <class F>
static PetscErrorCode ForEachSliding(MSimImplicitTerm term, FrictionData *fd, Vec X, F &&f)
{
  MSimImplicit       imp = term->imp;
  const PetscReal   *vf  = imp->sys->fix_velocity, dt = imp->step.tx - imp->step.t;
  const PetscScalar *da;

  PetscFunctionBeginUser;
  PetscCall(Lag(term, fd));
  PetscCall(VecWAXPY(fd->D, -1.0, imp->Xn, X));
  PetscCall(VecScatterBegin(fd->scatter, fd->D, fd->dl, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(fd->scatter, fd->D, fd->dl, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(fd->dl, &da));
  for (size_t q = 0; q < fd->pairs.size(); q++) {
    const MSimSelfContactPair &p = fd->pairs[q];
    PetscReal                  rel[3] = {0, 0, 0}, P[9], u[3], y = 0;
    for (int k = 0; k < 4; k++) {
      const PetscInt s = fd->slot[4 * q + k];
      for (int c = 0; c < 3; c++) rel[c] += p.w[k] * (s >= 0 ? PetscRealPart(da[3 * s + c]) : vf[c] * dt);
    }
    for (int a = 0; a < 3; a++)
      for (int c = 0; c < 3; c++) P[3 * a + c] = (a == c) - p.n[a] * p.n[c];
    for (int a = 0; a < 3; a++) {
      u[a] = 0;
      for (int c = 0; c < 3; c++) u[a] += P[3 * a + c] * rel[c];
      y += u[a] * u[a];
    }
    f(q, p.force / fd->h2, P, u, std::sqrt(y));
  }
  PetscCall(VecRestoreArrayRead(fd->dl, &da));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode LocalEnergy(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  FrictionData   *fd = (FrictionData *)term->data;
  const PetscReal w = term->imp->step.h2 * fd->mu, eps = fd->eps_v * term->imp->step.h;

  PetscFunctionBeginUser;
  PetscCall(ForEachSliding(term, fd, X, [&](size_t, PetscReal lambda, const PetscReal *, const PetscReal *, PetscReal y) {
    *e += w * lambda * MSimFrictionF0(y, eps);
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += sign h2 mu lambda f1(y)/y w_k u, sent to the vertices' owners */
static PetscErrorCode AddGradient(MSimImplicitTerm term, Vec X, Vec G, PetscReal sign)
{
  FrictionData   *fd = (FrictionData *)term->data;
  const PetscReal w = term->imp->step.h2 * fd->mu, eps = fd->eps_v * term->imp->step.h;
  PetscScalar    *ga;

  PetscFunctionBeginUser;
  PetscCall(Lag(term, fd));
  fd->g.assign(3 * fd->gfree.size(), 0);
  PetscCall(ForEachSliding(term, fd, X, [&](size_t q, PetscReal lambda, const PetscReal *, const PetscReal *u, PetscReal y) {
    const PetscReal a = sign * w * lambda * MSimFrictionF1OverY(y, eps);
    for (int k = 0; k < 4; k++) {
      const PetscInt s = fd->slot[4 * q + k];
      if (s >= 0)
        for (int c = 0; c < 3; c++) fd->g[3 * s + c] += a * fd->pairs[q].w[k] * u[c];
    }
  }));
  PetscCall(VecGetArray(fd->dl, &ga));
  for (size_t k = 0; k < fd->g.size(); k++) ga[k] = fd->g[k];
  PetscCall(VecRestoreArray(fd->dl, &ga));
  PetscCall(VecScatterBegin(fd->scatter, fd->dl, G, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(fd->scatter, fd->dl, G, ADD_VALUES, SCATTER_REVERSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Hessian_SelfFriction(MSimImplicitTerm term, Vec X, PetscBool, Mat J)
{
  FrictionData    *fd = (FrictionData *)term->data;
  const PetscReal  w = term->imp->step.h2 * fd->mu, eps = fd->eps_v * term->imp->step.h;
  PetscErrorCode   ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  /* a lagged pair may join vertices no barrier block joins now: the system's matrix takes new
     entries when self-contact is on, and matrix.cpp rebuilds its assembly map when they come */
  PetscCall(MSimSelfHessianBegin(&fd->hess, J));
  PetscCall(ForEachSliding(term, fd, X, [&](size_t q, PetscReal lambda, const PetscReal *P, const PetscReal *u, PetscReal y) {
    const MSimSelfContactPair &p = fd->pairs[q];
    PetscScalar                H[144];
    PetscReal                  M[9];
    const PetscReal a = MSimFrictionF1OverY(y, eps), c = MSimFrictionHessianUU(y, eps);
    if (ierr) return;
    for (int r = 0; r < 3; r++)
      for (int s = 0; s < 3; s++) M[3 * r + s] = w * lambda * (a * P[3 * r + s] + c * u[r] * u[s]);
    for (int i = 0; i < 12; i++)
      for (int j = 0; j < 12; j++) H[12 * i + j] = p.w[i / 3] * p.w[j / 3] * M[3 * (i % 3) + j % 3];
    ierr = MSimSelfHessianAdd(&fd->hess, p.gnum, H);
  }));
  PetscCall(ierr);
  PetscCall(MSimSelfHessianEnd(&fd->hess, fd->scatter)); /* the pairs' free vertices are its leaves */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A lag iteration: the pairs at X (the handles at tx) against those the solve used, each list in
   the order of its pairs' vertices (the candidates' order otherwise; a tie keeps it, and at worst
   costs one more solve). Where the same pairs are within dhat and no pair's normal force vector
   changed by more than lag_rtol of the largest force, the solve stands; otherwise X's pairs are
   the lag for another solve, while lag_max allows one. */
static PetscErrorCode Lag_SelfFriction(MSimImplicitTerm term, Vec X, PetscBool *again)
{
  FrictionData *fd = (FrictionData *)term->data;
  MSimImplicit  imp = term->imp;

  PetscFunctionBeginUser;
  PetscCall(Lag(term, fd)); /* the step's, taken at x_n where the step is new */
  if (fd->lags + 1 >= fd->lag_max) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimSelfContactGetPairs(fd->self, imp->step.tx, X, fd->next));
  auto order = [](const std::vector<MSimSelfContactPair> &p) {
    std::vector<size_t> o(p.size());
    for (size_t k = 0; k < o.size(); k++) o[k] = k;
    std::stable_sort(o.begin(), o.end(), [&](size_t a, size_t b) { return std::lexicographical_compare(p[a].gnum, p[a].gnum + 4, p[b].gnum, p[b].gnum + 4); });
    return o;
  };
  const std::vector<size_t> oa = order(fd->pairs), ob = order(fd->next);
  PetscReal                 w[3] = {0, 0, (PetscReal)(oa.size() != ob.size())}; /* largest change, largest force, pairs differ */
  for (size_t k = 0; k < oa.size() && !w[2]; k++) {
    const MSimSelfContactPair &a = fd->pairs[oa[k]], &b = fd->next[ob[k]];
    PetscReal                  d2 = 0;
    if (!std::equal(a.gnum, a.gnum + 4, b.gnum)) w[2] = 1;
    for (int c = 0; c < 3; c++) d2 += PetscSqr(a.force * a.n[c] - b.force * b.n[c]);
    w[0] = PetscMax(w[0], PetscSqrtReal(d2));
    w[1] = PetscMax(w[1], PetscMax(a.force, b.force));
  }
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, w, 3, MPIU_REAL, MPIU_MAX, imp->sys->comm));
  if (!w[2] && w[0] <= fd->lag_rtol * w[1]) PetscFunctionReturn(PETSC_SUCCESS);
  fd->pairs.swap(fd->next);
  PetscCall(PlanPairs(imp, fd));
  fd->lags++;
  *again = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_SelfFriction(MSimImplicitTerm term, PetscViewer viewer)
{
  FrictionData *fd = (FrictionData *)term->data;

  PetscFunctionBeginUser;
  if (fd->lag_max > 1) PetscCall(PetscViewerASCIIPrintf(viewer, "self-friction: mu %g between the surface's pairs in self-contact, normal forces and tangents lagged up to %" PetscInt_FMT " solves a step (relative tolerance %g), smoothing eps_v %g m/s\n", (double)fd->mu, fd->lag_max, (double)fd->lag_rtol, (double)fd->eps_v));
  else PetscCall(PetscViewerASCIIPrintf(viewer, "self-friction: mu %g between the surface's pairs in self-contact, normal forces and tangents lagged at each step's start, smoothing eps_v %g m/s\n", (double)fd->mu, (double)fd->eps_v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_SelfFriction(MSimImplicitTerm term)
{
  FrictionData *fd = (FrictionData *)term->data;

  PetscFunctionBeginUser;
  PetscCall(VecScatterDestroy(&fd->scatter));
  PetscCall(VecDestroy(&fd->dl));
  PetscCall(VecDestroy(&fd->D));
  PetscCall(MSimSelfHessianDestroy(&fd->hess));
  delete fd;
  term->data = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimImplicitTermOps SelfFrictionOps = {.energy = MSimTermSummedEnergy<LocalEnergy>, .gradient = MSimTermGradient<AddGradient>, .hessian = Hessian_SelfFriction, .pd_rhs = MSimTermPDRHS<LocalEnergy, AddGradient>, .lag = Lag_SelfFriction, .view = View_SelfFriction, .destroy = Destroy_SelfFriction};

PetscErrorCode MSimImplicitTermCreate_SelfFriction(MSimImplicitTerm term)
{
  MSimImplicit   imp  = term->imp;
  MSimImplicitTerm self = NULL;
  PetscContainer container;
  MSimContact    ct = NULL;

  PetscFunctionBeginUser;
  for (PetscInt k = 0; k < imp->nterms; k++) {
    PetscBool same;
    PetscCall(PetscStrcmp(imp->terms[k]->type, "self_contact", &same));
    if (same && imp->terms[k]->data) self = imp->terms[k];
  }
  if (!self) PetscFunctionReturn(PETSC_SUCCESS); /* no self-contact (or it comes later in -msim_implicit_terms): no op */
  /* -msim_friction and -msim_friction_eps are the contact object's options, read (and kept) even
     where there is no obstacle, when MSimContactGet returns NULL */
  PetscCall(MSimContactGet(imp->sys, &ct));
  PetscCall(PetscObjectQuery((PetscObject)imp->sys->X0, "MSimContact", (PetscObject *)&container));
  if (container) PetscCall(PetscContainerGetPointer(container, (void **)&ct));
  if (!ct || ct->mu == 0) PetscFunctionReturn(PETSC_SUCCESS);
  FrictionData *fd = new FrictionData();
  fd->mu           = ct->mu;
  fd->eps_v        = ct->eps_v;
  fd->self         = self;
  PetscCall(MSimFrictionLagOptions(imp->sys, &fd->lag_max, &fd->lag_rtol));
  term->data       = fd;
  term->ops        = SelfFrictionOps;
  PetscCall(MSimSelfHessianCreate(imp->sys->comm, &fd->hess));
  PetscFunctionReturn(PETSC_SUCCESS);
}
