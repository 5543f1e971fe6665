/* PC type "msimllt": msim's sparse Cholesky for PD's matrix, factored in PCSetUp and stored by
   supernodes (supernodal.h), so up to four right-hand sides (PD's x, y and z columns) cost one
   sweep of the factor. PCMSimLLTSolveInterleaved takes them straight from a block-size-3 Vec's
   array, without the dense-matrix copies of KSPMatSolve.
   Serially: Eigen's AMD ordering and msim's symbolic factorization, kept while A's pattern is;
   the numbers by msim's left-looking supernodal factorization (supernodal_numeric.h), which at a
   later set-up recomputes only the supernodes that A's changed entries reach (PD's contact
   weights change a few rows' diagonal), bit for bit the full factorization (-pc_msimllt_partial
   0 refactors in full). And where A differs from the last factored matrix (the base) only on a
   few diagonal entries, it keeps the base's factor and corrects each solve by a low-rank update
   (llt_update.h; -pc_msimllt_update, -pc_msimllt_update_max_rank), which costs a sparse forward
   solve per changed row instead of a partial refactorization's two thirds of the factor. On several ranks: one level of domain
   decomposition (schur_cholesky.h), each rank factoring and sweeping its own rows, the interface
   rows of all ranks solved as one small dense Schur complement. MUMPS stays one option away
   (-pd_pc_type cholesky -pd_pc_factor_mat_solver_type mumps), for partitions whose interface is
   too large for a dense Schur complement. */
#include <msim/solvers.h>
#include <msim/log.h>
#include <msim/options.h>
#include "supernodal.h"
#include "supernodal_numeric.h"
#include "llt_update.h"
#include "schur_cholesky.h"
#include "lower_triangle.h"
#include <algorithm>
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
  msim::LowerTriangle    lower;  /* serial: A's lower triangle, kept between set-ups */
  std::vector<int>       aptr, acol; /* A's lower triangle by rows, at the last factorization */
  std::vector<double>    aval;   /* serial: the base, the values the factor holds */
  PetscInt               nfull, npartial, nupdate;
  PetscBool              update_on; /* serial: a low-rank update where only a few diagonal entries changed */
  PetscInt               update_max_rank;
  msim::LowRankUpdate    update;    /* A = base + the update (rank 0: A is the base) */
  std::vector<double>    uval;      /* A's values the update was built for (empty: none) */
  std::vector<double>    pending_base; /* PCMSimLLTSetBaseDiagonal's, for the next set-up */
  bool                   has_pending_base;
} PC_LLT;

static PetscLogEvent LLT_Partial; /* -log_view: the factorizations that reused part of the last */
static PetscLogEvent LLT_Update;  /* -log_view: the low-rank updates built in place of one */

/* the position of row i's diagonal entry among A's lower-triangle entries, -1 if none */
static int DiagonalEntry(const std::vector<int> &aptr, const std::vector<int> &acol, PetscInt i)
{
  for (int e = aptr[i + 1] - 1; e >= aptr[i]; e--)
    if (acol[e] == i) return e;
  return -1;
}

/* In place of a refactorization, when A (aval) differs from the base (ctx->aval, same pattern)
   only on at most update_max_rank diagonal entries: the update's Y and C from the base's factor.
   *taken false: refactor (an off-diagonal or too many entries changed, or C singular). The
   changed rows go in the factor's order, so the update depends only on the base and A. One rank
   alone updates (several refactor, with the bits of a full refactorization), so its solves' roundoff
   (up to 1e-10 |x| at the thresholds below) is 1 rank's own: PD at -msim_contact_distance 1e-5
   amplifies it (the 21 x 21 cloth on a centred ball, PD-10: 1 and 2 ranks 1.05e-10 m apart after
   its update at step 5, 5.1e-5 m at step 7, 2.4e-2 m at step 20; -pd_pc_msimllt_update 0:
   3.0e-13, 1.7e-9 and 6.3e-6 m). */
