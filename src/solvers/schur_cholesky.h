/* Sparse Cholesky of a distributed SPD matrix by one level of domain decomposition: each rank's
   rows split into interior rows (coupled to its own rows only) and interface rows (coupled to
   another rank's). The interior rows are eliminated rank by rank with a local sparse factor whose
   interface rows come last; what is left is the Schur complement on the interface rows of all
   ranks, small and dense, factored on every rank. A solve sweeps the local factor's interior
   columns forward, gathers the interface right-hand sides (one MPI_Allgatherv), solves the dense
   system, and sweeps back: each rank touches only its own part of the sparse factor. */
#pragma once
#include "supernodal.h"
#include "supernodal_numeric.h"
#include <msim/petsc_compat.h>
#include <vector>

namespace msim {
class SchurCholesky {
public:
  /* Collective. A: MPIAIJ, symmetric positive definite. relax, max_width: the local factor's
     supernode amalgamation (supernodal.h). Called again on the same object, the local analysis is
     kept while the diagonal block's pattern and the interface are the same, and with partial only
     the local supernodes that changed entries reach are recomputed (*was_partial; *done, *total:
     the local factor's flops recomputed and in all; partial_event logs the partial ones). */
  PetscErrorCode SetUp(Mat A, double relax, int max_width, bool partial, PetscLogEvent partial_event, bool *was_partial, double *done, double *total);
  /* x = A^-1 b for the owned rows of nrhs <= 4 columns stored interleaved. Collective. */
  PetscErrorCode Solve(PetscInt nrhs, const PetscScalar *b, PetscScalar *x);
  int64_t        LocalEntries() const { return local_.Entries(); }
  int            LocalSupernodes() const { return local_.Supernodes(); }
  PetscInt       InterfaceSize() const { return ntotal_; }

private:
  MPI_Comm                 comm_ = MPI_COMM_NULL;
  PetscInt                 nlocal_ = 0, ninterior_ = 0, ninterface_ = 0;
  PetscInt                 ntotal_ = 0, offset_ = 0; /* interface rows of all ranks; this rank's first */
  std::vector<int>         perm_;                    /* owned row i is row perm_[i] of the local factor */
  SupernodalFactor         local_;                   /* interior columns first, interface last */
  SupernodalCholesky       numeric_;                 /* its kept analysis */
  bool                     analyzed_ = false;
  double                   relax_     = -1; /* the amalgamation options the kept analysis was made with */
  int                      max_width_ = -1;
  std::vector<char>        iface_;                   /* the owned rows coupled to other ranks' */
  std::vector<int>         aptr_, acol_;             /* the diagonal block's lower triangle at the last factorization */
  std::vector<double>      aval_;
  std::vector<PetscMPIInt> counts_, displs_;         /* interface rows per rank, in doubles (4 lanes) */
  std::vector<double>      schur_, schurT_;          /* dense Cholesky factor L of the Schur complement and
                                                        L^T, row-major, each its triangle only */
  std::vector<V4>          z_, c_;
};
} // namespace msim
