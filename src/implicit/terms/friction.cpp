/* Coulomb friction with the obstacles as IPC's lagged, smoothed dissipative potential (Li et al.
   2020, sec. 5): for each free vertex v within dhat of an obstacle at x_n, with the normal n and
   the normal force lambda = kappa m |b'(d)| of the barrier there (lagged: fixed over the step),
   the tangential displacement over the step u = P (x - x_n), P = I - n n^T, and
     D = beta h^2 mu lambda f0(|u|),   f0' = f1,   f1(y) = 2 y/eps - y^2/eps^2 (y < eps), 1 beyond,
   eps = eps_v h (-msim_friction_eps): a sliding vertex feels mu lambda against its slip, one
   slower than eps_v is held by a stiff spring-like force. Gradient beta h^2 mu lambda f1(y)/y u;
   the Hessian beta h^2 mu lambda [f1(y)/y P + (f1'(y) y - f1(y))/y^3 u u^T] is PSD as it is (in
   the tangent plane its eigenvalues are f1'(y) >= 0 along u and f1(y)/y across), so no
   projection. Everything lagged (the vertices within dhat at x_n, lambda, P and the obstacle's
   shift) is computed once per step (and per lag iteration) and kept (Lagged: keyed by x_n's id
   and state, the step's times and kappa, so a restart or a new step recomputes it; the same
   numbers as the per-call loop of msim/private/contactimpl.h, which cost 2 queries per vertex
   and obstacle per PD iteration: +35% of a free PD step on the 101 x 101 drape,
   runs/contact/README.md). It leaves
   x_n, the lag point and the step's times on the contact object so that the output's force at the
   step's result includes the friction that acted (src/contact/contact_force.cpp).
   Lagged at x_n alone, a step that leaves the obstacle keeps x_n's friction to its end (2 N on a
   cloth with no vertex within dhat at the step's result) and one that lands has none, so a load
   that should stick slides a distance that grows with h. IPC's lag iterations
   (-msim_friction_lag_iterations N, op lag): the integrator solves the step again from its result
   with lambda and P taken there (the obstacles at tx; u still measured from x_n), at most N
   solves, until the normal forces change by less than -msim_friction_lag_rtol of the largest with
   the same vertices in contact (examples/cloth_sphere.opts: 461 -> 1455 Newton iterations at
   N = 10, 3x the time). N = 1, the default, is the lag at x_n alone. PD: its gradient at the
   current iterate in the right-hand side, as the barrier's. A moving obstacle
   (-msim_contact_velocity) drags: the slip u is the displacement relative to it, P (x - x_n -
   v_o (tx - t)). */
#include <msim/implicit.h>
#include <msim/contact.h>
#include <msim/options.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>
#include <cmath>
#include <vector>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: x_n's lagged data kept for the step */

/* the lag point's part of the loop, for one solve: per owned vertex and obstacle in contact there
   (in MSimContactForEachSliding's order), lambda, P, the obstacle's velocity v_o and the normal
   force f n (lambda along the unit normal), which the lag iterations compare */
typedef struct {
  PetscInt  v;
  PetscReal lambda, P[9], vo[3], fn[3];
} Sliding;

typedef struct {
  std::vector<Sliding> s, next; /* the solve's; a lag iteration's candidate */
  PetscObjectId        id    = 0; /* x_n's, at its state: 0 none yet */
  PetscObjectState     state = 0;
  PetscReal            t = 0, tx = 0, kappa = 0;
  /* per owned vertex, where its distances were last computed (anchor) and their least less dhat
     and a roundoff margin (ex), as the obstacles term keeps them: the distance is 1-Lipschitz, so
     a point within ex of the anchor is beyond dhat of every obstacle and not queried (the query of
     every vertex at each step was 1.2 M instructions of a 123 M PD-10 step of the 101 x 101 drape,
     runs/contact/README.md). Static analytic obstacles only: a moving one's distances hold at one
     t, and a mesh keeps per-vertex answers that its later queries start from. */
  std::vector<PetscReal> anchor, ex;
  /* IPC's lag iterations: at most lag_max solves a step, the lag taken again at each solve's
     result until the normal forces there are within lag_rtol of those the solve used (the
     largest per-vertex change against the largest force) with the same vertices in contact.
     lags: the lags taken this step; xl, tl: the lag point and the obstacles' time there (x_n at
     t until the first lag; xl made then) */
  PetscInt  lag_max = 1, lags = 0;
  PetscReal lag_rtol = 0, tl = 0;
  Vec       xl = NULL;
} Lagged;

