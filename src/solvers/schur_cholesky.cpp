/* SchurCholesky (schur_cholesky.h). The local factor is Eigen's SimplicialLLT of the owned block
   ordered [interior by AMD | interface]: its trailing block L_SS gives this rank's part of the
   Schur complement, A_SS - A_SI A_II^-1 A_IS = L_SS L_SS^T, and its forward sweep over the interior
   columns leaves b_S - L_SI L_II^-1 b_I in the interface rows, the Schur right-hand side. */
#include "schur_cholesky.h"
#include <Eigen/SparseCore>
#include <Eigen/SparseCholesky>
#include <Eigen/Dense>
#include <unordered_map>

namespace msim {
typedef Eigen::SparseMatrix<double, Eigen::ColMajor, int> SpMat;

/* where row r of an N x N upper triangle starts when its rows are packed one after another
   (row i holds columns i .. N-1) */
static inline size_t UpperRow(size_t N, size_t r)
{
  return r * N - r * (r - 1) / 2;
}

PetscErrorCode SchurCholesky::SetUp(Mat A, double relax, int max_width)
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

  /* local numbering: interior rows in AMD order, then the interface rows */
  std::vector<PetscInt> pos(nlocal_);
  for (PetscInt k = 0; k < ninterior_; k++) pos[interior[k]] = k;
  for (PetscInt k = 0; k < ninterface_; k++) pos[interface[k]] = ninterior_ + k;
  std::vector<Eigen::Triplet<double, int>> t;
  for (PetscInt i = 0; i < nlocal_; i++) {
    PetscCall(MatGetRow(Ad, i, &ncols, &cols, &vals));
    for (PetscInt q = 0; q < ncols; q++) t.emplace_back((int)pos[i], (int)pos[cols[q]], PetscRealPart(vals[q]));
    PetscCall(MatRestoreRow(Ad, i, &ncols, &cols, &vals));
  }
  perm_.resize(nlocal_);
  {
    std::vector<Eigen::Triplet<double, int>> tI;
    for (const auto &e : t)
      if (e.row() < ninterior_ && e.col() <= e.row()) tI.push_back(e);
    SpMat AI((int)ninterior_, (int)ninterior_);
    AI.setFromTriplets(tI.begin(), tI.end());
    Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> amd;
    amd.analyzePattern(AI);
    for (PetscInt k = 0; k < ninterior_; k++) perm_[interior[k]] = amd.permutationP().indices()[k];
    for (PetscInt k = 0; k < ninterface_; k++) perm_[interface[k]] = (int)(ninterior_ + k);
  }
  std::vector<Eigen::Triplet<double, int>> tl;
  for (PetscInt i = 0; i < nlocal_; i++) {
    PetscCall(MatGetRow(Ad, i, &ncols, &cols, &vals));
    for (PetscInt q = 0; q < ncols; q++) {
      const int r = perm_[i], c = perm_[cols[q]];
      if (c <= r) tl.emplace_back(r, c, PetscRealPart(vals[q]));
    }
    PetscCall(MatRestoreRow(Ad, i, &ncols, &cols, &vals));
  }
  t.clear();
  SpMat S((int)nlocal_, (int)nlocal_);
  S.setFromTriplets(tl.begin(), tl.end());
  tl.clear();
  Eigen::MatrixXd Lss = Eigen::MatrixXd::Zero(ninterface_, ninterface_);
  {
    Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::NaturalOrdering<int>> llt(S);
    PetscCheck(llt.info() == Eigen::Success, PETSC_COMM_SELF, PETSC_ERR_MAT_CH_ZRPVT, "msimllt: the matrix is not positive definite");
    const SpMat &L = llt.matrixL().nestedExpression();
    local_.Build((int)nlocal_, L.outerIndexPtr(), L.innerIndexPtr(), L.valuePtr(), (int)ninterior_, relax, max_width);
    for (PetscInt j = ninterior_; j < nlocal_; j++)
      for (int p = L.outerIndexPtr()[j]; p < L.outerIndexPtr()[j + 1]; p++) Lss(L.innerIndexPtr()[p] - ninterior_, j - ninterior_) = L.valuePtr()[p];
  }

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
