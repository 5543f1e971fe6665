/* PC type "msimllt": msim's sparse Cholesky for PD's matrix, factored in PCSetUp and stored by
   supernodes (supernodal.h), so up to four right-hand sides (PD's x, y and z columns) cost one
   sweep of the factor. PCMSimLLTSolveInterleaved takes them straight from a block-size-3 Vec's
   array, without the dense-matrix copies of KSPMatSolve.
   Serially: Eigen's AMD ordering and msim's symbolic factorization, kept while A's pattern is;
   the numbers by msim's left-looking supernodal factorization (supernodal_numeric.h), which at a
   later set-up recomputes only the supernodes that A's changed entries reach (PD's contact
   weights change a few rows' diagonal), bit for bit the full factorization (-pc_msimllt_partial
   0 refactors in full). On several ranks: one level of domain
   decomposition (schur_cholesky.h), each rank factoring and sweeping its own rows, the interface
   rows of all ranks solved as one small dense Schur complement. MUMPS stays one option away
   (-pd_pc_type cholesky -pd_pc_factor_mat_solver_type mumps), for partitions whose interface is
   too large for a dense Schur complement. */
#include <msim/solvers.h>
#include <msim/log.h>
#include <msim/options.h>
#include "supernodal.h"
#include "supernodal_numeric.h"
#include "schur_cholesky.h"
#include "lower_triangle.h"
#include <cstring>
#include <petscksp.h>
#include <Eigen/SparseCore>
#include <Eigen/OrderingMethods>
#include <vector>

PETSC_EXTERN PetscErrorCode PCCreate_Shell(PC); /* exported by PETSc, declared in no public header */

typedef Eigen::SparseMatrix<double, Eigen::ColMajor, int> SpMat;

typedef struct {
  msim::SupernodalFactor factor; /* serial */
  std::vector<int>       perm;   /* row i of the matrix is row perm[i] of the factor */
  std::vector<msim::V4>  z;      /* work: n rows of 4 lanes */
  PetscInt               n;      /* rows */
  msim::SchurCholesky   *schur;  /* several ranks */
  PetscReal              relax;     /* supernode amalgamation (supernodal.h) */
  PetscInt               max_width;
  PetscBool              partial;   /* refactor only what A's changed entries reach */
  msim::SupernodalCholesky numeric; /* serial: the kept analysis */
  bool                   analyzed;
  PetscReal              analyzed_relax;     /* the options the kept analysis was made with */
  PetscInt               analyzed_max_width;
  std::vector<int>       aptr, acol; /* A's lower triangle by rows, at the last factorization */
  std::vector<double>    aval;
  PetscInt               nfull, npartial;
} PC_LLT;

static PetscLogEvent LLT_Partial; /* -log_view: the factorizations that reused part of the last */

/* PCShellGet/SetContext only act on a PC whose type name is "shell", so the data hangs on the PC
   in a container and dies with it. */
