/* The parallel series (HDF5 + XDMF): see hdf5_series.cpp. */
#pragma once
#include <msim/output.h>
#include <string>

struct MSimHDF5Series {
  MSimSystem  sys = NULL;
  std::string dir;
  std::string grids;      /* the XDMF grids of the frames written so far */
  PetscInt    ncells = 0; /* cells drawn, over all ranks */
};

/* Collective: writes DIR/mesh.h5. */
PetscErrorCode MSimHDF5SeriesSetUp(MSimHDF5Series *h, MSimSystem sys, const char dir[]);
/* Collective: DIR/frame_NNNNNN.h5 and DIR/series.xdmf. */
PetscErrorCode MSimHDF5SeriesWriteFrame(MSimHDF5Series *h, PetscInt step, PetscReal t, Vec X);
/* Collective: DIR/NAME.h5 and DIR/NAME.xdmf outside the series (e.g. the last finite state). */
PetscErrorCode MSimHDF5SeriesWriteExtra(MSimHDF5Series *h, const char name[], PetscReal t, Vec X);
