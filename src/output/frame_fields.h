/* The per-cell fields of a frame, from positions: shared by the .vtu series (rank 0, every cell)
   and the HDF5 series (each rank its own cells). */
#pragma once
#include <petscsys.h>

/* strain[s] = l/L - 1 of spring s, its ends ends[2s], ends[2s+1] indexing x (3 per point) */
void MSimFrameStrain(size_t n, const PetscInt *ends, const PetscReal *L, const PetscReal *x, PetscReal *strain);
/* ratio[c] = V/V0 of tet c (signed volumes: negative where it is inverted), corners tets[4c..4c+3] */
void MSimFrameVolumeRatio(size_t n, const PetscInt *tets, const PetscReal *V0, const PetscReal *x, PetscReal *ratio);