static PetscErrorCode TryUpdate(PC pc, PC_LLT *ctx, const std::vector<int> &aptr, const std::vector<int> &acol, const std::vector<double> &aval, bool *taken)
{
  std::vector<std::pair<int, double>> ch;
  bool                                diagonal = true;

  PetscFunctionBeginUser;
  *taken = false;
  if (ctx->uval.size() == aval.size() && !std::memcmp(ctx->uval.data(), aval.data(), sizeof(double) * aval.size())) { /* set up again on the same values */
    *taken = true;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  ctx->uval.clear();
  /* the entries whose bits differ, found a block at a time (a few dozen of 60,000 on the drape) */
  const size_t ne = aval.size(), B = 64;
  long         ndiag = 0, noff = 0, nlarge = 0;
  for (size_t b0 = 0; b0 < ne; b0 += B) {
    const size_t b1 = std::min(ne, b0 + B);
    if (!std::memcmp(aval.data() + b0, ctx->aval.data() + b0, sizeof(double) * (b1 - b0))) continue;
    for (size_t e = b0; e < b1; e++) {
      const double dv = aval[e] - ctx->aval[e]; /* 0 for -0 against 0: the same matrix */
      if (dv == 0) continue;
      const PetscInt i = (PetscInt)(std::upper_bound(aptr.begin(), aptr.end(), (int)e) - aptr.begin()) - 1; /* e's row */
      if (acol[e] != i) noff++;
      else if (dv < 0 ? -dv > 1e3 * aval[e] : dv > 1e6 * ctx->aval[e]) nlarge++; /* d < 0: C = 1/d + (B^-1)_jj cancels, about eps |d| / a_jj lost; d > 0: the right-hand side's (b_jj + d) x_j goes through B^-1 and the correction cancels all but x_j, about eps d / b_jj |x| lost (PD's contact weight 1e15 x the base's put every vertex's global step 20 m off; up to 1e6, 1e-10 |x|: the default contact distance's drapes stay below 6.4e5) */
      else if (++ndiag <= ctx->update_max_rank) ch.emplace_back(ctx->perm[i], dv);
    }
  }
  diagonal = !noff && !nlarge && ndiag <= ctx->update_max_rank;
  if (!diagonal) {
    PetscCall(PetscInfo(pc, "msimllt: %ld diagonal and %ld off-diagonal entries changed since the last factorization (at most %" PetscInt_FMT " diagonal ones for an update), %ld diagonal ones lowered by over 1e3 x their new value or raised by over 1e6 x their old one: refactoring\n", ndiag + nlarge, noff, ctx->update_max_rank, nlarge));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  std::sort(ch.begin(), ch.end());
  std::vector<int>    col(ch.size());
  std::vector<double> d(ch.size());
  for (size_t j = 0; j < ch.size(); j++) {
    col[j] = ch[j].first;
    d[j]   = ch[j].second;
  }
  double flops;
  PetscCall(PetscLogEventBegin(LLT_Update, pc, 0, 0, 0));
  const bool ok = ctx->update.Build(ctx->factor, col, d, &flops);
  PetscCall(PetscLogFlops(flops));
  PetscCall(PetscLogEventEnd(LLT_Update, pc, 0, 0, 0));
  if (!ok) {
    PetscCall(PetscInfo(pc, "msimllt: the update's capacitance matrix (rank %d) is singular: refactoring\n", (int)col.size()));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  ctx->nupdate++;
  ctx->uval = aval;
  *taken    = true;
  PetscCall(PetscInfo(pc, "msimllt: update of rank %d in place of a refactorization (%" PetscInt_FMT " full, %" PetscInt_FMT " partial, %" PetscInt_FMT " updates so far): %.4g Mflop, %ld rows of Y in groups of 4\n", (int)col.size(), ctx->nfull, ctx->npartial, ctx->nupdate, flops * 1e-6, ctx->update.Rows()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

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
  PetscCall(PetscOptionsBool("-pc_msimllt_update", "Serially, where the matrix differs from the last factored one only on a few diagonal entries, correct the solves by a low-rank update instead of refactoring", "", ctx->update_on, &ctx->update_on, NULL));
  PetscCall(MSimOptionsInt("-pc_msimllt_update_max_rank", "Most changed diagonal entries (against the last factored matrix) an update takes; more refactor", "", ctx->update_max_rank, &ctx->update_max_rank, NULL));
  PetscCall(PetscOptionsBool("-pc_msimllt_partial", "Refactor only the supernodes that the matrix's changed entries reach (on several ranks, of each rank's local factor; same bits as a full refactorization)", "", ctx->partial, &ctx->partial, NULL));
  PetscOptionsEnd();
  PetscCheck(ctx->relax >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "-%spc_msimllt_relax must be >= 0", prefix ? prefix : "");
  PetscCheck(ctx->update_max_rank >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "-%spc_msimllt_update_max_rank must be >= 0 (got %" PetscInt_FMT ")", prefix ? prefix : "", ctx->update_max_rank);
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
  PetscCall(ctx->lower.Update(A));
  const std::vector<int>    &aptr = ctx->lower.aptr, &acol = ctx->lower.acol;
  const std::vector<double> &aval = ctx->lower.aval;
  std::vector<char>          dirty;
  /* the analysis is kept for the same pattern and the same amalgamation options (which shape the supernodes) */
  bool              keep = ctx->analyzed && aptr == ctx->aptr && acol == ctx->acol && ctx->relax == ctx->analyzed_relax && ctx->max_width == ctx->analyzed_max_width;
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
  }
  double done, total;
  if (ctx->has_pending_base) { /* PCMSimLLTSetBaseDiagonal: the base first, A's off-diagonal with its diagonal, from scratch */
    PetscCheck((PetscInt)ctx->pending_base.size() == n, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "msimllt: PCMSimLLTSetBaseDiagonal gave %d rows, the matrix has %" PetscInt_FMT, (int)ctx->pending_base.size(), n);
    std::vector<double> base(aval);
    for (PetscInt i = 0; i < n; i++) {
      const int e = DiagonalEntry(aptr, acol, i);
      if (e >= 0) base[e] = ctx->pending_base[i];
    }
    ctx->has_pending_base = false;
    std::vector<double>().swap(ctx->pending_base);
    const int bad = ctx->numeric.Factor(ctx->factor, base.data(), nullptr, &done, &total);
    if (bad >= 0) {
      ctx->analyzed = false;
      PetscCall(PetscLogEventEnd(MSIM_LLTFactor, pc, 0, 0, 0));
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_MAT_CH_ZRPVT, "msimllt: the base matrix given by PCMSimLLTSetBaseDiagonal is not positive definite");
    }
    PetscCall(PetscLogFlops(done));
    ctx->nfull++;
    PetscCall(PetscInfo(pc, "msimllt: full factorization of the given base (%" PetscInt_FMT " full so far): %.4g Mflop\n", ctx->nfull, done * 1e-6));
    ctx->aptr = aptr;
    ctx->acol = acol;
    ctx->aval.swap(base);
    ctx->update.Forget();
    ctx->uval.clear();
    keep = true;
  }
  ctx->z.resize(n);
  if (keep && ctx->update_on) { /* the base's factor kept, corrected by a low-rank update */
    bool taken;
    PetscCall(TryUpdate(pc, ctx, aptr, acol, aval, &taken));
    if (taken) {
      PetscCall(PetscLogEventEnd(MSIM_LLTFactor, pc, 0, 0, 0));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
  }
  ctx->update.Forget(); /* refactored: A becomes the base */
  ctx->uval.clear();
  if (keep && ctx->partial) ctx->numeric.MarkChanged(aval, ctx->aval, dirty);
  /* the numbers always come from msim's factorization, so a factor is the same bits whichever
     of full and partial made it (a restarted run factors from scratch) */
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
  if (!keep) { /* kept: the pattern is the one held (keep's test) */
    ctx->aptr = aptr;
    ctx->acol = acol;
  }
  ctx->aval = aval;
  if (keep && ctx->partial) ctx->npartial++;
  else ctx->nfull++;
  PetscCall(PetscInfo(pc, "msimllt: %s factorization (%" PetscInt_FMT " full, %" PetscInt_FMT " partial so far): %.4g of %.4g Mflop\n", keep && ctx->partial ? "partial" : (keep ? "full (analysis kept)" : "full (new analysis)"), ctx->nfull, ctx->npartial, done * 1e-6, total * 1e-6));
  PetscCall(PetscLogEventEnd(MSIM_LLTFactor, pc, 0, 0, 0));
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
  c->factor.Forward(c->z.data(), (int)c->n);
  if (c->update.Rank()) { /* A = base + P D P^T: Woodbury's correction between the sweeps */
    double flops;
    c->update.Apply(c->z.data(), (int)nrhs, &flops);
    PetscCall(PetscLogFlops(flops));
  }
  c->factor.Backward(c->z.data(), (int)c->n);
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

PetscErrorCode PCMSimLLTGetBaseDiagonal(PC pc, Vec d, PetscBool *has)
{
  PC_LLT      *c;
  PetscMPIInt  size;
  PetscScalar *x;

  PetscFunctionBeginUser;
  PetscCall(PCLLTGetContext(pc, &c));
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)pc), &size));
  *has = PETSC_FALSE;
  if (size > 1 || (!c->has_pending_base && (c->schur || c->aval.empty() || !c->analyzed))) PetscFunctionReturn(PETSC_SUCCESS);
  PetscInt nd;
  PetscCall(VecGetLocalSize(d, &nd));
  PetscCheck(nd == c->n || c->has_pending_base, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "msimllt: the base diagonal's Vec has %" PetscInt_FMT " rows, the matrix %" PetscInt_FMT, nd, c->n);
  PetscCall(VecGetArrayWrite(d, &x));
  if (c->has_pending_base) {
    PetscCheck(nd == (PetscInt)c->pending_base.size(), PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "msimllt: the base diagonal's Vec has %" PetscInt_FMT " rows, the pending base %d", nd, (int)c->pending_base.size());
    for (PetscInt i = 0; i < nd; i++) x[i] = c->pending_base[i];
  } else
    for (PetscInt i = 0; i < nd; i++) {
      const int e = DiagonalEntry(c->aptr, c->acol, i);
      x[i]        = e >= 0 ? c->aval[e] : 0;
    }
  PetscCall(VecRestoreArrayWrite(d, &x));
  *has = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCMSimLLTSetBaseDiagonal(PC pc, Vec d)
{
  PC_LLT            *c;
  PetscMPIInt        size;
  const PetscScalar *x;
  PetscInt           nd;

  PetscFunctionBeginUser;
  PetscCall(PCLLTGetContext(pc, &c));
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)pc), &size));
  if (size > 1) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetLocalSize(d, &nd));
  PetscCall(VecGetArrayRead(d, &x));
  c->pending_base.resize(nd);
  for (PetscInt i = 0; i < nd; i++) c->pending_base[i] = PetscRealPart(x[i]);
  PetscCall(VecRestoreArrayRead(d, &x));
  c->has_pending_base = true;
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
  ctx->update_on = PETSC_TRUE;
  ctx->update_max_rank = 128; /* runs/contact/README.md: the 101 x 101 drape's step, 64 against 128 */
  if (!LLT_Partial) PetscCall(PetscLogEventRegister("MSimLLTPartial", MSIM_CLASSID, &LLT_Partial));
  if (!LLT_Update) PetscCall(PetscLogEventRegister("MSimLLTUpdate", MSIM_CLASSID, &LLT_Update));
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
