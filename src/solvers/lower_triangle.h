/* A sequential AIJ matrix's lower triangle by rows, as msim's Cholesky analysis and numeric
   factorization take it (supernodal_numeric.h): the serial factor reads the whole matrix, each
   rank's local factor its diagonal block. */
#pragma once
#include <msim/petsc_compat.h>
#include <petscmat.h>
#include <vector>

namespace msim {
/* row i: columns acol[aptr[i] .. aptr[i+1]) (each <= i, ascending as A stores them), values aval */
PetscErrorCode LowerTriangleRows(Mat A, std::vector<int> &aptr, std::vector<int> &acol, std::vector<double> &aval);
} // namespace msim
