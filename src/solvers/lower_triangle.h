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

/* The same lower triangle kept from one set-up of a matrix to the next (msimllt, serial): where A
   is SeqAIJ with the pattern of the last Update, only the entries whose bits changed are copied,
   found by comparing A's value array with the copy kept at the last Update (PD's contact weights
   change a few diagonal entries between set-ups, and extracting the whole triangle cost 2.2 M
   valgrind instructions a set-up of the 101 x 101 cloth's matrix, against about 0.2 M for the
   comparisons); else LowerTriangleRows. aptr, acol, aval: as LowerTriangleRows gives them, the
   same bits either way. */
class LowerTriangle {
public:
  PetscErrorCode      Update(Mat A);
  std::vector<int>    aptr, acol;
  std::vector<double> aval;

private:
  std::vector<PetscInt>    ia_, ja_; /* A's row starts and columns at the last Update (empty: not SeqAIJ) */
  std::vector<PetscScalar> va_;      /* and its values, upper triangle included */
};
} // namespace msim
