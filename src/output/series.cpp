/* ParaView series every k steps, in one of two forms: DIR/frame_NNNNNN.vtu (a mesh's springs in
   DIR/frame_NNNNNN_springs.vtu) and DIR/series.pvd, written by rank 0 from positions and
   velocities gathered whole (small runs; the topology, file ids, rest lengths and volumes
   gathered once), or the parallel HDF5 + XDMF series of hdf5_series.cpp that every rank writes
   its part of (any size). The fields each frame holds: msim/output.h. The collection always
   lists exactly the frames written: each frame adds its entry in place (collection.cpp), and a
   run's first frame writes it whole, so that a restart drops the entries after its checkpoint (and
   the checkpoint's own frame where it is off the schedule). */
#include "collection.h"
#include "hdf5_series.h"
#include "frame_fields.h"
#include <msim/contact_force.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <string>
#include <vector>
#include <msim/errors.h>
#include <cerrno>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <sys/stat.h>
#include <unistd.h>

struct _n_MSimOutput {
  MSimSystem            sys;
  char                  dir[PETSC_MAX_PATH_LEN];
  PetscInt              every;
  MSimCollection        pvd; /* series.pvd, on rank 0 */
  PetscBool             hdf5;
  MSimHDF5Series        h5;
  /* .vtu: on rank 0, every vertex's flag and file id, the cells drawn (input ids) and their rest
     volumes (tets), a mesh's springs and the rest lengths of the springs drawn */
  std::vector<char>      fixed;
  std::vector<PetscInt>  cells, springs;
  std::vector<int64_t>   file_id; /* as the .vtu stores it */
  std::vector<PetscReal> cell_V0, spring_L;
  char                  made[PETSC_MAX_PATH_LEN] = ""; /* the outermost directory SetUp created */
};

