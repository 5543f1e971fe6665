/* The discrete_gradient scheme's residual (src/implicit/terms/springs_discrete_gradient.cpp), at
   1 and 2 ranks:
   - its exact Jacobian (nonsymmetric) matches central finite differences of the residual along a
     random direction, with spring damping, drag and moving handles, at an x far from x_n (the
     springs stretched and turned, where gradbar differs most from a midpoint gradient), and is
     really not symmetric (|J - J^T| is a sizable part of |J|: a symmetric stand-in would fail);
   - the discrete gradient is one: with fixed handles, the springs' part of the residual,
     r(x) - M (x - y) = h^2/2 gradbar E(x_n, x), dotted with x - x_n gives h^2/2 (E(x) - E(x_n))
     to roundoff, for a random x far from x_n (no Taylor argument: the identity is exact);
   - the problem has no objective: asking for Phi is an error. */
#include "harness.h"
#include <cmath>

/* x_{n+1} guess far from x_n: x_n + h v + a random displacement of up to 3 cm per component */
static PetscErrorCode BeginFar(TestSim *s, MSimImplicit *imp, PetscReal h, Vec X1)
{
  PetscFunctionBeginUser;
  PetscCall(MSimImplicitCreateWithScheme(s->sys, MSIMSCHEMEDISCGRAD, imp));
  PetscCall(SetRandom(s->V, -0.5, 0.5));
  PetscCall(MSimImplicitBeginStep(*imp, 0.1, h, s->X, s->V));
  PetscCall(SetRandom(X1, -0.03, 0.03));
  PetscCall(VecAXPY(X1, 1.0, s->X));
  PetscCall(VecAXPY(X1, h, s->V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestJacobianFD(void)
{
  TestSim      s;
  MSimImplicit imp;
  Mat          J, Jt;
  Vec          X1, dX;
  PetscReal    eps = 1e-6, err, nrm, asym;

  PetscFunctionBeginUser;
  PetscCall(TestSimCreate("-msim_cloth_n 6 -msim_perturb 0.02 -msim_prestretch 0.95 -msim_damping 0.7 -msim_drag 0.05 -msim_wind 1,0,0 -msim_fix_velocity 0,0,0.1 -msim_integrator discrete_gradient", &s));
  PetscCall(VecDuplicate(s.X, &X1));
  PetscCall(BeginFar(&s, &imp, 0.02, X1));
  PetscCall(MSimSystemCreateMatrix(s.sys, &J));
  PetscCall(MatSetOption(J, MAT_SYMMETRY_ETERNAL, PETSC_FALSE));
  PetscCall(MatSetOption(J, MAT_SYMMETRIC, PETSC_FALSE));
  PetscCall(MSimImplicitJacobian(imp, X1, J));
  PetscCall(VecDuplicate(X1, &dX));
  PetscCall(SetRandom(dX, -1, 1));
  PetscCall(JacobianFDError(imp, J, X1, dX, eps, &err, &nrm));
  NOTE("discrete gradient: Jacobian vs finite differences of the residual: relative error %.2e\n", (double)(err / nrm));
  CHECK(err <= 1e-7 * nrm, "discrete-gradient Jacobian off by %g relative", (double)(err / nrm));
  /* asymmetry against the springs' own blocks (J less its diagonal, where the mass sits) */
  PetscCall(MatTranspose(J, MAT_INITIAL_MATRIX, &Jt));
  PetscCall(MatAXPY(Jt, -1.0, J, SAME_NONZERO_PATTERN));
  PetscCall(MatNorm(Jt, NORM_FROBENIUS, &asym));
  {
    /* the springs' own blocks: J - diag(J) */
    Vec d;
    Mat S;
    PetscReal sn;
    PetscCall(VecDuplicate(X1, &d));
    PetscCall(MatGetDiagonal(J, d));
    PetscCall(MatDuplicate(J, MAT_COPY_VALUES, &S));
    PetscCall(VecScale(d, -1.0));
    PetscCall(MatDiagonalSet(S, d, ADD_VALUES));
    PetscCall(MatNorm(S, NORM_FROBENIUS, &sn));
    NOTE("discrete gradient: |J - J^T|_F = %.3e, |J - diag J|_F = %.3e\n", (double)asym, (double)sn);
    CHECK(asym > 1e-3 * sn, "the discrete-gradient Jacobian is symmetric (|J - J^T| %g)", (double)asym);
    PetscCall(MSimDestroy(&S, &d));
  }
  /* no Phi: an error, not a number */
  {
    PetscReal      phi;
    PetscErrorCode ierr;
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = MSimImplicitObjective(imp, X1, &phi);
    PetscCall(PetscPopErrorHandler());
    CHECK(ierr == PETSC_ERR_SUP, "MSimImplicitObjective with discrete_gradient returned %d, not PETSC_ERR_SUP", (int)ierr);
  }
  PetscCall(MSimDestroy(&Jt, &X1, &dX, &J, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* gradbar . (x - x_n) = E(x) - E(x_n), exactly, far from x_n (fixed handles, no damping or drag) */
static PetscErrorCode TestDiscreteGradientExact(void)
{
  TestSim            s;
  MSimImplicit       imp;
  Vec                X1, G, D, Xn, Y, M;
  PetscInt           nloc;
  PetscReal          h = 0.05, e0, e1, dot;
  const PetscScalar *y, *m, *x;
  PetscScalar       *g;

  PetscFunctionBeginUser;
  PetscCall(TestSimCreate("-msim_cloth_n 6 -msim_perturb 0.02 -msim_stiffness 5000 -msim_integrator discrete_gradient", &s));
  PetscCall(VecDuplicate(s.X, &X1));
  PetscCall(VecDuplicate(s.X, &G));
  PetscCall(VecDuplicate(s.X, &D));
  PetscCall(BeginFar(&s, &imp, h, X1));
  PetscCall(MSimImplicitResidual(imp, X1, G));
  PetscCall(MSimImplicitGetStepState(imp, &Xn, &Y));
  PetscCall(MSimSystemGetMass(s.sys, &M));
  PetscCall(VecGetLocalSize(G, &nloc));
  /* G - M (x - y): the springs' part, h^2/2 gradbar */
  PetscCall(VecGetArray(G, &g));
  PetscCall(VecGetArrayRead(X1, &x));
  PetscCall(VecGetArrayRead(Y, &y));
  PetscCall(VecGetArrayRead(M, &m));
  for (PetscInt i = 0; i < nloc; i++) g[i] -= m[i] * (x[i] - y[i]);
  PetscCall(VecRestoreArrayRead(M, &m));
  PetscCall(VecRestoreArrayRead(Y, &y));
  PetscCall(VecRestoreArrayRead(X1, &x));
  PetscCall(VecRestoreArray(G, &g));
  PetscCall(VecWAXPY(D, -1.0, Xn, X1));
  PetscCall(VecDot(G, D, &dot));
  dot /= 0.5 * h * h;
  PetscCall(MSimSystemSpringEnergy(s.sys, 0.1, Xn, &e0));
  PetscCall(MSimSystemSpringEnergy(s.sys, 0.1 + h, X1, &e1));
  NOTE("discrete gradient: gradbar . (x - x_n) = %.15e J, E(x) - E(x_n) = %.15e J (E(x_n) = %.6e J)\n", (double)dot, (double)(e1 - e0), (double)e0);
  CHECK(std::abs(dot - (e1 - e0)) <= 1e-11 * PetscMax(e0, e1), "gradbar . (x - x_n) %.15e differs from E(x) - E(x_n) %.15e", (double)dot, (double)(e1 - e0));
  PetscCall(MSimDestroy(&X1, &G, &D, &imp, &s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestDiscreteGradient(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestJacobianFD());
  PetscCall(TestDiscreteGradientExact());
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestDiscreteGradient)
