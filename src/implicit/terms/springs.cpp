/* The springs with their damping: h2 E(x) + hd kd/2 sum_s (n_s . A_s (x - xref))^2, where
   A_s x = x_i - x_j (fixed ends from b(t)), n_s the spring's axis at xref (implicit Euler: h^2 E
   and h kd with x_n's axes). Without damping every op goes through the system's vectorized
   sweeps (msim/spring_sweep.h), with the ghost exchange in flight while the owned springs run.
   PD: each spring is h2 k/2 |A_s x - d_s|^2 (|d_s| = L) plus hd kd/2 |A_s x - e_s|^2 (e_s is
   A_s xref plus any vector normal to n_s), minimised over d_s and e_s: its weight in A is
   h2 k + hd kd, constant, and its projection gives Phi exactly. Never infeasible: no max_step. */
#include <msim/implicit.h>
#include <msim/kernels.hpp>
#include <msim/spring_sweep.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

using msim::Vec3;
typedef Eigen::Map<const Vec3> CMap3;
typedef Eigen::Map<Vec3>       Map3;

static PetscBool Damped(MSimImplicitTerm term)
{
  return (PetscBool)(term->imp->sys->damping > 0);
}

/* the spring damping's loops: x and xref in the local slots (xloc, vloc) */
static PetscErrorCode DampedSlotsGet(MSimImplicit imp, Vec X, const PetscScalar **x, const PetscScalar **xn)
{
  MSimSystem sys = imp->sys;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGlobalToLocal(sys, imp->step.tx, X, sys->xloc));
  PetscCall(MSimSystemGlobalToLocal(sys, imp->step.tref, imp->step.xref, sys->vloc));
  if (x) PetscCall(VecGetArrayRead(sys->xloc, x));
  if (xn) PetscCall(VecGetArrayRead(sys->vloc, xn));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Energy_Springs(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const PetscReal    h2 = imp->step.h2, hkd = imp->step.hd * sys->damping;
  const PetscScalar *x, *xn;
  PetscReal          local = 0, springs = 0;

  PetscFunctionBeginUser;
  if (!Damped(term)) {
    PetscCall(MSimSystemSpringSweep(sys, imp->step.tx, X, NULL, 0, 0, &springs));
    *e += h2 * springs;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(DampedSlotsGet(imp, X, &x, &xn));
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    const Vec3   dn = CMap3(xn + 3 * i) - CMap3(xn + 3 * j);
    const double a  = dn.normalized().dot(CMap3(x + 3 * i) - CMap3(x + 3 * j) - dn);
    local += h2 * msim::SpringEnergy(CMap3(x + 3 * i), CMap3(x + 3 * j), k, L) + 0.5 * hkd * a * a;
  });
  PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  *e += local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += h2 grad E (c = h2 k (1 - L/l) along each spring, in place), plus the damping term */
static PetscErrorCode Gradient_Springs(MSimImplicitTerm term, Vec X, Vec G)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const PetscReal    h2 = imp->step.h2, hkd = imp->step.hd * sys->damping;
  const PetscScalar *x, *xn;
  PetscScalar       *f;

  PetscFunctionBeginUser;
  if (!Damped(term)) {
    PetscCall(MSimSystemSpringSweep(sys, imp->step.tx, X, G, h2, -h2, NULL));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(DampedSlotsGet(imp, X, &x, &xn));
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArray(sys->floc, &f));
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    const Vec3 dn = CMap3(xn + 3 * i) - CMap3(xn + 3 * j), n = dn.normalized();
    Vec3       r  = -h2 * msim::SpringForce(CMap3(x + 3 * i), CMap3(x + 3 * j), k, L);
    r += (hkd * n.dot(CMap3(x + 3 * i) - CMap3(x + 3 * j) - dn)) * n;
    Map3(f + 3 * i) += r;
    Map3(f + 3 * j) -= r;
  });
  PetscCall(VecRestoreArray(sys->floc, &f));
  PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, G));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* h2 K(X) (blocks PSD-projected on request) + hd kd sum_s n_s n_s^T, in the system's assembly */
