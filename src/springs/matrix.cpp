/* Assembly of spring matrices (stiffness, Newton Jacobian) into a Mat preallocated once. */
#include <msim/system.h>
#include <msim/kernels.hpp>

using msim::Mat3;
using msim::Vec3;
typedef Eigen::Map<const Vec3> CMap3;

/* Block nonzeros per owned row of the free-vertex graph (diagonal included): counted in the local
   slots (diagonal part or off-process), the ghost rows' counts summed into their owners with the
   reverse scatter. */
PetscErrorCode MSimSystemGraphPreallocation(MSimSystem sys, std::vector<PetscInt> &dnz, std::vector<PetscInt> &onz)
{
  Vec                nnz, gnnz;
  PetscScalar       *c;
  const PetscScalar *g;
  const PetscInt     nfree_local = sys->nown + sys->nghost;

  PetscFunctionBeginUser;
  dnz.resize(sys->nown);
  onz.resize(sys->nown);
  PetscCall(VecDuplicate(sys->floc, &nnz));
  PetscCall(VecZeroEntries(nnz));
  PetscCall(VecGetArray(nnz, &c));
  for (PetscInt i = 0; i < sys->nown; i++) c[3 * i] = 1; /* the diagonal block */
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal, PetscReal) {
    if (i >= nfree_local || j >= nfree_local) return; /* a fixed end adds no off-diagonal block */
    const bool local = i < sys->nown && j < sys->nown;
    c[3 * i + (local ? 0 : 1)] += 1;
    c[3 * j + (local ? 0 : 1)] += 1;
  });
  PetscCall(VecRestoreArray(nnz, &c));
  PetscCall(VecDuplicate(sys->mass, &gnnz));
  PetscCall(VecZeroEntries(gnnz));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, nnz, gnnz));
  PetscCall(VecGetArrayRead(gnnz, &g));
  for (PetscInt i = 0; i < sys->nown; i++) {
    dnz[i] = PetscMin((PetscInt)g[3 * i], sys->nown);
    onz[i] = PetscMin((PetscInt)g[3 * i + 1], sys->nfree - sys->nown);
  }
  PetscCall(VecRestoreArrayRead(gnnz, &g));
  PetscCall(VecDestroy(&nnz));
  PetscCall(VecDestroy(&gnnz));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemCreateMatrix(MSimSystem sys, Mat *A)
{
  std::vector<PetscInt> dnz, onz;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGraphPreallocation(sys, dnz, onz));
  PetscCall(MatCreate(sys->comm, A));
  PetscCall(MatSetSizes(*A, 3 * sys->nown, 3 * sys->nown, 3 * sys->nfree, 3 * sys->nfree));
  PetscCall(MatSetBlockSize(*A, 3));
  PetscCall(MatSetType(*A, MATAIJ));
  PetscCall(MatXAIJSetPreallocation(*A, 3, dnz.data(), onz.data(), NULL, NULL));
  PetscCall(MatSetOption(*A, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(*A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static inline void AddBlock(Mat A, PetscInt r, PetscInt c, const Mat3 &B, PetscErrorCode *ierr)
{
  /* Eigen is column-major; PETSc wants row-major: B is symmetric for every spring block */
  *ierr = MatSetValuesBlocked(A, 1, &r, 1, &c, B.data(), ADD_VALUES);
}

PetscErrorCode MSimSystemAssembleMatrix(MSimSystem sys, PetscReal t, Vec X, PetscReal mass_coef, PetscReal diag_coef, PetscReal stiff_coef, PetscBool psd, PetscReal tn, Vec Xn, PetscReal damp_coef, Mat A)
{
  const PetscScalar *x, *xn = NULL, *m;
  const PetscInt     nfree_local = sys->nown + sys->nghost;
  PetscErrorCode     ierr        = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Jacobian, X, A, 0, 0));
  PetscCall(MatZeroEntries(A));
  if (Xn && damp_coef != 0) {
    /* spring axes at the start of the step, held in vloc (free during assembly) */
    PetscCall(MSimSystemGlobalToLocal(sys, tn, Xn, sys->vloc));
    PetscCall(VecGetArrayRead(sys->vloc, &xn));
  }
  PetscCall(MSimSystemGlobalToLocal(sys, t, X, sys->xloc));
  PetscCall(VecGetArrayRead(sys->xloc, &x));
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    if (ierr) return;
    Mat3 H = stiff_coef * msim::SpringHessian(CMap3(x + 3 * i), CMap3(x + 3 * j), k, L, (bool)psd);
    if (xn) {
      const Vec3 n = (CMap3(xn + 3 * i) - CMap3(xn + 3 * j)).normalized();
      H += (damp_coef * sys->damping) * (n * n.transpose());
    }
    const bool     fi = i < nfree_local, fj = j < nfree_local;
    const PetscInt gi = fi ? sys->local_to_global[i] : -1, gj = fj ? sys->local_to_global[j] : -1;
    if (fi) AddBlock(A, gi, gi, H, &ierr);
    if (fj && !ierr) AddBlock(A, gj, gj, H, &ierr);
    if (fi && fj && !ierr) {
      const Mat3 Hn = -H;
      AddBlock(A, gi, gj, Hn, &ierr);
      if (!ierr) AddBlock(A, gj, gi, Hn, &ierr);
    }
  });
  PetscCall(ierr);
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  if (xn) PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
  /* diagonal: mass and drag */
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) {
    PetscInt    row = 3 * sys->rstart + i;
    PetscScalar v   = mass_coef * m[i] + diag_coef;
    if (v != 0) PetscCall(MatSetValues(A, 1, &row, 1, &row, &v, ADD_VALUES));
  }
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscLogEventEnd(MSIM_Jacobian, X, A, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemCreateMassMatrix(MSimSystem sys, Mat *M)
{
  PetscFunctionBeginUser;
  PetscCall(MatCreateAIJ(sys->comm, 3 * sys->nown, 3 * sys->nown, 3 * sys->nfree, 3 * sys->nfree, 1, NULL, 0, NULL, M));
  PetscCall(MatDiagonalSet(*M, sys->mass, INSERT_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}
