/* Coulomb friction with the obstacles as IPC's lagged, smoothed dissipative potential (Li et al.
   2020, sec. 5): for each free vertex v within dhat of an obstacle at x_n, with the normal n and
   the normal force lambda = kappa m |b'(d)| of the barrier there (lagged: fixed over the step),
   the tangential displacement over the step u = P (x - x_n), P = I - n n^T, and
     D = beta h^2 mu lambda f0(|u|),   f0' = f1,   f1(y) = 2 y/eps - y^2/eps^2 (y < eps), 1 beyond,
   eps = eps_v h (-msim_friction_eps): a sliding vertex feels mu lambda against its slip, one
   slower than eps_v is held by a stiff spring-like force. Gradient beta h^2 mu lambda f1(y)/y u;
   the Hessian beta h^2 mu lambda [f1(y)/y P + (f1'(y) y - f1(y))/y^3 u u^T] is PSD as it is (in
   the tangent plane its eigenvalues are f1'(y) >= 0 along u and f1(y)/y across), so no
   projection. Everything lagged is recomputed from x_n per call: no state, no step hook. PD: its
   gradient at the current iterate in the right-hand side, as the barrier's. A moving obstacle
   (-msim_contact_velocity) drags: the slip u is the displacement relative to it, P (x - x_n -
   v_o (tx - t)). */
#include <msim/implicit.h>
#include <msim/contact.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>
#include <cmath>

/* f(v, lambda, P (3 x 3), u, y) for every owned vertex and obstacle in contact at x_n */
template <class F>
static PetscErrorCode ForEachSliding(MSimImplicitTerm term, MSimContact ct, Vec X, F &&f)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const PetscScalar *x, *xn, *m;

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(imp->Xn, &xn));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt v = 0; v < sys->nown; v++)
    for (const MSimObstacle &o : ct->obs) {
      PetscReal       n[3], P[9], u[3], b, db, d2b, y = 0;
      const PetscReal d  = MSimObstacleDistanceAt(&o, imp->step.t, xn + 3 * v, n, NULL); /* x_n with the obstacle at t */
      const PetscReal dt = imp->step.tx - imp->step.t;
      if (d >= ct->dhat || d <= 0) continue;
      MSimBarrier(d, ct->dhat, &b, &db, &d2b);
      const PetscReal lambda = ct->kappa * PetscRealPart(m[3 * v]) * PetscAbsReal(db);
      for (int a = 0; a < 3; a++)
        for (int c = 0; c < 3; c++) P[3 * a + c] = (a == c) - n[a] * n[c];
      for (int a = 0; a < 3; a++) {
        u[a] = 0;
        for (int c = 0; c < 3; c++) u[a] += P[3 * a + c] * (x[3 * v + c] - xn[3 * v + c] - o.v[c] * dt); /* slip relative to the obstacle */
        y += u[a] * u[a];
      }
      f(v, lambda, P, u, std::sqrt(y));
    }
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Xn, &xn));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Contact(MSimImplicitTerm term, MSimContact *ct)
{
  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, ct));
  if (*ct && (*ct)->kappa == 0) { /* the barrier term sets it; friction alone uses the same rule */
    PetscReal b, db, d2b;
    MSimBarrier(0.5 * (*ct)->dhat, (*ct)->dhat, &b, &db, &d2b);
    (*ct)->kappa = 1.0 / (term->imp->step.h2 * d2b);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode LocalEnergy(MSimImplicitTerm term, MSimContact ct, Vec X, PetscReal *e)
{
  const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h;

  PetscFunctionBeginUser;
  PetscCall(ForEachSliding(term, ct, X, [&](PetscInt, PetscReal lambda, const PetscReal *, const PetscReal *, PetscReal y) {
    const PetscReal f0 = y < eps ? -y * y * y / (3 * eps * eps) + y * y / eps + eps / 3 : y;
    *e += w * lambda * f0;
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Energy_Friction(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  MSimContact ct;
  PetscReal   local = 0;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  PetscCall(LocalEnergy(term, ct, X, &local));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, term->imp->sys->comm));
  *e += local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += sign h2 mu lambda f1(y)/y u; the friction force joins the recorded contact force */
static PetscErrorCode AddGradient(MSimImplicitTerm term, MSimContact ct, Vec X, Vec G, PetscReal sign)
{
  const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h;
  PetscScalar    *g;

  PetscFunctionBeginUser;
  PetscCall(VecGetArray(G, &g));
  PetscCall(ForEachSliding(term, ct, X, [&](PetscInt v, PetscReal lambda, const PetscReal *, const PetscReal *u, PetscReal y) {
    const PetscReal f1y = y < eps ? 2 / eps - y / (eps * eps) : 1 / y; /* f1(y) / y */
    for (int c = 0; c < 3; c++) {
      g[3 * v + c] += sign * w * lambda * f1y * u[c];
      ct->force[c] -= ct->mu * lambda * f1y * u[c];
    }
  }));
  PetscCall(VecRestoreArray(G, &g));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Gradient_Friction(MSimImplicitTerm term, Vec X, Vec G)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  PetscCall(AddGradient(term, ct, X, G, 1.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Hessian_Friction(MSimImplicitTerm term, Vec X, PetscBool psd, Mat J)
{
  MSimSystem     sys = term->imp->sys;
  MSimContact    ct;
  PetscErrorCode ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  const PetscReal w = term->imp->step.h2 * ct->mu, eps = ct->eps_v * term->imp->step.h;
  PetscCall(ForEachSliding(term, ct, X, [&](PetscInt v, PetscReal lambda, const PetscReal *P, const PetscReal *u, PetscReal y) {
    PetscScalar blk[9];
    PetscInt    idx[3];
    /* f1(y)/y and (f1'(y) y - f1(y)) / y^3 */
    const PetscReal a = y < eps ? 2 / eps - y / (eps * eps) : 1 / y;
    const PetscReal c = y < eps ? -1 / (eps * eps * PetscMax(y, PETSC_SMALL * eps)) : -1 / (y * y * y);
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
  PetscCall(AddGradient(term, ct, X, rhs, -1.0));
  if (e) PetscCall(LocalEnergy(term, ct, X, e));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_Friction(MSimImplicitTerm term, PetscViewer viewer)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  PetscCall(PetscViewerASCIIPrintf(viewer, "friction: mu %g, lagged normal forces, smoothing eps_v %g m/s\n", (double)ct->mu, (double)ct->eps_v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitTermCreate_Friction(MSimImplicitTerm term)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  if (!ct || ct->mu == 0) PetscFunctionReturn(PETSC_SUCCESS); /* nothing per iteration */
  term->ops.energy   = Energy_Friction;
  term->ops.gradient = Gradient_Friction;
  term->ops.hessian  = Hessian_Friction;
  term->ops.pd_rhs   = PDRHS_Friction;
  term->ops.view     = View_Friction;
  PetscFunctionReturn(PETSC_SUCCESS);
}
