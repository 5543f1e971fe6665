/* Output layer: ParaView series, per-step monitors, final positions. Everything is in input vertex
   order, so files do not depend on the rank count (a .vtu series is written by rank 0 from data
   gathered there, the HDF5 series by every rank at once). Files
   are written whole (temporary file, then rename): a killed run never leaves a truncated frame. The
   series' collection (series.pvd, series.xdmf) grows in place by each frame's entry, so that its
   writes stay O(1) a frame; a kill leaves it well-formed (src/output/collection.cpp). */
#pragma once
#include <msim/system.h>
#include <cstdio>
#include <vector>

typedef struct _n_MSimOutput *MSimOutput;

/* -msim_output DIR, -msim_output_every k. Returns NULL output (no-op) when no directory is set. */
PetscErrorCode MSimOutputCreate(MSimSystem sys, MSimOutput *out);
PetscErrorCode MSimOutputSetUp(MSimOutput out); /* creates the directory: call once input is valid */
/* Takes away the directories MSimOutputSetUp created while they are still empty: for a run refused
   after it (a monitor file that cannot be written), which then leaves nothing behind. */
PetscErrorCode MSimOutputRemoveIfUnused(MSimOutput out);
/* A restarted run: the series lists the frames on disk up to that step, and goes on */
PetscErrorCode MSimOutputResume(MSimOutput out, PetscInt step);
PetscErrorCode MSimOutputWanted(MSimOutput out, PetscInt step, PetscInt last, PetscBool *want);
/* A frame of the state (X, V) at time t. Besides positions it holds, in input vertex order, each
   vertex's `fixed` flag, `file_id` (its id in the input file; -1 for a vertex msim made, by TetGen
   or -msim_refine) and `velocity`, each spring's `strain` l/L - 1 and each tet's `volume_ratio`
   V/V0 (signed volumes: negative where inverted), and with obstacles each vertex's `contact_force`
   (N, msim/contact_force.h). The springs are the cells where the scene has
   no others (grids, chains); a mesh's springs are a second piece (.vtu: frame_NNNNNN_springs.vtu,
   part 1 of the .pvd's timestep; HDF5: the second grid of the frame's spatial collection). */
PetscErrorCode MSimOutputWriteFrame(MSimOutput out, PetscInt step, PetscReal t, Vec X, Vec V);
/* A file NAME.vtu in the output directory outside the series (e.g. the last finite state). */
PetscErrorCode MSimOutputWriteExtra(MSimOutput out, const char name[], PetscReal t, Vec X, Vec V);
PetscErrorCode MSimOutputDestroy(MSimOutput *out);
/* made (optional, len bytes): the outermost directory this call created ("" if none), so that a run
   refused before it writes anything can take them away again (MSimOutputRemoveIfUnused) */
PetscErrorCode MSimMakeDirectory(MPI_Comm comm, const char dir[], const char option[], char made[], size_t len);

/* One .vtu file (raw appended binary): points, cells of cell_size vertices each (2: VTK_LINE, 3:
   VTK_TRIANGLE, 4: VTK_TETRA), the fixed flag, and optionally one point vector field `name` (e.g.
   a mode shape; NULL for none). Rank 0 only. */
PetscErrorCode MSimWriteVTU(const char path[], PetscInt nv, const PetscReal *x, PetscInt ncell, int cell_size, const PetscInt *cells, const char *fixed, const char name[], const PetscReal *field);
/* A named array of a .vtu piece: one tuple of ncomp values of VTK type `type` (Float64, Int64 or
   UInt8) per point or per cell */
typedef struct {
  const char *name;
  const char *type;
  int         ncomp;
  const void *data;
} MSimVTUArray;
/* The same with any point and cell arrays. Rank 0 only. */
PetscErrorCode MSimWriteVTUPiece(const char path[], PetscInt nv, const PetscReal *x, PetscInt ncell, int cell_size, const PetscInt *cells, int npoint, const MSimVTUArray point[], int ncelldata, const MSimVTUArray cell[]);
/* Write text atomically: PATH.tmp then rename. */
PetscErrorCode MSimWriteFileAtomic(const char path[], const void *data, size_t n);

typedef struct {
  PetscBool      ascii;
  FILE          *csv;
  char           csv_path[PETSC_MAX_PATH_LEN];
  PetscLogDouble wall0;
} MSimMonitor;

