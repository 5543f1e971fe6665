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
   shift) is computed once per step and kept (Lagged: keyed by x_n's id and state, the step's
   times and kappa, so a restart or a new step recomputes it; the same numbers as the per-call
   loop of msim/private/contactimpl.h, which cost 2 queries per vertex and obstacle per PD
   iteration: +35% of a free PD step on the 101 x 101 drape, runs/contact/README.md). It leaves
   x_n and the step's times on the contact object so that the output's force at the step's result
   includes friction (src/contact/contact_force.cpp). PD: its
   gradient at the current iterate in the right-hand side, as the barrier's. A moving obstacle
   (-msim_contact_velocity) drags: the slip u is the displacement relative to it, P (x - x_n -
   v_o (tx - t)). */
#include <msim/implicit.h>
#include <msim/contact.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>
#include <cmath>
#include <vector>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: x_n's lagged data kept for the step */

/* x_n's part of the loop, for one step: per owned vertex and obstacle in contact at x_n (in
   MSimContactForEachSliding's order), lambda, P and the obstacle's velocity v_o */
typedef struct {
  PetscInt  v;
  PetscReal lambda, P[9], vo[3];
} Sliding;

typedef struct {
  std::vector<Sliding> s;
  PetscObjectId        id    = 0; /* x_n's, at its state: 0 none yet */
  PetscObjectState     state = 0;
  PetscReal            t = 0, tx = 0, kappa = 0;
  /* per owned vertex, where x_n's distances were last computed (anchor) and their least less dhat
     and a roundoff margin (ex), as the obstacles term keeps them: the distance is 1-Lipschitz, so
     an x_n within ex of the anchor is beyond dhat of every obstacle and not queried (the query of
     every vertex at each step was 1.2 M instructions of a 123 M PD-10 step of the 101 x 101 drape,
     runs/contact/README.md). Static analytic obstacles only: a moving one's distances hold at one
     t, and a mesh keeps per-vertex answers that its later queries start from. */
  std::vector<PetscReal> anchor, ex;
} Lagged;

/* the step's lagged data, recomputed where x_n (its id or state), the step's times or kappa
   changed since it was kept: the same expressions as MSimContactForEachSliding's */
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
    const PetscReal    t = imp->step.t;
    auto add = [&](PetscInt v, const MSimObstacle &o, PetscReal d, const PetscReal *n, const PetscReal *) {
      PetscReal e, de, d2e;
      Sliding   q;
      if (d <= 0) return;
      MSimBarrier(d, ct->dhat, &e, &de, &d2e);
      q.v      = v;
      MSimFrictionNormal(ct->kappa * PetscRealPart(m[3 * v]) * PetscAbsReal(de), n, &q.lambda, q.P);
      for (int c = 0; c < 3; c++) q.vo[c] = o.v[c];
      L->s.push_back(q);
    };
    const PetscBool skip = (PetscBool)!ct->moving;
    L->s.clear();
    PetscCall(VecGetArrayRead(imp->Xn, &xn));
    PetscCall(VecGetArrayRead(sys->mass, &m));
    if (!skip) MSimContactForEachNear(ct, sys->nown, xn, t, ct->dhat, PETSC_FALSE, add);
    else {
      /* MSimContactForEachNear's queries, in its order, less the vertices within ex of their
         anchors. A mesh answers "band" beyond band, which would leave no ball to skip in, but
         knows a larger lower bound there (MSimMeshObstacleVertexClearance, as the barrier's anchors
         take it): each step's x_n queries on the 101 x 101 drape on the 20,480-triangle ball were
         1.7 M instructions of its 114 M PD-10 step, most of them for vertices far from the mesh */
      if ((PetscInt)L->ex.size() != sys->nown) {
        L->anchor.assign(3 * sys->nown, 0.0);
        L->ex.assign(sys->nown, -PETSC_MAX_REAL);
      }
      for (PetscInt v = 0; v < sys->nown; v++) {
        const PetscReal *an = L->anchor.data() + 3 * v, ev = L->ex[v];
        const PetscReal  dx = xn[3 * v] - an[0], dy = xn[3 * v + 1] - an[1], dz = xn[3 * v + 2] - an[2];
        PetscReal        dmin = PETSC_MAX_REAL, xmax = 0;
        if (ev > 0 && dx * dx + dy * dy + dz * dz <= ev * ev) continue;
        for (const MSimObstacle &o : ct->obs) {
          const PetscReal d = MSimObstacleContacts(o, v, xn + 3 * v, t, ct->dhat, PETSC_FALSE, [&](PetscReal dc, const PetscReal *n, const PetscReal *) { add(v, o, dc, n, NULL); }); /* each contact, a mesh's creases' too */
          if (o.kind == MSIM_OBSTACLE_MESH && d >= ct->dhat) {
            const PetscReal y[3] = {xn[3 * v] - o.v[0] * t, xn[3 * v + 1] - o.v[1] * t, xn[3 * v + 2] - o.v[2] * t}; /* MSimObstacleContacts' point */
            dmin                 = PetscMin(dmin, PetscMax(d, MSimMeshObstacleVertexClearance(o.mesh, v, y)));
          } else dmin = PetscMin(dmin, d);
        }
        for (int c = 0; c < 3; c++) {
          L->anchor[3 * v + c] = xn[3 * v + c];
          xmax                 = PetscMax(xmax, PetscAbsReal(xn[3 * v + c]));
        }
        L->ex[v] = MSimContactAnchorExcess(dmin, ct->dhat, xmax);
      }
    }
    PetscCall(VecRestoreArrayRead(sys->mass, &m));
    PetscCall(VecRestoreArrayRead(imp->Xn, &xn));
    L->id    = id;
    L->state = state;
    L->t     = t;
    L->tx    = imp->step.tx;
    L->kappa = ct->kappa;
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
  ct->fr_xn = imp->Xn;
  ct->fr_t  = imp->step.t;
  ct->fr_tx = imp->step.tx;
  ct->fr_h  = imp->step.h;
  PetscCall(GetLagged(term, ct, &L));
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

static PetscErrorCode View_Friction(MSimImplicitTerm term, PetscViewer viewer)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  if (ct) PetscCall(PetscViewerASCIIPrintf(viewer, "friction: mu %g, lagged normal forces, smoothing eps_v %g m/s\n", (double)ct->mu, (double)ct->eps_v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the output's force must not read this problem's x_n once the problem is gone */
static PetscErrorCode Destroy_Friction(MSimImplicitTerm term)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  if (ct && ct->fr_xn == term->imp->Xn) ct->fr_xn = NULL;
  delete (Lagged *)term->data;
  term->data = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimImplicitTermOps FrictionOps = {.energy = Energy_Friction, .gradient = Gradient_Friction, .hessian = Hessian_Friction, .pd_rhs = PDRHS_Friction, .view = View_Friction, .destroy = Destroy_Friction};

PetscErrorCode MSimImplicitTermCreate_Friction(MSimImplicitTerm term)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  if (!ct || ct->mu == 0) PetscFunctionReturn(PETSC_SUCCESS); /* nothing per iteration */
  term->data = new Lagged();
  term->ops  = FrictionOps;
  PetscFunctionReturn(PETSC_SUCCESS);
}
