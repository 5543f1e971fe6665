#include "anderson.h"
#include <msim/petsc_compat.h>
#include <Eigen/Dense>

PetscErrorCode MSimAndersonCreate(Vec tmpl, PetscInt m, MSimAnderson *aa)
{
  PetscFunctionBeginUser;
  aa->m = m;
  aa->dF.assign(m, NULL);
  aa->dG.assign(m, NULL);
  for (PetscInt k = 0; k < m; k++) {
    PetscCall(VecDuplicate(tmpl, &aa->dF[k]));
    PetscCall(VecDuplicate(tmpl, &aa->dG[k]));
  }
  PetscCall(VecDuplicate(tmpl, &aa->f_prev));
  PetscCall(VecDuplicate(tmpl, &aa->g_prev));
  aa->gram.assign(m * m, 0.0);
  PetscCall(MSimAndersonReset(aa));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimAndersonDestroy(MSimAnderson *aa)
{
  PetscFunctionBeginUser;
  for (Vec &v : aa->dF) PetscCall(VecDestroy(&v));
  for (Vec &v : aa->dG) PetscCall(VecDestroy(&v));
  PetscCall(VecDestroy(&aa->f_prev));
  PetscCall(VecDestroy(&aa->g_prev));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimAndersonReset(MSimAnderson *aa)
{
  PetscFunctionBeginUser;
  aa->count = aa->next = 0;
  aa->have_prev        = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimAndersonMix(MSimAnderson *aa, Vec x, Vec g, Vec y, PetscBool *accelerated)
{
  PetscFunctionBeginUser;
  *accelerated = PETSC_FALSE;
  /* y <- f = g - x (y is overwritten below anyway) */
  PetscCall(VecWAXPY(y, -1.0, x, g));
  Vec f = y;
  if (aa->m > 0 && aa->have_prev) {
    const PetscInt p = aa->next;
    PetscCall(VecWAXPY(aa->dF[p], -1.0, aa->f_prev, f));
    PetscCall(VecWAXPY(aa->dG[p], -1.0, aa->g_prev, g));
    aa->next  = (aa->next + 1) % aa->m;
    aa->count = PetscMin(aa->count + 1, aa->m);
    /* the Gram matrix keeps its other entries: only the new difference's row and column change */
    std::vector<PetscScalar> col(aa->count);
    PetscCall(VecMDot(aa->dF[p], aa->count, aa->dF.data(), col.data()));
    for (PetscInt q = 0; q < aa->count; q++) aa->gram[p * aa->m + q] = aa->gram[q * aa->m + p] = col[q];
  }
  if (aa->m > 0) {
    PetscCall(VecCopy(f, aa->f_prev));
    PetscCall(VecCopy(g, aa->g_prev));
    aa->have_prev = PETSC_TRUE;
  }
  if (aa->count == 0) {
    PetscCall(VecCopy(g, y));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* normal equations of the small least-squares problem, regularized for near-dependence */
  const PetscInt           n = aa->count;
  std::vector<PetscScalar> col(n);
  Eigen::MatrixXd          G(n, n);
  Eigen::VectorXd          b(n);
  for (PetscInt i = 0; i < n; i++)
    for (PetscInt j = 0; j < n; j++) G(i, j) = PetscRealPart(aa->gram[i * aa->m + j]);
  PetscCall(VecMDot(f, n, aa->dF.data(), col.data()));
  for (PetscInt i = 0; i < n; i++) b(i) = PetscRealPart(col[i]);
  G.diagonal().array() += 1e-12 * G.diagonal().maxCoeff() + 1e-300;
  Eigen::VectorXd theta = G.ldlt().solve(b);
  if (!theta.allFinite()) {
    PetscCall(VecCopy(g, y));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  for (PetscInt i = 0; i < n; i++) col[i] = -theta(i);
  PetscCall(VecCopy(g, y));
  PetscCall(VecMAXPY(y, n, col.data(), aa->dG.data()));
  *accelerated = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}
