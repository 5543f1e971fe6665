/* Assembly of spring matrices (stiffness, Newton Jacobian) into a Mat preallocated once. */
#include <msim/system.h>
#include <msim/kernels.hpp>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <algorithm>

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

static PetscErrorCode AssemblePattern(MSimSystem sys, Mat A);

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
  /* self-contact's blocks join surface vertices the springs do not, as pairs come within the
     contact distance: their entries are allocated when they first appear (the assembly map below
     follows the pattern's changes) */
  if (sys->self_contact.on) PetscCall(MatSetOption(*A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE));
  /* the spring graph's pattern assembled now and its map built, so that every assembly of the run
     is a mapped one: the first, by search, cost 14 x a mapped one (1.4 s against 0.1 s on the 52^3
     tet box) and fell inside the run's first step, where it weighed on the steps' speed-up
     (runs/device/README.md) */
  PetscCall(AssemblePattern(sys, *A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The blocks the springs add to the rank's own rows, in the one order the assembly map relies on:
   each owned spring (i, j) gives (i,i), (j,j), then (i,j), (j,i), those whose row is owned (a
   ghost's row is its owner's) and both of whose ends are free for the off-diagonal ones (a fixed
   end, eliminated, adds none of its own); then each halo spring (an owned hi, a ghost hj) gives
   (hi,hi), (hi,hj). f(i, j, k, L, r, col, off) for the spring (i, j, k, L) and its block (r, col); off
   says an off-diagonal block. So no rank adds to another's rows: PETSc's assembly would sum what
   several ranks send to one row in the order the messages arrive, which at 3 ranks and more made
   two runs of one scene differ in the last bits. The map's builder, the zero pattern and every
   assembly visit the blocks through this. */
template <class F>
static inline void SpringBlocks(MSimSystem sys, F &&f)
{
  const PetscInt nfl = sys->nown + sys->nghost, nown = sys->nown;
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    const bool fi = i < nfl, fj = j < nfl;
    if (i < nown) f(i, j, k, L, i, i, false);
    if (j < nown) f(i, j, k, L, j, j, false);
    if (fi && fj) {
      if (i < nown) f(i, j, k, L, i, j, true);
      if (j < nown) f(i, j, k, L, j, i, true);
    }
  });
  const MSimSprings &sp = sys->springs;
  for (size_t s = 0; s < sp.hi.size(); s++) {
    f(sp.hi[s], sp.hj[s], sp.hk[s], sp.hL[s], sp.hi[s], sp.hi[s], false);
    f(sp.hi[s], sp.hj[s], sp.hk[s], sp.hL[s], sp.hi[s], sp.hj[s], true);
  }
}

/* Where the spring blocks land in an assembled AIJ matrix, so that later assemblies add straight
   into its value arrays instead of searching each row in MatSetValuesBlocked (39 ms -> a few ms
   for the 101 x 101 cloth's Jacobian). Blocks are listed in SpringBlocks's order (owned rows
   only); for each, the offsets of its three rows' first entries in the diagonal part (owned
   columns) or the off-diagonal part. Built when the Mat is
   created, its pattern assembled with zeros (AssemblePattern); hangs on the Mat, and is rebuilt after an assembly once the Mat's nonzero pattern has
   changed (entries another term added, e.g. self-contact's blocks, move the value arrays). */
typedef struct {
  PetscObjectState      state; /* the Mat's nonzero state the offsets belong to */
  std::vector<PetscInt> off;  /* 3 per block */
  std::vector<char>     part; /* per block: 0 diagonal part, 1 off-diagonal part */
  std::vector<PetscInt> diag; /* 3 nown: the diagonal entries of the owned rows */
} AssemblyMap;

