/* Residual, objective and Jacobian of the implicit Euler step (see msim/implicit.h). */
#include <msim/implicit.h>
#include <msim/kernels.hpp>

using msim::Mat3;
using msim::Vec3;
typedef Eigen::Map<const Vec3> CMap3;
typedef Eigen::Map<Vec3>       Map3;

PetscErrorCode MSimImplicitCreate(MSimSystem sys, MSimImplicit *imp)
{
  PetscFunctionBeginUser;
  *imp        = new _n_MSimImplicit();
  (*imp)->sys = sys;
  (*imp)->psd = PETSC_TRUE;
  PetscCall(VecDuplicate(sys->X0, &(*imp)->Xn));
  PetscCall(VecDuplicate(sys->X0, &(*imp)->Y));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitDestroy(MSimImplicit *imp)
{
  PetscFunctionBeginUser;
  if (!*imp) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecDestroy(&(*imp)->Xn));
  PetscCall(VecDestroy(&(*imp)->Y));
  PetscCall(VecDestroy(&(*imp)->rhs));
  PetscCall(MatDestroy(&(*imp)->A));
  PetscCall(MatDestroy(&(*imp)->A3));
  PetscCall(MatDestroy(&(*imp)->B));
  PetscCall(MatDestroy(&(*imp)->Xd));
  PetscCall(VecDestroy(&(*imp)->pdb));
  PetscCall(VecDestroy(&(*imp)->pdx));
  PetscCall(KSPDestroy(&(*imp)->pdksp));
  delete *imp;
  *imp = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitBeginStep(MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V)
{
  MSimSystem         sys = imp->sys;
  PetscScalar       *y;
  const PetscScalar *m;

  PetscFunctionBeginUser;
  PetscCheck(!imp->A || h == imp->h, sys->comm, PETSC_ERR_ARG_WRONGSTATE, "the PD matrix was built for h = %g; a new h needs a new factorization", (double)imp->h);
  imp->t       = t;
  imp->h       = h;
  imp->pd_lits = 0;
  PetscCall(VecCopy(X, imp->Xn));
  PetscCall(VecWAXPY(imp->Y, h, V, X));
  PetscCall(VecGetArray(imp->Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) y[i] += h * h * (sys->gravity[i % 3] + sys->drag * sys->wind[i % 3] / m[i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArray(imp->Y, &y));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The vertex terms of g: M (x - y) + h c (x - x_n), owned rows */
static PetscErrorCode MSimImplicitVertexResidual(MSimImplicit imp, Vec X, Vec G)
{
  MSimSystem         sys = imp->sys;
  const PetscReal    hc  = imp->h * sys->drag;
  const PetscScalar *xg, *xng, *y, *m;
  PetscScalar       *g;

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayWrite(G, &g));
  PetscCall(VecGetArrayRead(X, &xg));
  PetscCall(VecGetArrayRead(imp->Xn, &xng));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) g[i] = m[i] * (xg[i] - y[i]) + hc * (xg[i] - xng[i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(imp->Xn, &xng));
  PetscCall(VecRestoreArrayRead(X, &xg));
  PetscCall(VecRestoreArrayWrite(G, &g));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* g = vertex terms - h^2 f_spring(x) (+ the damping term). Without spring damping the springs go
   through the system's in-place sweep: c = h^2 k (1 - L/l) along each spring. */
PetscErrorCode MSimImplicitResidual(MSimImplicit imp, Vec X, Vec G)
{
  MSimSystem         sys = imp->sys;
  const MSimSprings &sp  = sys->springs;
  const PetscReal    h = imp->h, h2 = h * h, hkd = h * sys->damping;
  const PetscScalar *x, *xn;
  PetscScalar       *f;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Residual, X, G, 0, 0));
  PetscCall(MSimImplicitVertexResidual(imp, X, G));
  if (hkd == 0) PetscCall(MSimSystemSpringSweep(sys, imp->t + h, X, G, h2, -h2, NULL));
  else {
    PetscCall(MSimSystemGlobalToLocal(sys, imp->t + h, X, sys->xloc));
    PetscCall(MSimSystemGlobalToLocal(sys, imp->t, imp->Xn, sys->vloc));
    PetscCall(VecZeroEntries(sys->floc));
    PetscCall(VecGetArrayRead(sys->xloc, &x));
    PetscCall(VecGetArrayRead(sys->vloc, &xn));
    PetscCall(VecGetArray(sys->floc, &f));
    MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
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
  }
  PetscCall(PetscLogEventEnd(MSIM_Residual, X, G, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitObjective(MSimImplicit imp, Vec X, PetscReal *phi)
{
  MSimSystem         sys = imp->sys;
  const MSimSprings &sp  = sys->springs;
  const PetscReal    h = imp->h, hkd = h * sys->damping, hc = h * sys->drag;
  const PetscScalar *x, *xn, *xg, *xng, *y, *m;
  PetscReal          local = 0, springs = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Energy, X, 0, 0, 0));
  if (hkd == 0) PetscCall(MSimSystemSpringSweep(sys, imp->t + h, X, NULL, 0, 0, &springs));
  else {
    PetscCall(MSimSystemGlobalToLocal(sys, imp->t + h, X, sys->xloc));
    PetscCall(MSimSystemGlobalToLocal(sys, imp->t, imp->Xn, sys->vloc));
    PetscCall(VecGetArrayRead(sys->xloc, &x));
    PetscCall(VecGetArrayRead(sys->vloc, &xn));
    MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
      const Vec3   dn = CMap3(xn + 3 * i) - CMap3(xn + 3 * j);
      const double a  = dn.normalized().dot(CMap3(x + 3 * i) - CMap3(x + 3 * j) - dn);
      local += h * h * msim::SpringEnergy(CMap3(x + 3 * i), CMap3(x + 3 * j), k, L) + 0.5 * hkd * a * a;
    });
    PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
    PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  }
  PetscCall(VecGetArrayRead(X, &xg));
  PetscCall(VecGetArrayRead(imp->Xn, &xng));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) local += 0.5 * m[i] * (xg[i] - y[i]) * (xg[i] - y[i]) + 0.5 * hc * (xg[i] - xng[i]) * (xg[i] - xng[i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(imp->Xn, &xng));
  PetscCall(VecRestoreArrayRead(X, &xg));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  *phi = local + h * h * springs;
  PetscCall(PetscLogEventEnd(MSIM_Energy, X, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitJacobian(MSimImplicit imp, Vec X, Mat J)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitJacobianShifted(imp, X, 0.0, J));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitJacobianShifted(MSimImplicit imp, Vec X, PetscReal delta, Mat J)
{
  MSimSystem sys = imp->sys;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemAssembleMatrix(sys, imp->t + imp->h, X, 1.0 + delta, imp->h * sys->drag, imp->h * imp->h, imp->psd, imp->t, sys->damping > 0 ? imp->Xn : NULL, imp->h, J));
  PetscFunctionReturn(PETSC_SUCCESS);
}
