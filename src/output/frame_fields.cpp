/* Spring strain and tet volume ratio of a frame (see frame_fields.h). */
#include "frame_fields.h"
#include <msim/mesh.h>

void MSimFrameStrain(size_t n, const PetscInt *ends, const PetscReal *L, const PetscReal *x, PetscReal *strain)
{
  for (size_t s = 0; s < n; s++) {
    const PetscReal *a = x + 3 * ends[2 * s], *b = x + 3 * ends[2 * s + 1];
    const PetscReal  d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    strain[s]             = PetscSqrtReal(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / L[s] - 1.0;
  }
}

void MSimFrameVolumeRatio(size_t n, const PetscInt *tets, const PetscReal *V0, const PetscReal *x, PetscReal *ratio)
{
  for (size_t c = 0; c < n; c++) {
    const PetscInt *t = tets + 4 * c;
    ratio[c]          = MSimTetVolume(x + 3 * t[0], x + 3 * t[1], x + 3 * t[2], x + 3 * t[3]) / V0[c];
  }
}
