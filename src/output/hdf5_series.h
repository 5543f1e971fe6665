/* The parallel series (HDF5 + XDMF): see hdf5_series.cpp. */
#pragma once
#include "collection.h"
#include <msim/output.h>
#include <string>

struct MSimHDF5Series {
  MSimSystem  sys = NULL;
  std::string dir;
  MSimCollection xdmf;      /* series.xdmf (on rank 0): the XDMF grids of the frames written so far */
  PetscInt    ncells = 0;   /* cells drawn, over all ranks */
  PetscInt    nsprings = 0; /* a mesh's springs (its second grid), over all ranks; 0 for grids and chains */
  PetscBool   contact  = PETSC_FALSE; /* obstacles: each frame holds "/contact_force" (msim/contact_force.h) */
  PetscBool   mesh_written = PETSC_FALSE; /* DIR/mesh.h5, written with the first frame */
  /* the frame's per-cell fields: the positions of the vertices this rank's cells and springs
     touch (gathered from the natural Vec by `fetch`), their ends as indices into it, and the
     fields as Vecs laid out like the cells (each rank its own, in rank order) */
  VecScatter            fetch = NULL;
  Vec                   xcell = NULL, strain = NULL, ratio = NULL;
  std::vector<PetscInt> cell_ends, spring_ends;
};

/* Collective: DIR/mesh.h5 comes with the first frame. */
PetscErrorCode MSimHDF5SeriesSetUp(MSimHDF5Series *h, MSimSystem sys, const char dir[]);
/* Collective: DIR/frame_NNNNNN.h5 and DIR/series.xdmf. */
PetscErrorCode MSimHDF5SeriesWriteFrame(MSimHDF5Series *h, PetscInt step, PetscReal t, Vec X, Vec V);
/* Collective: DIR/NAME.h5 and DIR/NAME.xdmf outside the series (e.g. the last finite state). */
PetscErrorCode MSimHDF5SeriesWriteExtra(MSimHDF5Series *h, const char name[], PetscReal t, Vec X, Vec V);
PetscErrorCode MSimHDF5SeriesDestroy(MSimHDF5Series *h);
