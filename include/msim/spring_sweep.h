/* The hot loop over many springs, shared by the explicit force, the implicit residual and energy,
   and the projective-dynamics local step. With d = x_i - x_j, l = |d| and c = k (alpha + beta L/l):
   f_i += c d, f_j -= c d, and the spring energy sum k/2 (l - L)^2. Choices of (alpha, beta):
   force -f = grad E: (-1, 1); h^2 grad E: (h^2, -h^2); PD projection h^2 k (L/l) d: (0, h^2).
   Positions and forces are rows of 3 (a block-size-3 Vec's array). With AVX2 four springs go
   through the square root and the division together. */

#pragma once
#include <petscsys.h>

/* f may be NULL (energy only); energy may be NULL (no energy). */
void MSimSpringSweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *energy);

/* The same over springs [s0, s1) whose ends are local slots (msim/system.h): a slot below nown is
   row slot of xown / fown (the Vec arrays), any other is row slot of xloc / floc. */
void MSimSpringSweepSlots(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, PetscInt nown, const PetscReal *xown, const PetscReal *xloc, PetscReal *fown, PetscReal *floc, PetscReal alpha, PetscReal beta, PetscReal *energy);

/* The sliced springs (msim/system.h, MSimSprings): slice c's four vertices keep their sums in
   registers and add them once; each spring's other end adds into f4, rows of 4 (x, y, z, pad),
   one aligned 4-wide update instead of a 2-wide and a scalar one. Fold f4 into f afterwards. */
void MSimSpringSweepSlices(PetscInt nslice, const PetscInt *cptr, const PetscInt *sj, const PetscReal *sk, const PetscReal *sL, const PetscReal *x, PetscReal *f4, PetscReal alpha, PetscReal beta, PetscReal *energy);
/* f[3v + c] += f4[4v + c] for v < n, c < 3, and f4 back to zero */
void MSimSpringFold(PetscInt n, PetscReal *f4, PetscReal *f);