/* checkpoint.cpp: -msim_checkpoint F (-msim_checkpoint_every k), -msim_restart F */
typedef struct _n_MSimCheckpoint *MSimCheckpoint;
PetscErrorCode MSimCheckpointCreate(MSimSystem sys, MSimCheckpoint *ck);
PetscErrorCode MSimCheckpointWanted(MSimCheckpoint ck, PetscInt step, PetscInt last, PetscBool *want);
PetscErrorCode MSimCheckpointWrite(MSimCheckpoint ck, PetscInt step, PetscReal t, PetscReal dt, PetscReal E0, Vec X, Vec V);
/* Collective: with -msim_restart, checks the file against this scene and loads X, V and the step,
   time, step size and initial energy it was written at (*restarted: whether it did) */
PetscErrorCode MSimCheckpointRestart(MSimCheckpoint ck, PetscInt steps, Vec X, Vec V, PetscInt *step, PetscReal *t, PetscReal *dt, PetscReal *E0, PetscBool *restarted);
PetscErrorCode MSimCheckpointPath(MSimCheckpoint ck, char buf[], size_t len);
/* the state a restart read, in words for a refusal that names it: "the checkpoint's state
   (-msim_restart F: step 12, t = 0.24 s)" */
PetscErrorCode MSimCheckpointRestartState(MSimCheckpoint ck, PetscInt step, PetscReal t, char buf[], size_t len);
/* refuses, in one line, a checkpoint path that cannot be written (before any step) */
PetscErrorCode MSimCheckpointCheckWritable(MSimCheckpoint ck);
/* the integrator whose history (ops.get_history) checkpoints carry, under its type name; set
   after its set-up, before MSimCheckpointRestart (none: x and v only) */
PetscErrorCode MSimCheckpointSetIntegrator(MSimCheckpoint ck, struct _n_MSimIntegrator *integ);
PetscErrorCode MSimCheckpointDestroy(MSimCheckpoint *ck);

/* progress.cpp: a line on stderr now and then on long runs (-msim_progress) */
typedef struct {
  PetscReal      interval;    /* s; 0: quiet */
  PetscInt       steps, decile;
  PetscInt       first; /* the step the clock started at (a restarted run's checkpoint step) */
  PetscMPIInt    rank;
  PetscLogDouble start, last;
} MSimProgress;
PetscErrorCode MSimProgressCreate(MPI_Comm comm, PetscInt steps, MSimProgress *p);
PetscErrorCode MSimProgressBegin(MSimProgress *p, PetscInt first);
PetscErrorCode MSimProgressUpdate(MSimProgress *p, PetscInt step, PetscReal t);

PetscErrorCode MSimMonitorCreate(MPI_Comm comm, MSimMonitor *mon);
/* resume_step >= 0: a restarted run, keeping an existing file's rows up to that step if they end
   with it at time resume_t (the checkpoint's), refusing the file otherwise */
PetscErrorCode MSimMonitorSetUp(MPI_Comm comm, MSimMonitor *mon, PetscInt resume_step, PetscReal resume_t);
/* Rank 0: a CSV file whose rows start with their step keeps its header and its rows up to step
   `last` (the tail cut off in place); *kept: whether it existed with a header. t_last (or NULL):
   the time the row of step `last` must have; where it has not (or there is none) *foreign is set,
   *row_t is that row's time (NaN: none) and the file is left untouched */
PetscErrorCode MSimCSVKeepSteps(const char path[], PetscInt last, const PetscReal *t_last, PetscBool *kept, PetscBool *foreign, PetscReal *row_t);
PetscErrorCode MSimMonitorWanted(MSimMonitor *mon, PetscBool *want);
/* phi: the implicit step's incremental potential at its result (0 for explicit methods); contact
   (or NULL: zeros): the obstacles' total force x, y, z, vertices in contact and contact energy
   (msim/contact_force.h) */
PetscErrorCode MSimMonitorWrite(MPI_Comm comm, MSimMonitor *mon, PetscInt step, PetscReal t, PetscReal kinetic, PetscReal potential, PetscInt nl, PetscInt lin, PetscReal residual, PetscReal phi, const PetscReal contact[5]);
PetscErrorCode MSimMonitorDestroy(MPI_Comm comm, MSimMonitor *mon);

/* -msim_view_final VIEWER: positions of all vertices in msim's vertex order (that of the frames,
   whose file_id array maps it to the input file's ids). */
PetscErrorCode MSimViewFinal(MSimSystem sys, PetscReal t, Vec X);
/* before stepping: the directory of -msim_view_final's file exists and is writable (collective) */
PetscErrorCode MSimViewFinalCheckWritable(MSimSystem sys);
