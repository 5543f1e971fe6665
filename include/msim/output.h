/* Output layer: ParaView series, per-step monitors, final positions. Everything is written by rank 0
   from positions gathered in input vertex order, so files do not depend on the rank count. Files
   are written whole (temporary file, then rename): a killed run never leaves a truncated frame. */
#pragma once
#include <msim/system.h>
#include <cstdio>
#include <vector>

typedef struct _n_MSimOutput *MSimOutput;

/* -msim_output DIR, -msim_output_every k. Returns NULL output (no-op) when no directory is set. */
PetscErrorCode MSimOutputCreate(MSimSystem sys, MSimOutput *out);
PetscErrorCode MSimOutputSetUp(MSimOutput out); /* creates the directory: call once input is valid */
PetscErrorCode MSimOutputWanted(MSimOutput out, PetscInt step, PetscInt last, PetscBool *want);
PetscErrorCode MSimOutputWriteFrame(MSimOutput out, PetscInt step, PetscReal t, Vec X);
/* A file NAME.vtu in the output directory outside the series (e.g. the last finite state). */
PetscErrorCode MSimOutputWriteExtra(MSimOutput out, const char name[], PetscReal t, Vec X);
PetscErrorCode MSimOutputDestroy(MSimOutput *out);
PetscErrorCode MSimMakeDirectory(MPI_Comm comm, const char dir[], const char option[]);

/* One .vtu file (raw appended binary): points, cells of cell_size vertices each (2: VTK_LINE, 3:
   VTK_TRIANGLE, 4: VTK_TETRA), the fixed flag, and optionally one point vector field `name` (e.g.
   a mode shape; NULL for none). Rank 0 only. */
PetscErrorCode MSimWriteVTU(const char path[], PetscInt nv, const PetscReal *x, PetscInt ncell, int cell_size, const PetscInt *cells, const char *fixed, const char name[], const PetscReal *field);
/* Write text atomically: PATH.tmp then rename. */
PetscErrorCode MSimWriteFileAtomic(const char path[], const void *data, size_t n);

typedef struct {
  PetscBool      ascii;
  FILE          *csv;
  char           csv_path[PETSC_MAX_PATH_LEN];
  PetscLogDouble wall0;
} MSimMonitor;

PetscErrorCode MSimMonitorCreate(MPI_Comm comm, MSimMonitor *mon);
PetscErrorCode MSimMonitorSetUp(MPI_Comm comm, MSimMonitor *mon);
PetscErrorCode MSimMonitorWanted(MSimMonitor *mon, PetscBool *want);
/* phi: the implicit step's incremental potential at its result (0 for explicit methods) */
PetscErrorCode MSimMonitorWrite(MPI_Comm comm, MSimMonitor *mon, PetscInt step, PetscReal t, PetscReal kinetic, PetscReal potential, PetscInt nl, PetscInt lin, PetscReal residual, PetscReal phi);
PetscErrorCode MSimMonitorDestroy(MPI_Comm comm, MSimMonitor *mon);

/* -msim_view_final VIEWER: positions of all vertices in input order. */
PetscErrorCode MSimViewFinal(MSimSystem sys, PetscReal t, Vec X);
