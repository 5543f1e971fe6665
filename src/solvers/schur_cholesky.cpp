/* SchurCholesky (schur_cholesky.h). The local factor is msim's supernodal Cholesky
   (supernodal_numeric.h) of the owned block ordered [interior by Eigen's AMD | interface], its
   analysis kept while the block's pattern is, refactored in part when only some of its entries
   changed (as the serial factor; the dense Schur complement is redone each time): its trailing block L_SS gives this rank's part of the
   Schur complement, A_SS - A_SI A_II^-1 A_IS = L_SS L_SS^T, and its forward sweep over the interior
   columns leaves b_S - L_SI L_II^-1 b_I in the interface rows, the Schur right-hand side. */
#include "schur_cholesky.h"
#include "lower_triangle.h"
#include <Eigen/SparseCore>
#include <Eigen/SparseCholesky>
#include <Eigen/Dense>
#include <unordered_map>
#include <cstring>

namespace msim {
typedef Eigen::SparseMatrix<double, Eigen::ColMajor, int> SpMat;

/* where row r of an N x N upper triangle starts when its rows are packed one after another
   (row i holds columns i .. N-1) */
static inline size_t UpperRow(size_t N, size_t r)
{
  return r * N - r * (r - 1) / 2;
}

PetscErrorCode SchurCholesky::SetUp(Mat A, double relax, int max_width, bool partial, PetscLogEvent partial_event, bool *was_partial, double *done, double *total)
{
  Mat                Ad, Ao;
  const PetscInt    *colmap, *cols;
  const PetscScalar *vals;
  PetscInt           ncols, rstart;
  PetscMPIInt        size;

  PetscFunctionBeginUser;
  comm_ = PetscObjectComm((PetscObject)A);
  PetscCallMPI(MPI_Comm_size(comm_, &size));
  PetscCall(MatMPIAIJGetSeqAIJ(A, &Ad, &Ao, &colmap));
  PetscCall(MatGetOwnershipRange(A, &rstart, NULL));
  PetscCall(MatGetLocalSize(A, &nlocal_, NULL));

  /* interface rows: those with a coupling to another rank's rows */
  std::vector<char>     iface(nlocal_, 0);
  std::vector<PetscInt> interior, interface;
  for (PetscInt i = 0; i < nlocal_; i++) {
    PetscCall(MatGetRow(Ao, i, &ncols, NULL, NULL));
    iface[i] = ncols > 0;
    PetscCall(MatRestoreRow(Ao, i, &ncols, NULL, NULL));
    (iface[i] ? interface : interior).push_back(i);
  }
  ninterior_  = (PetscInt)interior.size();
  ninterface_ = (PetscInt)interface.size();

  /* the diagonal block's lower triangle by rows, in the owned rows' numbering */
  std::vector<int>    aptr, acol;
  std::vector<double> aval;
  PetscCall(LowerTriangleRows(Ad, aptr, acol, aval));
  const bool        keep = analyzed_ && iface == iface_ && aptr == aptr_ && acol == acol_ && relax == relax_ && max_width == max_width_;
  std::vector<char> dirty;
  if (!keep) { /* local numbering: interior rows in AMD order, then the interface rows; the analysis */
    std::vector<PetscInt> pos(nlocal_);
    for (PetscInt k = 0; k < ninterior_; k++) pos[interior[k]] = k;
    std::vector<Eigen::Triplet<double, int>> tI;
    for (PetscInt i = 0; i < nlocal_; i++)
      for (int e = aptr[i]; e < aptr[i + 1]; e++)
        if (!iface[i] && !iface[acol[e]]) tI.emplace_back((int)std::max(pos[i], pos[acol[e]]), (int)std::min(pos[i], pos[acol[e]]), aval[e]);
    SpMat AI((int)ninterior_, (int)ninterior_);
    AI.setFromTriplets(tI.begin(), tI.end());
    Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> amd;
    amd.analyzePattern(AI);
    perm_.resize(nlocal_);
    for (PetscInt k = 0; k < ninterior_; k++) perm_[interior[k]] = amd.permutationP().indices()[k];
    for (PetscInt k = 0; k < ninterface_; k++) perm_[interface[k]] = (int)(ninterior_ + k);
    numeric_.AnalyzeOrdering(local_, (int)nlocal_, perm_.data(), aptr, acol, (int)ninterior_, relax, max_width);
    analyzed_  = true;
    iface_     = iface;
    relax_     = relax;
    max_width_ = max_width;
  } else if (partial) numeric_.MarkChanged(aval, aval_, dirty);
  *was_partial = keep && partial;
  if (*was_partial) PetscCall(PetscLogEventBegin(partial_event, 0, 0, 0, 0));
  const int bad = numeric_.Factor(local_, aval.data(), dirty.empty() ? nullptr : &dirty, done, total);
  if (*was_partial) PetscCall(PetscLogEventEnd(partial_event, 0, 0, 0, 0));
  if (bad >= 0) analyzed_ = false;
  { /* every rank learns of a failed pivot before the collective steps below, so the error is
       raised on all of them (one rank returning alone would leave the others in MPI_Allgather);
       it names the matrix's global row (the least over the ranks), which a user can map to a
       vertex, as the serial factor's error does (the local factor's numbering is AMD's) */
    PetscInt row = PETSC_MAX_INT, first;
    if (bad >= 0)
      for (PetscInt i = 0; i < nlocal_; i++)
        if (perm_[i] == bad) row = rstart + i;
    PetscCall(MPIU_Allreduce(&row, &first, 1, MPIU_INT, MPI_MIN, comm_));
    PetscCheck(first == PETSC_MAX_INT, comm_, PETSC_ERR_MAT_CH_ZRPVT, "msimllt: the matrix is not positive definite (a non-positive pivot at its row %" PetscInt_FMT ")", first);
  }
  aptr_.swap(aptr);
  acol_.swap(acol);
  aval_.swap(aval);
  Eigen::MatrixXd Lss(ninterface_, ninterface_);
  numeric_.TrailingBlock(local_, (int)ninterior_, Lss.data());

  /* the interface rows of every rank, numbered rank by rank */
  std::vector<PetscMPIInt> nper(size), off(size + 1, 0);
  PetscMPIInt              mine = (PetscMPIInt)ninterface_, rank;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  PetscCallMPI(MPI_Allgather(&mine, 1, MPI_INT, nper.data(), 1, MPI_INT, comm_));
  for (PetscMPIInt r = 0; r < size; r++) off[r + 1] = off[r] + nper[r];
  ntotal_  = off[size];
  offset_  = off[rank];
  std::vector<PetscInt> gmine(ninterface_), gall(ntotal_);
  for (PetscInt k = 0; k < ninterface_; k++) gmine[k] = rstart + interface[k];
  PetscCallMPI(MPI_Allgatherv(gmine.data(), mine, MPIU_INT, gall.data(), nper.data(), off.data(), MPIU_INT, comm_));
  std::unordered_map<PetscInt, PetscInt> index;
  for (PetscInt k = 0; k < ntotal_; k++) index[gall[k]] = k;

  /* this rank's rows of the Schur complement: L_SS L_SS^T, plus the couplings to other ranks */
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = Eigen::MatrixXd::Zero(ninterface_, ntotal_);
  rows.block(0, offset_, ninterface_, ninterface_) = Lss * Lss.transpose();
  for (PetscInt k = 0; k < ninterface_; k++) {
    PetscCall(MatGetRow(Ao, interface[k], &ncols, &cols, &vals));
    for (PetscInt q = 0; q < ncols; q++) rows(k, index.at(colmap[cols[q]])) += PetscRealPart(vals[q]);
    PetscCall(MatRestoreRow(Ao, interface[k], &ncols, &cols, &vals));
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> full(ntotal_, ntotal_);
  {
    std::vector<PetscMPIInt> cnt(size), dsp(size);
    for (PetscMPIInt r = 0; r < size; r++) {
      cnt[r] = nper[r] * (PetscMPIInt)ntotal_;
      dsp[r] = off[r] * (PetscMPIInt)ntotal_;
    }
    PetscCallMPI(MPI_Allgatherv(rows.data(), cnt[rank], MPI_DOUBLE, full.data(), cnt.data(), dsp.data(), MPI_DOUBLE, comm_));
  }
  Eigen::LLT<Eigen::MatrixXd> dense(full);
  PetscCheck(dense.info() == Eigen::Success, comm_, PETSC_ERR_MAT_CH_ZRPVT, "msimllt: the interface Schur complement is not positive definite");
  /* L row by row for the forward solve, L^T row by row (L column by column) for the backward one:
     both then run as dot products over contiguous rows. Each is packed (its triangle only), so the
     two together take N^2 doubles: 128 MB at the 4,000 interface rows PD allows. */
  const size_t N = (size_t)ntotal_;
  schur_.assign(N * (N + 1) / 2, 0.0);
  schurT_.assign(N * (N + 1) / 2, 0.0);
  const Eigen::MatrixXd L = dense.matrixL();
  for (size_t r = 0; r < N; r++)
    for (size_t c = 0; c <= r; c++) schur_[r * (r + 1) / 2 + c] = schurT_[UpperRow(N, c) + (r - c)] = L(r, c);

  counts_.resize(size);
  displs_.resize(size);
  for (PetscMPIInt r = 0; r < size; r++) {
    counts_[r] = 4 * nper[r];
    displs_[r] = 4 * off[r];
  }
  z_.resize(nlocal_);
  c_.resize(ntotal_);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SchurCholesky::Solve(PetscInt nrhs, const PetscScalar *b, PetscScalar *x)
{
  const PetscInt N = ntotal_;
  V4            *z = z_.data(), *c = c_.data();

  PetscFunctionBeginUser;
  LoadPermuted(nlocal_, perm_.data(), nrhs, b, z);
  local_.Forward(z, (int)ninterior_);
  PetscCallMPI(MPI_Allgatherv(z + ninterior_, 4 * (PetscMPIInt)ninterface_, MPI_DOUBLE, c, counts_.data(), displs_.data(), MPI_DOUBLE, comm_));
  /* the dense Schur system, every rank the whole of it: L y = c, then L^T x = y */
  for (PetscInt r = 0; r < N; r++) {
    const double *l = &schur_[(size_t)r * (r + 1) / 2];
    c[r]            = RowSubtract(c[r], l, c, r) / Splat(l[r]);
  }
  for (PetscInt r = N - 1; r >= 0; r--) {
    const double *u = &schurT_[UpperRow(N, r)]; /* u[0] is the diagonal */
    c[r]            = RowSubtract(c[r], u + 1, c + r + 1, N - r - 1) / Splat(u[0]);
  }
  for (PetscInt k = 0; k < ninterface_; k++) z[ninterior_ + k] = c[offset_ + k];
  local_.Backward(z, (int)ninterior_);
  StorePermuted(nlocal_, perm_.data(), nrhs, z, x);
  PetscFunctionReturn(PETSC_SUCCESS);
}
} // namespace msim