/* into s, the contacts at the point xp (the obstacles at time tp): the same expressions as
   MSimContactForEachSliding's */
static void Collect(MSimSystem sys, MSimContact ct, Lagged *L, const PetscScalar *xp, const PetscScalar *m, PetscReal tp, std::vector<Sliding> &s)
{
  auto add = [&](PetscInt v, const MSimObstacle &o, PetscReal d, const PetscReal *n, const PetscReal *) {
    PetscReal e, de, d2e;
    Sliding   q;
    if (d <= 0) return;
    MSimBarrier(d, ct->dhat, &e, &de, &d2e);
    q.v                 = v;
    const PetscReal f   = ct->kappa * PetscRealPart(m[3 * v]) * PetscAbsReal(de);
    MSimFrictionNormal(f, n, &q.lambda, q.P);
    for (int c = 0; c < 3; c++) {
      q.vo[c] = o.v[c];
      q.fn[c] = f * n[c]; /* lambda n / |n| (MSimFrictionNormal) */
    }
    s.push_back(q);
  };
  s.clear();
  if (ct->moving) {
    MSimContactForEachNear(ct, sys->nown, xp, tp, ct->dhat, PETSC_FALSE, add);
    return;
  }
  /* MSimContactForEachNear's queries, in its order, less the vertices within ex of their anchors.
     A mesh answers "band" beyond band, which would leave no ball to skip in, but knows a larger
     lower bound there (MSimContactAnchorVertex, the barrier's anchors' query too): each
     step's x_n queries on the 101 x 101 drape on the 20,480-triangle ball were 1.7 M instructions
     of its 114 M PD-10 step, most of them for vertices far from the mesh */
  if ((PetscInt)L->ex.size() != sys->nown) {
    L->anchor.assign(3 * sys->nown, 0.0);
    L->ex.assign(sys->nown, -PETSC_MAX_REAL);
  }
  for (PetscInt v = 0; v < sys->nown; v++) {
    const PetscReal *an = L->anchor.data() + 3 * v, ev = L->ex[v];
    const PetscReal  dx = xp[3 * v] - an[0], dy = xp[3 * v + 1] - an[1], dz = xp[3 * v + 2] - an[2];
    if (ev > 0 && dx * dx + dy * dy + dz * dz <= ev * ev) continue;
    L->ex[v] = MSimContactAnchorVertex(ct, v, xp + 3 * v, tp, PETSC_FALSE, L->anchor.data() + 3 * v, NULL, [&](const MSimObstacle &o, PetscReal d, const PetscReal *n, const PetscReal *) { add(v, o, d, n, NULL); }); /* each contact, a mesh's creases' too */
  }
}

/* the solve's lagged data, taken at x_n where x_n (its id or state), the step's times or kappa
   changed since it was kept (a new step, whose lag starts afresh) */
static PetscErrorCode GetLagged(MSimImplicitTerm term, MSimContact ct, const Lagged **lag)
{
  MSimImplicit     imp = term->imp;
  MSimSystem       sys = imp->sys;
  Lagged          *L   = (Lagged *)term->data;
  PetscObjectId    id;
  PetscObjectState state;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectGetId((PetscObject)imp->Xn, &id));
  PetscCall(PetscObjectStateGet((PetscObject)imp->Xn, &state));
  if (id != L->id || state != L->state || imp->step.t != L->t || imp->step.tx != L->tx || ct->kappa != L->kappa) {
    const PetscScalar *xn, *m;
    PetscCall(VecGetArrayRead(imp->Xn, &xn));
    PetscCall(VecGetArrayRead(sys->mass, &m));
    Collect(sys, ct, L, xn, m, imp->step.t, L->s);
    PetscCall(VecRestoreArrayRead(sys->mass, &m));
    PetscCall(VecRestoreArrayRead(imp->Xn, &xn));
    L->id    = id;
    L->state = state;
    L->t     = imp->step.t;
    L->tx    = imp->step.tx;
    L->kappa = ct->kappa;
    L->lags  = 0;
    L->tl    = L->t;
  }
  *lag = L;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* f(v, lambda, P (3 x 3), u, y) for every owned vertex and obstacle in contact at x_n, from the
   step's lagged data (u and y as MSimContactForEachSliding computes them, which the output's
   contact force uses); leaves the step's x_n and times on the contact object for that output */