static PetscErrorCode PCLLTGetContext(PC pc, PC_LLT **ctx)
{
  PetscContainer c;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectQuery((PetscObject)pc, "MSimLLT", (PetscObject *)&c));
  PetscCheck(c, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_WRONG, "the PC is not of type msimllt");
  PetscCall(PetscContainerGetPointer(c, (void **)ctx));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PCLLTDestroyContext(void *p)
{
  PetscFunctionBeginUser;
  delete ((PC_LLT *)p)->schur;
  delete (PC_LLT *)p;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PCSetUp_LLT(PC pc)
{
  PC_LLT            *ctx;
  Mat                A;
  PetscInt           n;
  PetscMPIInt        size;
  const char        *prefix;

  PetscFunctionBeginUser;
  PetscCall(PCLLTGetContext(pc, &ctx));
  PetscCall(PCGetOptionsPrefix(pc, &prefix));
  PetscOptionsBegin(PetscObjectComm((PetscObject)pc), prefix, "msimllt: supernodal Cholesky", "PC");
  PetscCall(MSimOptionsReal("-pc_msimllt_relax", "Merge neighbouring supernodes while the stored entries, zeros included, grow by at most this fraction", "", ctx->relax, &ctx->relax, NULL));
  PetscCall(MSimOptionsInt("-pc_msimllt_max_width", "Widest merged supernode (columns)", "", ctx->max_width, &ctx->max_width, NULL));
  PetscCall(PetscOptionsBool("-pc_msimllt_partial", "Refactor only the supernodes that the matrix's changed entries reach (on several ranks, of each rank's local factor; same bits as a full refactorization)", "", ctx->partial, &ctx->partial, NULL));
  PetscOptionsEnd();
  PetscCheck(ctx->relax >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "-%spc_msimllt_relax must be >= 0", prefix ? prefix : "");
  PetscCheck(ctx->max_width >= 1, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "-%spc_msimllt_max_width must be >= 1 (got %" PetscInt_FMT ")", prefix ? prefix : "", ctx->max_width);
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)pc), &size));
  PetscCall(PCGetOperators(pc, NULL, &A));
  PetscCall(MatGetLocalSize(A, &n, NULL));
  ctx->n = n;
  PetscCall(PetscLogEventBegin(MSIM_LLTFactor, pc, 0, 0, 0)); /* -log_view: one per factorization */
  if (size > 1) {
    bool   was_partial;
    double done, total;
    if (!ctx->schur) ctx->schur = new msim::SchurCholesky();
    PetscCall(ctx->schur->SetUp(A, ctx->relax, (int)ctx->max_width, ctx->partial, LLT_Partial, &was_partial, &done, &total));
    PetscCall(PetscLogFlops(done));
    PetscCall(PetscLogEventEnd(MSIM_LLTFactor, pc, 0, 0, 0));
    if (was_partial) ctx->npartial++;
    else ctx->nfull++;
    PetscCall(PetscInfo(pc, "msimllt: %s local factorization (%" PetscInt_FMT " full, %" PetscInt_FMT " partial so far): %.4g of %.4g Mflop\n", was_partial ? "partial" : "full", ctx->nfull, ctx->npartial, done * 1e-6, total * 1e-6));
    PetscCall(PetscInfo(pc, "msimllt: %" PetscInt_FMT " local rows, local factor entries %" PetscInt64_FMT " in %d supernodes, %" PetscInt_FMT " interface rows in all\n", n, (PetscInt64)ctx->schur->LocalEntries(), ctx->schur->LocalSupernodes(), ctx->schur->InterfaceSize()));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  std::vector<int>    aptr, acol;
  std::vector<double> aval;
  PetscCall(msim::LowerTriangleRows(A, aptr, acol, aval));
  std::vector<char> dirty;
  /* the analysis is kept for the same pattern and the same amalgamation options (which shape the supernodes) */
  const bool        keep = ctx->analyzed && aptr == ctx->aptr && acol == ctx->acol && ctx->relax == ctx->analyzed_relax && ctx->max_width == ctx->analyzed_max_width;
  if (!keep) { /* a new pattern: Eigen's AMD ordering (as its SimplicialLLT orders), the structure, the analysis */
    std::vector<Eigen::Triplet<double, int>> t;
    t.reserve(acol.size());
    for (PetscInt i = 0; i < n; i++)
      for (int e = aptr[i]; e < aptr[i + 1]; e++) t.emplace_back((int)i, acol[e], aval[e]);
    SpMat S((int)n, (int)n), C;
    S.setFromTriplets(t.begin(), t.end());
    C = S.selfadjointView<Eigen::Lower>();
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> pinv, p;
    Eigen::AMDOrdering<int>                                        amd;
    amd(C, pinv);
    p = pinv.inverse();
    ctx->perm.assign(p.indices().data(), p.indices().data() + n);
    ctx->numeric.AnalyzeOrdering(ctx->factor, (int)n, ctx->perm.data(), aptr, acol, -1, ctx->relax, (int)ctx->max_width);
    ctx->analyzed           = true;
    ctx->analyzed_relax     = ctx->relax;
    ctx->analyzed_max_width = ctx->max_width;
  } else if (ctx->partial) ctx->numeric.MarkChanged(aval, ctx->aval, dirty);
  /* the numbers always come from msim's factorization, so a factor is the same bits whichever
     of full and partial made it (a restarted run factors from scratch) */
  double done, total;
  if (keep && ctx->partial) PetscCall(PetscLogEventBegin(LLT_Partial, pc, 0, 0, 0));
  const int bad = ctx->numeric.Factor(ctx->factor, aval.data(), dirty.empty() ? nullptr : &dirty, &done, &total);
  if (keep && ctx->partial) PetscCall(PetscLogEventEnd(LLT_Partial, pc, 0, 0, 0));
  if (bad >= 0) { /* the next set-up starts afresh; the error names the matrix's row, which a user can map to a vertex (the factor's numbering is AMD's) */
    PetscInt row = -1;
    for (PetscInt i = 0; i < n; i++)
      if (ctx->perm[i] == bad) row = i;
    ctx->analyzed = false;
    PetscCall(PetscLogEventEnd(MSIM_LLTFactor, pc, 0, 0, 0));
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_MAT_CH_ZRPVT, "msimllt: the matrix is not positive definite (a non-positive pivot at its row %" PetscInt_FMT ")", row);
  }
  PetscCall(PetscLogFlops(done));
  ctx->aptr.swap(aptr);
  ctx->acol.swap(acol);
  ctx->aval.swap(aval);
  if (keep && ctx->partial) ctx->npartial++;
  else ctx->nfull++;
  PetscCall(PetscInfo(pc, "msimllt: %s factorization (%" PetscInt_FMT " full, %" PetscInt_FMT " partial so far): %.4g of %.4g Mflop\n", keep && ctx->partial ? "partial" : (keep ? "full (analysis kept)" : "full (new analysis)"), ctx->nfull, ctx->npartial, done * 1e-6, total * 1e-6));
  PetscCall(PetscLogEventEnd(MSIM_LLTFactor, pc, 0, 0, 0));
  ctx->z.resize(n);
  PetscCall(PetscInfo(pc, "msimllt: n = %" PetscInt_FMT ", factor entries %" PetscInt64_FMT " in %d supernodes\n", n, (PetscInt64)ctx->factor.Entries(), ctx->factor.Supernodes()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* x = A^-1 b for nrhs <= 4 interleaved columns of the whole matrix (one rank). */
static PetscErrorCode LLTSolveSerial(PC_LLT *c, PetscInt nrhs, const PetscScalar *b, PetscScalar *x)
{
  PetscFunctionBeginUser;
  msim::LoadPermuted(c->n, c->perm.data(), nrhs, b, c->z.data());
  /* MSimLLTSweep: the forward and backward sweeps alone, the yardstick of the PD global step
     (runs/bench/suite.py); its flops, 4 per factor entry and column, give the entry count */
  PetscCall(PetscLogEventBegin(MSIM_LLTSweep, 0, 0, 0, 0));
  c->factor.Solve(c->z.data());
  PetscCall(PetscLogFlops(4.0 * nrhs * (double)c->factor.Entries()));
  PetscCall(PetscLogEventEnd(MSIM_LLTSweep, 0, 0, 0, 0));
  msim::StorePermuted(c->n, c->perm.data(), nrhs, c->z.data(), x);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The owned rows of nrhs <= 4 interleaved columns, and their flops (4 per local factor entry and
   column; the serial solve logs its own). Collective on several ranks. */
static PetscErrorCode LLTSolveLocal(PC_LLT *c, PetscInt nrhs, const PetscScalar *b, PetscScalar *x)
{
  PetscFunctionBeginUser;
  if (c->schur) {
    PetscCall(c->schur->Solve(nrhs, b, x));
    PetscCall(PetscLogFlops(4.0 * nrhs * (double)c->schur->LocalEntries()));
  } else PetscCall(LLTSolveSerial(c, nrhs, b, x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCMSimLLTGetFactorSize(PC pc, PetscInt64 *entries, PetscInt *supernodes)
{
  PC_LLT *c;

  PetscFunctionBeginUser;
  PetscCall(PCSetUp(pc));
  PetscCall(PCLLTGetContext(pc, &c));
  *entries    = c->schur ? c->schur->LocalEntries() : c->factor.Entries();
  *supernodes = c->schur ? c->schur->LocalSupernodes() : c->factor.Supernodes();
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCMSimLLTSolveInterleaved(PC pc, PetscInt nrhs, const PetscScalar *b, PetscScalar *x)
{
  PC_LLT *c;

  PetscFunctionBeginUser;
  PetscCheck(nrhs >= 1 && nrhs <= 4, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "msimllt: 1 to 4 interleaved right-hand sides (got %" PetscInt_FMT ")", nrhs);
  PetscCall(PCSetUp(pc));
  PetscCall(PCLLTGetContext(pc, &c));
  PetscCall(LLTSolveLocal(c, nrhs, b, x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PCMatApply_LLT(PC pc, Mat B, Mat X)
{
  PC_LLT                  *c;
  const PetscScalar       *b;
  PetscScalar             *x;
  PetscInt                 nrhs, ldb, ldx;
  std::vector<PetscScalar> bi, xi;

  PetscFunctionBeginUser;
  PetscCall(PCLLTGetContext(pc, &c));
  PetscCall(MatGetSize(B, NULL, &nrhs));
  PetscCall(MatDenseGetLDA(B, &ldb));
  PetscCall(MatDenseGetLDA(X, &ldx));
  PetscCall(MatDenseGetArrayRead(B, &b));
  PetscCall(MatDenseGetArrayWrite(X, &x));
  for (PetscInt c0 = 0; c0 < nrhs; c0 += 4) { /* groups of up to four columns, interleaved */
    const PetscInt k = PetscMin(4, nrhs - c0);
    bi.resize(k * c->n);
    xi.resize(k * c->n);
    for (PetscInt i = 0; i < c->n; i++)
      for (PetscInt r = 0; r < k; r++) bi[k * i + r] = b[(c0 + r) * ldb + i];
    PetscCall(LLTSolveLocal(c, k, bi.data(), xi.data()));
    for (PetscInt i = 0; i < c->n; i++)
      for (PetscInt r = 0; r < k; r++) x[(c0 + r) * ldx + i] = xi[k * i + r];
  }
  PetscCall(MatDenseRestoreArrayRead(B, &b));
  PetscCall(MatDenseRestoreArrayWrite(X, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PCApply_LLT(PC pc, Vec b, Vec x)
{
  PC_LLT            *c;
  const PetscScalar *ba;
  PetscScalar       *xa;

  PetscFunctionBeginUser;
  PetscCall(PCLLTGetContext(pc, &c));
  PetscCall(VecGetArrayRead(b, &ba));
  PetscCall(VecGetArrayWrite(x, &xa));
  PetscCall(LLTSolveLocal(c, 1, ba, xa));
  PetscCall(VecRestoreArrayWrite(x, &xa));
  PetscCall(VecRestoreArrayRead(b, &ba));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCCreate_MSimLLT(PC pc)
{
  PetscContainer c;

  PetscFunctionBeginUser;
  PetscCall(PCCreate_Shell(pc));
  PetscCall(PetscContainerCreate(PetscObjectComm((PetscObject)pc), &c));
  PC_LLT *ctx    = new PC_LLT();
  ctx->relax     = 0.3; /* runs/bench/README.md: 5-8% off the sweep of the benchmark cloth's factor */
  ctx->max_width = 16;
  ctx->partial   = PETSC_TRUE;
  if (!LLT_Partial) PetscCall(PetscLogEventRegister("MSimLLTPartial", MSIM_CLASSID, &LLT_Partial));
  PetscCall(PetscContainerSetPointer(c, ctx));
  PetscCall(PetscContainerSetUserDestroy(c, PCLLTDestroyContext));
  PetscCall(PetscObjectCompose((PetscObject)pc, "MSimLLT", (PetscObject)c));
  PetscCall(PetscContainerDestroy(&c));
  PetscCall(PCShellSetSetUp(pc, PCSetUp_LLT));
  PetscCall(PCShellSetApply(pc, PCApply_LLT));
  PetscCall(PCShellSetMatApply(pc, PCMatApply_LLT));
  PetscCall(PCShellSetName(pc, "msimllt: sparse Cholesky (AMD, supernodal, refactored in part where the matrix changed), supernodal solves of up to 4 right-hand sides at once; on several ranks, local factors and a dense interface Schur complement"));
  PetscFunctionReturn(PETSC_SUCCESS);
}