static PetscErrorCode AssemblyMapDestroy(void *p)
{
  PetscFunctionBeginUser;
  delete (AssemblyMap *)p;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the diagonal and off-diagonal parts (seqaij) of A, NULL when A is neither seqaij nor mpiaij */
static PetscErrorCode AssemblyParts(Mat A, Mat *Ad, Mat *Ao, const PetscInt **garray)
{
  PetscBool seq, mpi;

  PetscFunctionBeginUser;
  *Ad = *Ao = NULL;
  *garray   = NULL;
  PetscCall(PetscObjectTypeCompare((PetscObject)A, MATSEQAIJ, &seq));
  PetscCall(PetscObjectTypeCompare((PetscObject)A, MATMPIAIJ, &mpi));
  if (seq) *Ad = A;
  if (mpi) PetscCall(MatMPIAIJGetSeqAIJ(A, Ad, Ao, garray));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode AssemblyMapBuild(MSimSystem sys, Mat A, AssemblyMap **out)
{
  Mat             Ad, Ao;
  const PetscInt *garray, *ia[2] = {NULL, NULL}, *ja[2] = {NULL, NULL};
  PetscInt        nr, nghostcols = 0;
  PetscBool       done;
  AssemblyMap    *map = new AssemblyMap();
  PetscErrorCode  ierr = 0;

  PetscFunctionBeginUser;
  PetscCall(AssemblyParts(A, &Ad, &Ao, &garray));
  PetscCall(MatGetRowIJ(Ad, 0, PETSC_FALSE, PETSC_FALSE, &nr, &ia[0], &ja[0], &done));
  PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_SUP, "no row structure of the diagonal part");
  if (Ao) {
    PetscCall(MatGetRowIJ(Ao, 0, PETSC_FALSE, PETSC_FALSE, &nr, &ia[1], &ja[1], &done));
    PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_SUP, "no row structure of the off-diagonal part");
    PetscCall(MatGetSize(Ao, NULL, &nghostcols));
  }
  /* offset of (row, col) in part q; -2 when missing (not expected: the pattern is the graph's) */
  auto find = [&](int q, PetscInt row, PetscInt col) -> PetscInt {
    const PetscInt *lo = ja[q] + ia[q][row], *hi = ja[q] + ia[q][row + 1], *p = std::lower_bound(lo, hi, col);
    if (p + 2 >= hi || p[0] != col || p[1] != col + 1 || p[2] != col + 2) return -2;
    return (PetscInt)(p - ja[q]);
  };
  auto add_block = [&](PetscInt r, PetscInt c) {
    int      q   = c < sys->nown ? 0 : 1;
    PetscInt col = 3 * c;
    if (q == 1) col = (PetscInt)(std::lower_bound(garray, garray + nghostcols, 3 * sys->local_to_global[c]) - garray); /* Ao's columns: garray's order */
    for (int a = 0; a < 3; a++) {
      const PetscInt o = find(q, 3 * r + a, col);
      if (o < 0) ierr = PETSC_ERR_PLIB;
      map->off.push_back(o);
    }
    map->part.push_back((char)q);
  };
  SpringBlocks(sys, [&](PetscInt, PetscInt, PetscReal, PetscReal, PetscInt r, PetscInt col, bool) { add_block(r, col); });
  map->diag.resize(3 * sys->nown);
  for (PetscInt r = 0; r < 3 * sys->nown; r++) {
    const PetscInt *lo = ja[0] + ia[0][r], *hi = ja[0] + ia[0][r + 1], *p = std::lower_bound(lo, hi, r);
    if (p == hi || *p != r) ierr = PETSC_ERR_PLIB;
    map->diag[r] = (PetscInt)(p - ja[0]);
  }
  PetscCall(MatRestoreRowIJ(Ad, 0, PETSC_FALSE, PETSC_FALSE, &nr, &ia[0], &ja[0], &done));
  if (Ao) PetscCall(MatRestoreRowIJ(Ao, 0, PETSC_FALSE, PETSC_FALSE, &nr, &ia[1], &ja[1], &done));
  if (ierr) delete map;
  PetscCheck(!ierr, PETSC_COMM_SELF, PETSC_ERR_PLIB, "the matrix lacks an entry of the spring graph's pattern");
  *out = map;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the map of A's assembled pattern, hung on A (AIJ only) */
static PetscErrorCode AssemblyMapAttach(MSimSystem sys, Mat A)
{
  Mat             Ad, Ao;
  const PetscInt *garray;
  AssemblyMap    *map = NULL;
  PetscContainer  container;

  PetscFunctionBeginUser;
  PetscCall(AssemblyParts(A, &Ad, &Ao, &garray));
  if (!Ad) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(AssemblyMapBuild(sys, A, &map));
  PetscCall(MatGetNonzeroState(A, &map->state));
  PetscCall(PetscContainerCreate(PETSC_COMM_SELF, &container));
  PetscCall(PetscContainerSetPointer(container, map));
  PetscCall(PetscContainerSetUserDestroy(container, AssemblyMapDestroy));
  PetscCall(PetscObjectCompose((PetscObject)A, "MSimAssemblyMap", (PetscObject)container));
  PetscCall(PetscContainerDestroy(&container));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* zeros in every entry an assembly writes (the spring blocks as MSimSystemAssembleMatrix adds them,
   the owned diagonal), then the map */
static PetscErrorCode AssemblePattern(MSimSystem sys, Mat A)
{
  const PetscScalar zero[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  PetscErrorCode    ierr    = 0;

  PetscFunctionBeginUser;
  auto add = [&](PetscInt r, PetscInt col) {
    if (ierr) return;
    const PetscInt gr = sys->local_to_global[r], gc = sys->local_to_global[col];
    ierr = MatSetValuesBlocked(A, 1, &gr, 1, &gc, zero, ADD_VALUES);
  };
  SpringBlocks(sys, [&](PetscInt, PetscInt, PetscReal, PetscReal, PetscInt r, PetscInt col, bool) { add(r, col); });
  PetscCall(ierr);
  for (PetscInt i = 0; i < 3 * sys->nown; i++) {
    const PetscInt row = 3 * sys->rstart + i;
    PetscCall(MatSetValues(A, 1, &row, 1, &row, zero, ADD_VALUES));
  }
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscCall(AssemblyMapAttach(sys, A));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemAssembleMatrix(MSimSystem sys, const MSimMatrixCoefficients *c, Mat A)
{
  const PetscScalar *x, *xn = NULL, *m;
  PetscScalar       *va[2] = {NULL, NULL};
  PetscErrorCode     ierr        = 0;
  PetscContainer     container;
  AssemblyMap       *map = NULL;
  Mat                Ad = NULL, Ao = NULL;
  const PetscInt    *garray;
  size_t             blk = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Jacobian, c->X, A, 0, 0));
  PetscCall(PetscObjectQuery((PetscObject)A, "MSimAssemblyMap", (PetscObject *)&container));
  if (container) PetscCall(PetscContainerGetPointer(container, (void **)&map));
  if (map) {
    PetscObjectState state;
    PetscCall(MatGetNonzeroState(A, &state));
    if (state != map->state) { /* the pattern grew since the map was made: assemble by search, then re-map */
      PetscCall(PetscObjectCompose((PetscObject)A, "MSimAssemblyMap", NULL));
      map = NULL;
    }
  }
  PetscCall(MatZeroEntries(A));
  if (map) {
    PetscCall(AssemblyParts(A, &Ad, &Ao, &garray));
    PetscCall(MatSeqAIJGetArray(Ad, &va[0]));
    if (Ao) PetscCall(MatSeqAIJGetArray(Ao, &va[1]));
  }
  if (c->Xn && c->damping != 0) {
    /* spring axes at the start of the step, held in vloc (free during assembly) */
    PetscCall(MSimSystemGlobalToLocal(sys, c->tn, c->Xn, sys->vloc));
    PetscCall(VecGetArrayRead(sys->vloc, &xn));
  }
  PetscCall(MSimSystemGlobalToLocal(sys, c->t, c->X, sys->xloc));
  PetscCall(VecGetArrayRead(sys->xloc, &x));
  /* one block: straight into the arrays where mapped, else MatSetValuesBlocked (B is symmetric,
     so Eigen's column-major storage is the row-major PETSc expects) */
  auto add = [&](PetscInt r, PetscInt col, const Mat3 &B) {
    if (map && map->off[3 * blk] >= 0) {
      PetscScalar *v = va[(int)map->part[blk]];
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) v[map->off[3 * blk + a] + b] += B(a, b);
    } else if (!ierr) {
      const PetscInt gr = sys->local_to_global[r], gc = sys->local_to_global[col];
      ierr = MatSetValuesBlocked(A, 1, &gr, 1, &gc, B.data(), ADD_VALUES);
    }
    blk++;
  };
  /* a spring's Hessian once for its blocks, which SpringBlocks gives in a row: a new spring is the
     one whose first block this is (its diagonal block of i or, i a ghost's, of j) */
  Mat3 H, Hn;
  SpringBlocks(sys, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L, PetscInt r, PetscInt col, bool off) {
    if (!off && (r == i || i >= sys->nown)) {
      H = c->stiffness * msim::SpringHessian(CMap3(x + 3 * i), CMap3(x + 3 * j), k, L, (bool)c->psd);
      if (xn) {
        const Vec3 n = (CMap3(xn + 3 * i) - CMap3(xn + 3 * j)).normalized();
        H += (c->damping * sys->damping) * (n * n.transpose());
      }
      Hn = -H;
    }
    add(r, col, off ? Hn : H);
  });
  PetscCall(ierr);
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  if (xn) PetscCall(VecRestoreArrayRead(sys->vloc, &xn));
  /* diagonal: mass and drag */
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) {
    PetscInt    row = 3 * sys->rstart + i;
    PetscScalar v   = c->mass * m[i] + c->diagonal;
    if (map) va[0][map->diag[i]] += v;
    else if (v != 0) PetscCall(MatSetValues(A, 1, &row, 1, &row, &v, ADD_VALUES));
  }
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  if (map) {
    PetscCall(MatSeqAIJRestoreArray(Ad, &va[0]));
    if (Ao) PetscCall(MatSeqAIJRestoreArray(Ao, &va[1]));
  }
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  if (!map) PetscCall(AssemblyMapAttach(sys, A)); /* the pattern is final now: map it for the next assemblies */
  PetscCall(PetscLogEventEnd(MSIM_Jacobian, c->X, A, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemCreateMassMatrix(MSimSystem sys, Mat *M)
{
  PetscFunctionBeginUser;
  PetscCall(MatCreateAIJ(sys->comm, 3 * sys->nown, 3 * sys->nown, 3 * sys->nfree, 3 * sys->nfree, 1, NULL, 0, NULL, M));
  PetscCall(MatDiagonalSet(*M, sys->mass, INSERT_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}