template <class F>
static PetscErrorCode ForEachSliding(MSimImplicitTerm term, MSimContact ct, Vec X, F &&f)
{
  MSimImplicit       imp = term->imp;
  const PetscScalar *x, *xn;
  const Lagged      *L;

  PetscFunctionBeginUser;
  PetscCall(GetLagged(term, ct, &L));
  ct->fr_xn = imp->Xn;
  ct->fr_t  = imp->step.t;
  ct->fr_tx = imp->step.tx;
  ct->fr_h  = imp->step.h;
  ct->fr_xl = L->lags ? L->xl : imp->Xn;
  ct->fr_tl = L->tl;
  const PetscReal t = L->t, tx = L->tx;
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(imp->Xn, &xn));
  for (const Sliding &q : L->s) {
    const PetscInt v = q.v;
    PetscReal      u[3], y = 0;
    for (int a = 0; a < 3; a++) {
      u[a] = 0;
      for (int c = 0; c < 3; c++) u[a] += q.P[3 * a + c] * PetscRealPart(x[3 * v + c] - xn[3 * v + c] - q.vo[c] * (tx - t)); /* as MSimContactForEachSliding's expression */
      y += u[a] * u[a];
    }
    f(v, q.lambda, q.P, u, std::sqrt(y));
  }
  PetscCall(VecRestoreArrayRead(imp->Xn, &xn));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* *ct NULL where the obstacles became VI bounds after this term was made (msim/contact_bounds.h):
   they give no normal force, so friction with them is nothing (self-contact's is its own term) */
static PetscErrorCode Contact(MSimImplicitTerm term, MSimContact *ct)
{
  PetscFunctionBeginUser;
  PetscCall(MSimContactGetForStep(term->imp->sys, term->imp->step.h2, ct)); /* the barrier term sets kappa; friction alone uses the same rule */
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode LocalEnergy(MSimImplicitTerm term, MSimContact ct, Vec X, PetscReal *e)
{
  const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h;

  PetscFunctionBeginUser;
  PetscCall(ForEachSliding(term, ct, X, [&](PetscInt, PetscReal lambda, const PetscReal *, const PetscReal *, PetscReal y) {
    *e += w * lambda * MSimFrictionF0(y, eps);
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Energy_Friction(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  MSimContact ct;
  PetscReal   local = 0;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (ct) PetscCall(LocalEnergy(term, ct, X, &local));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, term->imp->sys->comm));
  *e += local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += sign h2 mu lambda f1(y)/y u */
static PetscErrorCode AddGradient(MSimImplicitTerm term, MSimContact ct, Vec X, Vec G, PetscReal sign)
{
  const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h;

  return MSimContactAddToVec(G, [&](PetscScalar *g) {
    return ForEachSliding(term, ct, X, [&](PetscInt v, PetscReal lambda, const PetscReal *, const PetscReal *u, PetscReal y) {
      const PetscReal f1y = MSimFrictionF1OverY(y, eps);
      for (int c = 0; c < 3; c++) g[3 * v + c] += sign * w * lambda * f1y * u[c];
    });
  });
}

static PetscErrorCode Gradient_Friction(MSimImplicitTerm term, Vec X, Vec G)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (ct) PetscCall(AddGradient(term, ct, X, G, 1.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Hessian_Friction(MSimImplicitTerm term, Vec X, PetscBool psd, Mat J)
{
  MSimSystem     sys = term->imp->sys;
  MSimContact    ct;
  PetscErrorCode ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h;
  PetscCall(ForEachSliding(term, ct, X, [&](PetscInt v, PetscReal lambda, const PetscReal *P, const PetscReal *u, PetscReal y) {
    PetscScalar blk[9];
    PetscInt    idx[3];
    /* f1(y)/y and (f1'(y) y - f1(y)) / y^3 */
    const PetscReal a = MSimFrictionF1OverY(y, eps);
    const PetscReal c = MSimFrictionHessianUU(y, eps);
    for (int r = 0; r < 3; r++) {
      idx[r] = 3 * (sys->rstart + v) + r;
      for (int s = 0; s < 3; s++) blk[3 * r + s] = w * lambda * (a * P[3 * r + s] + c * u[r] * u[s]);
    }
    if (!ierr) ierr = MatSetValues(J, 3, idx, 3, idx, blk, ADD_VALUES);
  }));
  PetscCall(ierr);
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDRHS_Friction(MSimImplicitTerm term, Vec X, Vec rhs, PetscReal *e)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  if (!e) PetscCall(AddGradient(term, ct, X, rhs, -1.0));
  else {
    /* AddGradient's and LocalEnergy's terms in one pass over the sliding vertices (same order) */
    const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h, sign = -1.0;
    PetscCall(MSimContactAddToVec(rhs, [&](PetscScalar *g) {
      return ForEachSliding(term, ct, X, [&](PetscInt v, PetscReal lambda, const PetscReal *, const PetscReal *u, PetscReal y) {
        const PetscReal f1y = MSimFrictionF1OverY(y, eps);
        for (int c = 0; c < 3; c++) g[3 * v + c] += sign * w * lambda * f1y * u[c];
        *e += w * lambda * MSimFrictionF0(y, eps);
      });
    }));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A lag iteration: the contacts at X (the obstacles at tx) against those the solve used. Where the
   same vertices are in contact and no vertex's normal force changed by more than lag_rtol of the
   largest force of either, the solve stands (and the output reports the forces it used);
   otherwise X becomes the lag point for another solve, while lag_max allows one. */
static PetscErrorCode Lag_Friction(MSimImplicitTerm term, Vec X, PetscBool *again)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  MSimContact        ct;
  const Lagged      *Lc;
  const PetscScalar *x, *m;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(GetLagged(term, ct, &Lc)); /* the step's, taken at x_n where the step is new */
  Lagged *L = (Lagged *)term->data;
  if (L->lags + 1 >= L->lag_max) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  Collect(sys, ct, L, x, m, imp->step.tx, L->next);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(X, &x));
  /* per vertex, the summed normal force of each list: [0] the solve's, [1] X's */
  std::vector<PetscReal> f[2];
  PetscReal              w[3] = {0, 0, 0}; /* largest change, largest force, contacts differ */
  for (int k = 0; k < 2; k++) {
    f[k].assign(3 * sys->nown, 0.0);
    for (const Sliding &q : k ? L->next : L->s)
      for (int c = 0; c < 3; c++) f[k][3 * q.v + c] += q.fn[c];
  }
  w[2] = L->s.size() != L->next.size();
  for (size_t k = 0; k < L->s.size() && !w[2]; k++) w[2] = L->s[k].v != L->next[k].v;
  for (PetscInt v = 0; v < sys->nown; v++) {
    PetscReal d2 = 0, a2 = 0, b2 = 0;
    for (int c = 0; c < 3; c++) {
      const PetscReal a = f[0][3 * v + c], b = f[1][3 * v + c];
      d2 += (a - b) * (a - b);
      a2 += a * a;
      b2 += b * b;
    }
    w[0] = PetscMax(w[0], PetscSqrtReal(d2));
    w[1] = PetscMax(w[1], PetscSqrtReal(PetscMax(a2, b2)));
  }
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, w, 3, MPIU_REAL, MPIU_MAX, sys->comm));
  if (!w[2] && w[0] <= L->lag_rtol * w[1]) PetscFunctionReturn(PETSC_SUCCESS);
  if (!L->xl) PetscCall(VecDuplicate(imp->Xn, &L->xl));
  PetscCall(VecCopy(X, L->xl));
  L->s.swap(L->next);
  L->tl = imp->step.tx;
  L->lags++;
  *again = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_Friction(MSimImplicitTerm term, PetscViewer viewer)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  const Lagged *L = (const Lagged *)term->data;
  if (ct && L->lag_max > 1) PetscCall(PetscViewerASCIIPrintf(viewer, "friction: mu %g, normal forces lagged up to %" PetscInt_FMT " solves a step (relative tolerance %g), smoothing eps_v %g m/s\n", (double)ct->mu, L->lag_max, (double)L->lag_rtol, (double)ct->eps_v));
  else if (ct) PetscCall(PetscViewerASCIIPrintf(viewer, "friction: mu %g, normal forces lagged at the step's start, smoothing eps_v %g m/s\n", (double)ct->mu, (double)ct->eps_v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the output's force must not read this problem's x_n once the problem is gone */
static PetscErrorCode Destroy_Friction(MSimImplicitTerm term)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  Lagged *L = (Lagged *)term->data;
  if (ct && ct->fr_xn == term->imp->Xn) ct->fr_xn = ct->fr_xl = NULL;
  PetscCall(VecDestroy(&L->xl));
  delete L;
  term->data = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimImplicitTermOps FrictionOps = {.energy = Energy_Friction, .gradient = Gradient_Friction, .hessian = Hessian_Friction, .pd_rhs = PDRHS_Friction, .lag = Lag_Friction, .view = View_Friction, .destroy = Destroy_Friction};

/* The lag's options, for the obstacles' friction and self-friction (terms/self_friction.cpp) */
PetscErrorCode MSimFrictionLagOptions(MSimSystem sys, PetscInt *lag_max, PetscReal *lag_rtol)
{
  PetscBool set_max, set_rtol;

  PetscFunctionBeginUser;
  *lag_max  = 1;
  *lag_rtol = 1e-2;
  PetscOptionsBegin(sys->comm, NULL, "msim friction", NULL);
  PetscCall(MSimOptionsInt("-msim_friction_lag_iterations", "Friction (with obstacles, and between surfaces in self-contact): at most this many solves a step, each taking the normal forces and tangent bases at the previous one's result (IPC's lag iterations) until they change by less than -msim_friction_lag_rtol with the same contacts; 1: taken at the step's start only, so a step that lands has no friction and one that leaves keeps it", NULL, *lag_max, lag_max, &set_max));
  PetscCall(MSimOptionsReal("-msim_friction_lag_rtol", "Friction's lag iterations: done once no contact's normal force changed by more than this fraction of the largest one (and the same contacts are there)", NULL, *lag_rtol, lag_rtol, &set_rtol));
  PetscOptionsEnd();
  PetscCheck(*lag_max >= 1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_friction_lag_iterations must be >= 1 (got %" PetscInt_FMT ")", *lag_max);
  PetscCheck(*lag_rtol >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_friction_lag_rtol must be >= 0 (got %g)", (double)*lag_rtol);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The lag's options are read by every implicit problem, so that -help lists them, and refused
   where there is no friction for them to act on: with an obstacle, or between surfaces in
   self-contact (the contact object carries -msim_friction even where there is no obstacle) */
PetscErrorCode MSimImplicitTermCreate_Friction(MSimImplicitTerm term)
{
  MSimSystem     sys = term->imp->sys;
  MSimContact    ct, any = NULL;
  PetscContainer container;
  PetscInt       lag_max;
  PetscReal      lag_rtol;
  PetscBool      set_max, set_rtol;

  PetscFunctionBeginUser;
  PetscCall(MSimFrictionLagOptions(sys, &lag_max, &lag_rtol));
  PetscCall(PetscOptionsHasName(NULL, NULL, "-msim_friction_lag_iterations", &set_max));
  PetscCall(PetscOptionsHasName(NULL, NULL, "-msim_friction_lag_rtol", &set_rtol));
  PetscCall(MSimContactGet(sys, &ct));
  PetscCall(PetscObjectQuery((PetscObject)sys->X0, "MSimContact", (PetscObject *)&container));
  if (container) PetscCall(PetscContainerGetPointer(container, (void **)&any));
  const PetscBool self_friction = (PetscBool)(sys->self_contact.on && any && any->mu > 0);
  PetscCheck((ct && ct->mu > 0) || self_friction || !(set_max || set_rtol), sys->comm, PETSC_ERR_ARG_WRONG, "%s acts on friction (-msim_friction > 0 with -msim_contact_plane, _sphere, _box or _mesh, or with -msim_self_contact), and there is none", set_max ? "-msim_friction_lag_iterations" : "-msim_friction_lag_rtol");
  if (!ct || ct->mu == 0) PetscFunctionReturn(PETSC_SUCCESS); /* nothing per iteration */
  Lagged *L   = new Lagged();
  L->lag_max  = lag_max;
  L->lag_rtol = lag_rtol;
  term->data  = L;
  term->ops   = FrictionOps;
  PetscFunctionReturn(PETSC_SUCCESS);
}
