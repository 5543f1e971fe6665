/* The springs' discrete gradient (Gonzalez 1996), for schemes whose residual is not Phi's gradient
   (discrete_gradient): the term's part of the residual at x is
     h2 gradbar E(x_n, x) + hd kd sum_s n_s n_s^T A_s (x - x_n),   n_s the axis of A_s xref,
   the second the spring damping at the step's mean velocity A_s (x - x_n)/h, handles' motion
   included, with the axes of the scheme's reference (discrete_gradient: the midpoint predictor
   at t + h/2), exactly dissipative as its matrix is the same on both sides. Per spring, with d0 = A_s x_n,
   d1 = A_s x (x_n's handles at b(t), x's at b(t + h)), l0, l1 their lengths, lm = (l0 + l1)/2 and
   dm = (d0 + d1)/2, Gonzalez's discrete gradient of E = phi(l) in d is
     gbar = [(phi(l1) - phi(l0)) / (l1 - l0)] dm / lm,
   for which gbar . (d1 - d0) = [(phi(l1) - phi(l0)) / (l1 - l0)] (l1^2 - l0^2) / (2 lm) = phi(l1) - phi(l0)
   exactly, and vertex i gets +gbar, j -gbar (A_s^T). For msim's spring phi(l) = k/2 (l - L)^2 the
   quotient is (k/2) ((l1 - L) + (l0 - L)) = k (lm - L) algebraically, so
     gbar = k (1 - L/lm) dm,
   the spring force's own formula at the averaged axis and length: no division by l1 - l0 and so no
   switch to the midpoint gradient when |l1 - l0| is small (for a general phi the quotient differs
   from phi'(lm) by phi'''(lm) (l1 - l0)^2 / 24 + O((l1 - l0)^4), so a switch to phi'(lm) below
   |l1 - l0| = (24 eps |phi'| / |phi'''|)^(1/3) loses no more than the quotient's own rounding,
   eps |phi| / |l1 - l0|; msim's quadratic phi has phi''' = 0 and needs neither). Its Jacobian in d1,
   with n1 = d1 / l1, dlm/dd1 = n1^T / 2, ddm/dd1 = I / 2:
     B = dgbar/dd1 = k/2 [(1 - L/lm) I + (L / lm^2) dm n1^T],
   not symmetric (dm n1^T); blocks +B at (i,i) and (j,j), -B at (i,j) and (j,i), plus the damping's
   symmetric hd kd n n^T. tests/unit/test_implicit.cpp checks B against finite differences of the
   residual and gbar . (d1 - d0) against the energy change. Owned springs only (the damped path of
   springs.cpp): a ghost end's share goes to its owner (residual) or through the Mat's stash. */
#include <msim/implicit.h>
#include <msim/kernels.hpp>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

using msim::Vec3;
typedef Eigen::Map<const Vec3>                   CMap3;
typedef Eigen::Map<Vec3>                         Map3;
typedef Eigen::Matrix<double, 3, 3, Eigen::RowMajor> RowMat3; /* PETSc's block order */

