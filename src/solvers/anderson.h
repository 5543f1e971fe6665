/* Type-II Anderson mixing for a fixed-point map G (Walker and Ni 2011; Peng et al. 2018 for
   local-global solvers): from the last m differences of f = G(x) - x and of G(x), propose
   x = G(x_k) - dG theta with theta = argmin |f_k - dF theta|. The caller safeguards it. */
#pragma once
#include <petscvec.h>
#include <vector>

typedef struct {
  PetscInt         m, count, next; /* history length, stored pairs, slot to overwrite */
  std::vector<Vec> dF, dG;         /* ring buffers of differences */
  Vec              f_prev, g_prev;
  PetscBool        have_prev;
  std::vector<PetscScalar> gram;   /* m x m: dF_i . dF_j, one new row and column per iteration */
} MSimAnderson;

PetscErrorCode MSimAndersonCreate(Vec tmpl, PetscInt m, MSimAnderson *aa);
PetscErrorCode MSimAndersonDestroy(MSimAnderson *aa);
PetscErrorCode MSimAndersonReset(MSimAnderson *aa);
/* Record f = g - x and g; write the mixed iterate into y (y = g when there is no history yet),
   x untouched: the caller checks the way from x to y before it takes y. *accelerated tells
   whether mixing was used. */
PetscErrorCode MSimAndersonMix(MSimAnderson *aa, Vec x, Vec g, Vec y, PetscBool *accelerated);