static PetscErrorCode HessianCoefficients_Springs(MSimImplicitTerm term, Vec X, PetscBool psd, MSimMatrixCoefficients *c)
{
  MSimImplicit imp = term->imp;

  PetscFunctionBeginUser;
  c->stiffness = imp->step.h2;
  c->psd       = psd;
  c->tn        = imp->step.tref;
  c->Xn        = Damped(term) ? imp->step.xref : NULL;
  c->damping   = imp->step.hd;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* w_s = h2 k_s + hd kd in the scalar graph Laplacian (free ends only), into the rank's own rows:
   the owned springs' owned ends, and the halo springs' (src/springs/matrix.cpp's SpringBlocks says
   why no rank adds to another's rows) */
static PetscErrorCode PDMatrix_Springs(MSimImplicitTerm term, Mat A)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const PetscInt     nfl = sys->nown + sys->nghost, nown = sys->nown;
  const MSimSprings &sp  = sys->springs;
  PetscErrorCode     ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  /* row i (owned) of the spring (i, j): w on the diagonal, -w at j where j is free */
  auto row = [&](PetscInt i, PetscInt j, PetscReal k) {
    const PetscScalar w = imp->step.h2 * k + imp->step.hd * sys->damping, wn = -w;
    const PetscInt    gi = sys->local_to_global[i];
    if (ierr) return;
    ierr = MatSetValue(A, gi, gi, w, ADD_VALUES);
    if (j < nfl && !ierr) ierr = MatSetValue(A, gi, sys->local_to_global[j], wn, ADD_VALUES);
  };
  MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal) {
    if (i < nown) row(i, j, k);
    if (j < nown) row(j, i, k);
  });
  for (size_t s = 0; s < sp.hi.size(); s++) row(sp.hi[s], sp.hj[s], sp.hk[s]);
  PetscCall(ierr);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The local step needs x's ghost and fixed slots (and, damped, xref's): started here, before the
   problem's inertia pass */