/* x_n's local slots (handles at b(t)): a local Vec composed on sys->xloc, made on first use */
static PetscErrorCode SlotsGet(MSimImplicit imp, Vec X, const PetscScalar **x, const PetscScalar **xn, const PetscScalar **xr, Vec *xnloc)
{
  MSimSystem sys = imp->sys;

  PetscFunctionBeginUser;
  PetscCall(PetscObjectQuery((PetscObject)sys->xloc, "MSimDGXnLoc", (PetscObject *)xnloc));
  if (!*xnloc) {
    Vec v;
    PetscCall(VecDuplicate(sys->xloc, &v));
    PetscCall(PetscObjectCompose((PetscObject)sys->xloc, "MSimDGXnLoc", (PetscObject)v));
    PetscCall(VecDestroy(&v));
    PetscCall(PetscObjectQuery((PetscObject)sys->xloc, "MSimDGXnLoc", (PetscObject *)xnloc));
  }
  PetscCall(MSimSystemGlobalToLocal(sys, imp->step.tx, X, sys->xloc));
  PetscCall(MSimSystemGlobalToLocal(sys, imp->t, imp->Xn, *xnloc));
  PetscCall(VecGetArrayRead(sys->xloc, x));
  PetscCall(VecGetArrayRead(*xnloc, xn));
  *xr = NULL;
  if (sys->damping > 0) {
    PetscCall(MSimSystemGlobalToLocal(sys, imp->step.tref, imp->step.xref, sys->vloc));
    PetscCall(VecGetArrayRead(sys->vloc, xr));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode SlotsRestore(MSimImplicit imp, const PetscScalar **x, const PetscScalar **xn, const PetscScalar **xr, Vec xnloc)
{
  PetscFunctionBeginUser;
  PetscCall(VecRestoreArrayRead(imp->sys->xloc, x));
  PetscCall(VecRestoreArrayRead(xnloc, xn));
  if (*xr) PetscCall(VecRestoreArrayRead(imp->sys->vloc, xr));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* gbar and, when B is not NULL, dgbar/dd1 of one spring (formulas above) */
static inline Vec3 SpringDiscreteGradient(const Vec3 &d0, const Vec3 &d1, double k, double L, RowMat3 *B)
{
  const double l0 = d0.norm(), l1 = d1.norm(), lm = 0.5 * (l0 + l1);
  const Vec3   dm = 0.5 * (d0 + d1);
  if (B) {
    *B = (0.5 * k * (1 - L / lm)) * RowMat3::Identity();
    if (l1 > 0) *B += (0.5 * k * L / (lm * lm)) * dm * (d1 / l1).transpose();
  }
  return (k * (1 - L / lm)) * dm;
}

/* G += h2 gbar + the damping, over owned springs, ghost shares to their owners */
PetscErrorCode MSimImplicitSpringsDiscreteGradient(MSimImplicitTerm term, Vec X, Vec G)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const PetscReal    h2 = imp->step.h2, hkd = imp->step.hd * sys->damping;
  const PetscScalar *x, *xn, *xr;
  PetscScalar       *f;
  Vec                xnloc;

  PetscFunctionBeginUser;
  PetscCall(SlotsGet(imp, X, &x, &xn, &xr, &xnloc));
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArray(sys->floc, &f));
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    const Vec3 d0 = CMap3(xn + 3 * i) - CMap3(xn + 3 * j), d1 = CMap3(x + 3 * i) - CMap3(x + 3 * j);
    Vec3       r  = h2 * SpringDiscreteGradient(d0, d1, k, L, NULL);
    if (xr) {
      const Vec3 n = (CMap3(xr + 3 * i) - CMap3(xr + 3 * j)).normalized();
      r += (hkd * n.dot(d1 - d0)) * n;
    }
    Map3(f + 3 * i) += r;
    Map3(f + 3 * j) -= r;
  });
  PetscCall(VecRestoreArray(sys->floc, &f));
  PetscCall(SlotsRestore(imp, &x, &xn, &xr, xnloc));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, G));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* J += h2 B + hd kd n n^T in the four blocks of each spring with free ends, then assembled */
PetscErrorCode MSimImplicitSpringsDiscreteJacobian(MSimImplicitTerm term, Vec X, Mat J)
{
  MSimImplicit       imp = term->imp;
  MSimSystem         sys = imp->sys;
  const PetscReal    h2 = imp->step.h2, hkd = imp->step.hd * sys->damping;
  const PetscInt     nfl = sys->nown + sys->nghost;
  const PetscScalar *x, *xn, *xr;
  Vec                xnloc;
  PetscErrorCode     ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Jacobian, X, J, 0, 0));
  PetscCall(SlotsGet(imp, X, &x, &xn, &xr, &xnloc));
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    const Vec3 d0 = CMap3(xn + 3 * i) - CMap3(xn + 3 * j), d1 = CMap3(x + 3 * i) - CMap3(x + 3 * j);
    RowMat3    B, Bn;
    if (ierr) return;
    SpringDiscreteGradient(d0, d1, k, L, &B);
    B *= h2;
    if (xr) {
      const Vec3 n = (CMap3(xr + 3 * i) - CMap3(xr + 3 * j)).normalized();
      B += hkd * n * n.transpose();
    }
    Bn                    = -B;
    const PetscInt slot[] = {i, j};
    for (int a = 0; a < 2 && !ierr; a++)
      for (int b = 0; b < 2 && !ierr; b++) {
        if (slot[a] >= nfl || slot[b] >= nfl) continue; /* a fixed end: no unknown */
        const PetscInt gr = sys->local_to_global[slot[a]], gc = sys->local_to_global[slot[b]];
        ierr = MatSetValuesBlocked(J, 1, &gr, 1, &gc, (a == b ? B : Bn).data(), ADD_VALUES);
      }
  });
  PetscCall(ierr);
  PetscCall(SlotsRestore(imp, &x, &xn, &xr, xnloc));
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscLogEventEnd(MSIM_Jacobian, X, J, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