PetscErrorCode MSimOutputCreate(MSimSystem sys, MSimOutput *out)
{
  char        dir[PETSC_MAX_PATH_LEN] = "";
  PetscInt    every                   = 50, format;
  PetscBool   set;
  const char *formats[] = {"auto", "vtu", "hdf5"};

  PetscFunctionBeginUser;
  *out = NULL;
  PetscOptionsBegin(sys->comm, NULL, "msim output", NULL);
  PetscCall(PetscOptionsString("-msim_output", "Directory for the ParaView series: frames of positions, velocity, file_id, spring strain and tet volume ratio", NULL, dir, dir, sizeof(dir), &set));
  PetscCall(MSimOptionsInt("-msim_output_every", "Write a frame every k steps", NULL, every, &every, NULL));
  format = 0;
  PetscCall(PetscOptionsEList("-msim_output_format", "Series format: vtu (rank 0 writes .vtu + .pvd), hdf5 (all ranks write HDF5 + XDMF), auto (vtu up to 10^6 vertices)", NULL, formats, 3, formats[0], &format, NULL));
  PetscOptionsEnd();
  PetscCheck(every >= 1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_output_every must be >= 1 (got %" PetscInt_FMT ")", every);
  if (!set || !dir[0]) PetscFunctionReturn(PETSC_SUCCESS);
  *out = new _n_MSimOutput();
  (*out)->sys   = sys;
  (*out)->every = every;
  (*out)->hdf5  = (PetscBool)(format == 2 || (format == 0 && sys->nv > 1000000));
  PetscCall(PetscStrncpy((*out)->dir, dir, sizeof((*out)->dir)));
  (*out)->pvd.path  = std::string(dir) + "/series.pvd";
  (*out)->pvd.head  = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n";
  (*out)->pvd.close = "    \n  </Collection>\n</VTKFile>\n";
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* mkdir -p on rank 0; every rank learns the outcome, so a failure is a collective error. */
PetscErrorCode MSimMakeDirectory(MPI_Comm comm, const char dir[], const char option[], char made[], size_t len)
{
  PetscMPIInt rank;
  int         ok = 1;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (made && len) made[0] = 0;
  if (rank == 0) {
    std::string path(dir);
    for (size_t pos = 1; ok && pos <= path.size(); pos++) {
      if (pos < path.size() && path[pos] != '/') continue;
      std::string part = path.substr(0, pos);
      if (mkdir(part.c_str(), 0755) == 0) {
        if (made && len && !made[0]) PetscCall(PetscStrncpy(made, part.c_str(), len));
      } else if (errno != EEXIST) ok = 0;
    }
    if (ok && access(dir, W_OK) != 0) ok = 0;
  }
  PetscCallMPI(MPI_Bcast(&ok, 1, MPI_INT, 0, comm));
  PetscCheck(ok, comm, PETSC_ERR_FILE_OPEN, "%s: cannot create or write directory %s", option, dir);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOutputRemoveIfUnused(MSimOutput out)
{
  PetscFunctionBeginUser;
  if (!out || !out->made[0] || out->sys->rank != 0) PetscFunctionReturn(PETSC_SUCCESS);
  /* from the innermost up to the outermost one created; rmdir takes only empty ones */
  std::string path(out->dir);
  while (!path.empty() && path.back() == '/') path.pop_back();
  while (path.size() >= strlen(out->made) && rmdir(path.c_str()) == 0) {
    const size_t slash = path.find_last_of('/');
    if (slash == std::string::npos || path == out->made) break;
    path.resize(slash);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOutputSetUp(MSimOutput out)
{
  PetscFunctionBeginUser;
  if (!out) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimMakeDirectory(out->sys->comm, out->dir, "-msim_output", out->made, sizeof(out->made)));
  /* a serial series: rank 0 writes every frame whole, so it holds the topology */
  if (out->hdf5) PetscCall(MSimHDF5SeriesSetUp(&out->h5, out->sys, out->dir));
  else {
    PetscCall(MSimSystemGatherTopology(out->sys, out->fixed, out->cells));
    std::vector<PetscInt> ids;
    PetscCall(MSimSystemGatherFrameTopology(out->sys, ids, out->cell_V0, out->springs, out->spring_L));
    out->file_id.assign(ids.begin(), ids.end());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The frame step in a collection entry's file name (frame_NNNNNN.), or -1 */
static long FrameStep(const std::string &entry)
{
  const size_t at = entry.find("frame_");
  return at == std::string::npos ? -1 : strtol(entry.c_str() + at + 6, NULL, 10);
}

PetscErrorCode MSimOutputResume(MSimOutput out, PetscInt step)
{
  PetscFunctionBeginUser;
  if (!out) PetscFunctionReturn(PETSC_SUCCESS);
  {
    /* the series goes on in the format the run before the checkpoint wrote: in the other one it
       would begin again beside it, its first frames missing (nothing here has been written yet) */
    const std::string mine = out->hdf5 ? "series.xdmf" : "series.pvd", other = out->hdf5 ? "series.pvd" : "series.xdmf";
    const std::string dir(out->dir);
    const PetscBool   ok = (PetscBool)(out->sys->rank || access((dir + "/" + other).c_str(), F_OK) != 0 || access((dir + "/" + mine).c_str(), F_OK) == 0);
    PetscCall(MSimCollectiveCheck(out->sys->comm, ok, "-msim_output " + dir + " holds the " + other + " series of the run before the checkpoint, and this restart writes " + mine + ": give -msim_output_format " + (out->hdf5 ? "vtu" : "hdf5") + " as that run did, or another -msim_output directory"));
  }
  if (out->sys->rank) PetscFunctionReturn(PETSC_SUCCESS);
  /* the collection as the earlier run left it, its entries after the checkpoint dropped (their
     frames are written again). The checkpoint's own frame stays only where this run's schedule
     has it: a first run that ended there off the schedule wrote it as its last frame, which the
     run it continues would not have (the series then matches an uninterrupted run's) */
  auto keep = [&](long k) { return k >= 0 && (k < step || (k == step && step % out->every == 0)); };
  /* the dropped frames this run does not write again (off its schedule): their files stay, as
     msim deletes no file it did not write in this run; a note names them */
  std::vector<long> stale;
  auto drop = [&](long k) {
    if (k >= 0 && k % out->every != 0 && (stale.empty() || stale.back() != k)) stale.push_back(k);
  };
  const std::string path = std::string(out->dir) + (out->hdf5 ? "/series.xdmf" : "/series.pvd");
  FILE             *fp   = fopen(path.c_str(), "r");
  std::string       text, kept;
  char              buf[4096];
  if (!fp) PetscFunctionReturn(PETSC_SUCCESS);
  while (fgets(buf, sizeof(buf), fp)) text += buf;
  fclose(fp);
  /* the entries only: a killed run may have left comments and an entry not yet listed inside a
     processing instruction (collection.cpp) */
  text = MSimCollectionStripMarkup(text);
  if (out->hdf5) { /* grids from "    <Grid Name=" to "    </Grid>" */
    /* a frame's grid may hold grids of its own (a mesh's cells and springs): its end is the
       first closing tag at its own depth */
    const std::string open = "    <Grid Name=\"frame_", close = "\n    </Grid>\n";
    for (size_t at = text.find(open); at != std::string::npos; at = text.find(open, at)) {
      const size_t end = text.find(close, at);
      if (end == std::string::npos) break;
      const std::string grid = text.substr(at, end + close.size() - at);
      if (keep(FrameStep(grid))) kept += grid;
      else drop(FrameStep(grid));
      at = end + close.size();
    }
    out->h5.xdmf.entries = kept;
  } else {
    size_t at = 0;
    while (at < text.size()) {
      size_t            nl   = text.find('\n', at);
      const std::string line = text.substr(at, nl == std::string::npos ? std::string::npos : nl + 1 - at);
      if (line.find("<DataSet ") != std::string::npos) {
        if (keep(FrameStep(line))) kept += line;
        else drop(FrameStep(line));
      }
      if (nl == std::string::npos) break;
      at = nl + 1;
    }
    out->pvd.entries = kept;
  }
  if (!stale.empty()) {
    std::string names;
    for (size_t q = 0; q < stale.size() && q < 3; q++) {
      char name[32];
      snprintf(name, sizeof(name), "%sframe_%06ld", q ? ", " : "", stale[q]);
      names += name;
    }
    if (stale.size() > 3) names += " and " + std::to_string(stale.size() - 3) + " more";
    PetscCall(PetscFPrintf(PETSC_COMM_SELF, PETSC_STDERR, "msim: note: -msim_output %s: %s, an earlier run's frames from the checkpoint's step %" PetscInt_FMT " on and off this run's schedule (every %" PetscInt_FMT "), are no longer in %s; their files stay on disk\n", out->dir, names.c_str(), step, out->every, out->hdf5 ? "series.xdmf" : "series.pvd"));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOutputWanted(MSimOutput out, PetscInt step, PetscInt last, PetscBool *want)
{
  PetscFunctionBeginUser;
  *want = (PetscBool)(out && (step % out->every == 0 || step == last));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* BASE.vtu, and for a mesh BASE_springs.vtu: the frame's pieces (output.h) */
static PetscErrorCode MSimOutputWriteVTU(MSimOutput out, const char base[], PetscReal t, Vec X, Vec V)
{
  MSimSystem             sys = out->sys;
  std::vector<PetscReal> x, v;
  char                   path[PETSC_MAX_PATH_LEN];

  PetscFunctionBeginUser;
  std::vector<PetscReal> fc;
  PetscBool              contact;
  PetscCall(MSimSystemGatherPositions(sys, t, X, x));
  PetscCall(MSimSystemGatherVelocities(sys, V, v));
  PetscCall(MSimContactHasObstacles(sys, &contact));
  if (contact) { /* the obstacles' force on each vertex (zero at the fixed ones) */
    Vec F;
    PetscCall(MSimSystemCreateVec(sys, &F));
    PetscCall(MSimContactForce(sys, t, X, F, NULL));
    PetscCall(MSimSystemGatherVector(sys, F, fc));
    PetscCall(VecDestroy(&F));
  }
  /* rank 0 writes the files; the others wait for its outcome, so that a failed write (disk full,
     an unwritable directory) is one error on every rank, not rank 0's alone while the others go
     on into the next step's collectives and wait there for ever */
  PetscCall(MSimCallOnRankZero(sys->comm, [&]() -> PetscErrorCode {
    const int                  k = sys->out_cell_size;
    const size_t               ncell = out->cells.size() / k, nspring = out->spring_L.size();
    const bool                 lines = out->springs.empty(); /* the cells are the springs */
    std::vector<PetscReal>     strain(nspring), ratio(out->cell_V0.size());
    MSimFrameStrain(nspring, lines ? out->cells.data() : out->springs.data(), out->spring_L.data(), x.data(), strain.data());
    MSimFrameVolumeRatio(ratio.size(), out->cells.data(), out->cell_V0.data(), x.data(), ratio.data());
    const MSimVTUArray point[4] = {
      {"fixed",         "UInt8",   1, out->fixed.data()  },
      {"file_id",       "Int64",   1, out->file_id.data()},
      {"velocity",      "Float64", 3, v.data()           },
      {"contact_force", "Float64", 3, fc.data()          }
    };
    const int npoint = contact ? 4 : 3;
    const MSimVTUArray cellstrain = {"strain", "Float64", 1, strain.data()}, cellratio = {"volume_ratio", "Float64", 1, ratio.data()};
    PetscCall(PetscSNPrintf(path, sizeof(path), "%s/%s.vtu", out->dir, base));
    PetscCall(MSimWriteVTUPiece(path, sys->nv, x.data(), (PetscInt)ncell, k, out->cells.data(), npoint, point, lines ? 1 : k == 4 ? 1 : 0, lines ? &cellstrain : &cellratio));
    if (!lines) {
      PetscCall(PetscSNPrintf(path, sizeof(path), "%s/%s_springs.vtu", out->dir, base));
      PetscCall(MSimWriteVTUPiece(path, sys->nv, x.data(), (PetscInt)nspring, 2, out->springs.data(), npoint, point, 1, &cellstrain));
    }
    return PETSC_SUCCESS;
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOutputWriteFrame(MSimOutput out, PetscInt step, PetscReal t, Vec X, Vec V)
{
  char base[64], line[512];

  PetscFunctionBeginUser;
  if (!out) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Output, X, 0, 0, 0));
  if (out->hdf5) {
    PetscCall(MSimHDF5SeriesWriteFrame(&out->h5, step, t, X, V));
    PetscCall(PetscLogEventEnd(MSIM_Output, X, 0, 0, 0));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(PetscSNPrintf(base, sizeof(base), "frame_%06" PetscInt_FMT, step));
  PetscCall(MSimOutputWriteVTU(out, base, t, X, V));
  /* series.pvd on rank 0, its outcome every rank's (MSimOutputWriteVTU says why) */
  PetscCall(MSimCallOnRankZero(out->sys->comm, [&]() -> PetscErrorCode {
    /* a mesh's springs are part 1 of the timestep: ParaView's .pvd reader makes the two a
       multiblock data set */
    PetscCall(PetscSNPrintf(line, sizeof(line), "    <DataSet timestep=\"%.9g\" part=\"0\" file=\"%s.vtu\"/>\n", (double)t, base));
    std::string entry = line;
    if (!out->springs.empty()) {
      PetscCall(PetscSNPrintf(line, sizeof(line), "    <DataSet timestep=\"%.9g\" part=\"1\" file=\"%s_springs.vtu\"/>\n", (double)t, base));
      entry += line;
    }
    PetscCall(MSimCollectionAppend(&out->pvd, entry));
    return PETSC_SUCCESS;
  }));
  PetscCall(PetscLogEventEnd(MSIM_Output, X, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOutputWriteExtra(MSimOutput out, const char name[], PetscReal t, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  if (!out) PetscFunctionReturn(PETSC_SUCCESS);
  if (out->hdf5) {
    PetscCall(MSimHDF5SeriesWriteExtra(&out->h5, name, t, X, V));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MSimOutputWriteVTU(out, name, t, X, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOutputDestroy(MSimOutput *out)
{
  PetscFunctionBeginUser;
  if (*out && (*out)->hdf5) PetscCall(MSimHDF5SeriesDestroy(&(*out)->h5));
  if (*out) PetscCall(MSimCallOnRankZero((*out)->sys->comm, [&]() { return MSimCollectionClose(&(*out)->pvd); })); /* its last rewrite */
  delete *out;
  *out = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