static PetscErrorCode PDBegin_Springs(MSimImplicitTerm term, Vec X)
{
  MSimImplicit imp = term->imp;

  PetscFunctionBeginUser;
  if (Damped(term)) PetscCall(DampedSlotsGet(imp, X, NULL, NULL));
  else PetscCall(MSimSystemGhostsBegin(imp->sys, X, imp->sys->xloc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* One spring through the local slots (xloc: ghost and fixed slots filled; the owned rows of x and
   rhs are the Vec arrays xo and ro; ghost contributions go to floc, or nowhere when fl is NULL):
   the PD projection, the damping term with the spring axes of xref (xn, all slots, or NULL), and
   the coupling to fixed ends. grad: the spring's part of Phi's gradient instead (ro is G), its
   part of A x less what it adds to rhs: h2 k (d - p) + hd kd (n . u) n, whatever its ends (a
   fixed end's coupling is in both and cancels). */
template <bool grad>
static inline void PDSpringSlots(MSimImplicit imp, PetscInt i, PetscInt j, PetscReal k, PetscReal L, const PetscScalar *xo, const PetscScalar *xl, const PetscScalar *xn, PetscScalar *ro, PetscScalar *fl, PetscReal *energy)
{
  MSimSystem      sys = imp->sys;
  const PetscInt  nfl = sys->nown + sys->nghost, nown = sys->nown;
  const PetscReal h2 = imp->step.h2, hkd = imp->step.hd * sys->damping;
  const Vec3      xi = CMap3((i < nown ? xo : xl) + 3 * i), xj = CMap3((j < nown ? xo : xl) + 3 * j);
  const PetscReal w1 = h2 * k;
  Vec3            p  = grad ? Vec3(w1 * ((xi - xj) - msim::SpringProjection(xi, xj, L))) : Vec3(w1 * msim::SpringProjection(xi, xj, L));
  if (energy) *energy += h2 * msim::SpringEnergy(xi, xj, k, L);
  if (xn) {
    const Vec3 dn = CMap3(xn + 3 * i) - CMap3(xn + 3 * j), n = dn.normalized(), u = xi - xj - dn;
    if (grad) p += (hkd * n.dot(u)) * n;
    else p += hkd * (dn + u - n.dot(u) * n);
    if (energy) *energy += 0.5 * hkd * n.dot(u) * n.dot(u);
  }
  if (!grad) {
    /* a fixed end moves its coupling term to the right-hand side */
    const PetscReal w = w1 + (xn ? hkd : 0.0);
    if (j >= nfl) p += w * xj;
    if (i >= nfl) p -= w * xi;
  }
  if (i < nown) Map3(ro + 3 * i) += p;
  else if (fl) Map3(fl + 3 * i) += p;
  if (j < nown) Map3(ro + 3 * j) -= p;
  else if (fl) Map3(fl + 3 * j) -= p;
}

/* rhs += sum_s A_s^T (w1 d_s + w2 e_s) + coupling to fixed ends, at X. Without damping the springs
   with both ends owned go through the vectorized sweep (c = h2 k L/l along each spring) straight
   into rhs's array while the ghost positions travel, then those with a ghost or fixed end and
   the halo, each adding to its owned end only; with damping, all through the slots. grad: Phi's
   gradient in rhs's place (PDGradient_Springs), the sweep with c = h2 k (1 - L/l). */
template <bool grad>
static PetscErrorCode PDLocal_Springs(MSimImplicitTerm term, Vec X, Vec rhs, PetscReal *energy)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const MSimSprings &sp  = sys->springs;
  const PetscReal    h2  = imp->step.h2;
  const PetscBool    damped = Damped(term);
  const PetscScalar *x, *xl, *xn = NULL;
  PetscScalar       *r, *fl;

  PetscFunctionBeginUser;
  PetscCall(VecGetArray(rhs, &r));
  PetscCall(VecGetArrayRead(X, &x));
  if (!damped) {
    PetscReal es = 0;
    MSimSpringSweepSlices(&sp.slices, &sys->sweep, x, r, NULL, NULL, grad ? h2 : 0.0, h2 * (grad ? -1 : 1), energy ? &es : NULL);
    MSimSpringSweep(sp.ninner, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x, r, grad ? h2 : 0.0, h2 * (grad ? -1 : 1), energy ? &es : NULL);
    if (energy) *energy += h2 * es;
    PetscCall(VecRestoreArrayRead(X, &x));
    PetscCall(MSimSystemGhostsEnd(sys, imp->step.tx, X, sys->xloc));
    PetscCall(VecGetArrayRead(X, &x));
  }
  PetscCall(VecGetArrayRead(sys->xloc, &xl));
  if (damped) {
    PetscCall(VecGetArrayRead(sys->vloc, &xn));
    PetscCall(VecGetArray(sys->floc, &fl));
    PetscCall(PetscArrayzero(fl + 3 * sys->nown, 3 * (sys->nloc - sys->nown)));
    MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) { PDSpringSlots<grad>(imp, i, j, k, L, x, xl, xn, r, fl, energy); });
    PetscCall(VecRestoreArray(sys->floc, &fl));
  } else {
    /* each adds to its owned end only; the halo's energy is its owners' */
    for (PetscInt s = sp.ninner; s < sp.n; s++) PDSpringSlots<grad>(imp, sp.i[s], sp.j[s], sp.k[s], sp.L[s], x, xl, NULL, r, NULL, energy);
    for (size_t s = 0; s < sp.hi.size(); s++) PDSpringSlots<grad>(imp, sp.hi[s], sp.hj[s], sp.hk[s], sp.hL[s], x, xl, NULL, r, NULL, NULL);
  }
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(VecRestoreArray(rhs, &r));
  if (xn) PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
  if (damped && sys->size > 1) PetscCall(MSimSystemGhostsAdd(sys, sys->floc, rhs)); /* collective */
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDRHS_Springs(MSimImplicitTerm term, Vec X, Vec rhs, PetscReal *energy)
{
  PetscFunctionBeginUser;
  PetscCall(PDLocal_Springs<false>(term, X, rhs, energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += the springs' part of Phi's gradient (A's spring weights times X less PDRHS_Springs's part),
   in the local step's passes (pd_gradient.cpp) */
static PetscErrorCode PDGradient_Springs(MSimImplicitTerm term, Vec X, Vec G, PetscReal *energy)
{
  PetscFunctionBeginUser;
  PetscCall(PDLocal_Springs<true>(term, X, G, energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* springs_discrete_gradient.cpp: the discrete_gradient scheme's residual and Jacobian */
PetscErrorCode MSimImplicitSpringsDiscreteGradient(MSimImplicitTerm, Vec, Vec);
PetscErrorCode MSimImplicitSpringsDiscreteJacobian(MSimImplicitTerm, Vec, Mat);

static const MSimImplicitTermOps SpringsOps = {.energy = Energy_Springs, .gradient = Gradient_Springs, .hessian_coefficients = HessianCoefficients_Springs, .pd_matrix = PDMatrix_Springs, .pd_begin = PDBegin_Springs,
                                               .pd_rhs = PDRHS_Springs, .pd_gradient = PDGradient_Springs, .discrete_gradient = MSimImplicitSpringsDiscreteGradient, .discrete_jacobian = MSimImplicitSpringsDiscreteJacobian};

PetscErrorCode MSimImplicitTermCreate_Springs(MSimImplicitTerm term)
{
  PetscFunctionBeginUser;
  term->ops = SpringsOps;
  PetscFunctionReturn(PETSC_SUCCESS);
}
