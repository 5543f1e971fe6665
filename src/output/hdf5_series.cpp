/* The series at scale: every rank writes its part at once through PETSc's HDF5 viewer (MPI-IO),
   nothing is gathered. DIR/mesh.h5 holds the cells ("/cells", n x k input vertex ids), a mesh's
   springs ("/springs", pairs of input ids), the fixed flags ("/fixed") and the file ids
   ("/file_id"), written once with the first frame (cells and springs in the scene's order at any rank count, each rank
   a block of it: MSimSceneDrawnCells, so a restart at another rank count rewrites mesh.h5 as it
   was under the frames written before); each frame is DIR/frame_NNNNNN.h5 with "/positions" and
   "/velocity" (nv x 3, input order, from the natural Vec), "/strain" (one per spring, in the order
   of the springs drawn), for tets "/volume_ratio" (one per cell) and with obstacles
   "/contact_force" (nv x 3, msim/contact_force.h). DIR/series.xdmf lists them
   for ParaView (XDMF 3, a temporal collection; a mesh's frame is a spatial collection of two
   grids, its cells and its springs, on the same points). Each rank computes the fields of its
   own cells and springs from the positions of the vertices they touch. Each file is written
   under a temporary name and renamed once closed, and each frame adds its grid to series.xdmf in
   place (collection.cpp): a killed run leaves no truncated file and a collection of exactly the
   frames on disk. */
#include "hdf5_series.h"
#include "frame_fields.h"
#include <msim/contact_force.h>
#include <msim/private/systemimpl.h>
#include <msim/destroy.h>
#include <msim/errors.h>
#include <petscviewerhdf5.h>
#include <algorithm>
#include <cstdio>

/* collective: PETSc's HDF5 viewer on PATH.tmp, then rank 0 renames it to PATH */
static PetscErrorCode OpenTemporary(MPI_Comm comm, const std::string &path, PetscViewer *v)
{
  PetscFunctionBeginUser;
  PetscCall(PetscViewerHDF5Open(comm, (path + ".tmp").c_str(), FILE_MODE_WRITE, v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode CloseAndRename(MPI_Comm comm, const std::string &path, PetscViewer *v)
{
  PetscMPIInt rank;
  int         ok = 1;

  PetscFunctionBeginUser;
  PetscCall(PetscViewerDestroy(v)); /* collective: the file is complete here */
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) ok = rename((path + ".tmp").c_str(), path.c_str()) == 0;
  PetscCallMPI(MPI_Bcast(&ok, 1, MPI_INT, 0, comm));
  PetscCheck(ok, comm, PETSC_ERR_FILE_WRITE, "cannot rename %s.tmp to %s", path.c_str(), path.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* an IS of this rank's part of a distributed dataset, viewed under NAME */
static PetscErrorCode ViewInts(MPI_Comm comm, PetscViewer v, const char name[], const std::vector<PetscInt> &ints, PetscInt bs)
{
  IS is;

  PetscFunctionBeginUser;
  PetscCall(ISCreateGeneral(comm, (PetscInt)ints.size(), ints.data(), PETSC_USE_POINTER, &is));
  PetscCall(ISSetBlockSize(is, bs));
  PetscCall(PetscObjectSetName((PetscObject)is, name));
  PetscCall(ISView(is, v));
  PetscCall(ISDestroy(&is));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* a Vec laid out like n local cells, named NAME */
static PetscErrorCode CellVec(MPI_Comm comm, size_t n, const char name[], Vec *v)
{
  PetscFunctionBeginUser;
  PetscCall(VecCreateMPI(comm, (PetscInt)n, PETSC_DETERMINE, v));
  PetscCall(PetscObjectSetName((PetscObject)*v, name));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* DIR/mesh.h5, with the first frame: a restart refused before it leaves the directory as it was */
static PetscErrorCode WriteMesh(MSimHDF5Series *h)
{
  const MSimSystem      sys = h->sys;
  PetscViewer           v;
  std::vector<PetscInt> flags(sys->nat_fixed_flag.begin(), sys->nat_fixed_flag.end()), ids;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemBlockFileIds(sys, ids));
  PetscCall(OpenTemporary(sys->comm, h->dir + "/mesh.h5", &v));
  PetscCall(ViewInts(sys->comm, v, "cells", sys->out_cells, sys->out_cell_size));
  if (sys->cell_size) PetscCall(ViewInts(sys->comm, v, "springs", sys->out_springs, 2));
  PetscCall(ViewInts(sys->comm, v, "fixed", flags, 1));
  PetscCall(ViewInts(sys->comm, v, "file_id", ids, 1));
  PetscCall(CloseAndRename(sys->comm, h->dir + "/mesh.h5", &v));
  h->mesh_written = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimHDF5SeriesSetUp(MSimHDF5Series *h, MSimSystem sys, const char dir[])
{
  PetscFunctionBeginUser;
  h->sys        = sys;
  h->dir        = dir;
  h->xdmf.path  = h->dir + "/series.xdmf";
  h->xdmf.head  = "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n  <Grid Name=\"msim\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  h->xdmf.close = "    \n  </Grid>\n  </Domain>\n</Xdmf>\n";
  PetscCall(MSimContactHasObstacles(sys, &h->contact));
  PetscInt n[2] = {(PetscInt)(sys->out_cells.size() / sys->out_cell_size), sys->cell_size ? (PetscInt)(sys->out_springs.size() / 2) : 0};
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, n, 2, MPIU_INT, MPI_SUM, sys->comm));
  h->ncells   = n[0];
  h->nsprings = n[1];

  /* the vertices this rank's cells and springs touch, and their ends as indices among them */
  const std::vector<PetscInt> &lines = sys->cell_size ? sys->out_springs : sys->out_cells;
  std::vector<PetscInt>        touched(lines);
  if (sys->out_cell_size == 4) touched.insert(touched.end(), sys->out_cells.begin(), sys->out_cells.end());
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  auto local = [&](const std::vector<PetscInt> &ends, std::vector<PetscInt> &loc) {
    loc.resize(ends.size());
    for (size_t q = 0; q < ends.size(); q++) loc[q] = (PetscInt)(std::lower_bound(touched.begin(), touched.end(), ends[q]) - touched.begin());
  };
  if (sys->out_cell_size == 4) local(sys->out_cells, h->cell_ends);
  local(lines, h->spring_ends);
  {
    IS from;
    PetscCall(MSimSystemNaturalSetUp(sys));
    PetscCall(VecCreateSeq(PETSC_COMM_SELF, 3 * (PetscInt)touched.size(), &h->xcell));
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, (PetscInt)touched.size(), touched.data(), PETSC_COPY_VALUES, &from));
    PetscCall(VecScatterCreate(sys->natural, from, h->xcell, NULL, &h->fetch));
    PetscCall(ISDestroy(&from));
  }
  PetscCall(CellVec(sys->comm, sys->out_spring_L.size(), "strain", &h->strain));
  if (sys->out_cell_size == 4) PetscCall(CellVec(sys->comm, sys->out_cell_V0.size(), "volume_ratio", &h->ratio));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimHDF5SeriesDestroy(MSimHDF5Series *h)
{
  PetscFunctionBeginUser;
  PetscCall(MSimDestroy(&h->fetch, &h->xcell, &h->strain, &h->ratio));
  if (h->sys) PetscCall(MSimCallOnRankZero(h->sys->comm, [&]() { return MSimCollectionClose(&h->xdmf); })); /* its last rewrite, rank 0's (none before MSimHDF5SeriesSetUp) */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* an XDMF Attribute: a dataset of n values (n x 3 for a vector) centred on nodes or cells */
static std::string AttributeXML(const char indent[], const char name[], bool vector, const char center[], PetscInt n, bool integer, const std::string &item)
{
  char buf[1024];
  snprintf(buf, sizeof(buf),
           "%s<Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"%s\">\n"
           "%s  <DataItem Dimensions=\"%lld%s\" NumberType=\"%s\" Precision=\"%d\" Format=\"HDF\">%s</DataItem>\n"
           "%s</Attribute>\n",
           indent, name, vector ? "Vector" : "Scalar", center, indent, (long long)n, vector ? " 3" : "", integer ? "Int" : "Float", integer ? (int)sizeof(PetscInt) : 8, item.c_str(), indent);
  return buf;
}

/* one uniform grid on the frame's points: cells of k vertices from mesh.h5:/TOPOLOGY, the point
   fields and the cell field CELLFIELD (none if NULL) */
static std::string UniformXML(const MSimHDF5Series *h, const char indent[], const char name[], const char time[], const char topology[], PetscInt ncells, int k, const char cellfield[], const std::string &file)
{
  const MSimSystem sys  = h->sys;
  const char      *topo = k == 4 ? "Tetrahedron" : k == 3 ? "Triangle" : "Polyline";
  const std::string in  = std::string(indent) + "  ";
  char             buf[2048];
  snprintf(buf, sizeof(buf),
           "%s<Grid Name=\"%s\" GridType=\"Uniform\">\n%s"
           "%s<Topology TopologyType=\"%s\" NumberOfElements=\"%lld\" NodesPerElement=\"%d\">\n"
           "%s  <DataItem Dimensions=\"%lld %d\" NumberType=\"Int\" Precision=\"%d\" Format=\"HDF\">mesh.h5:/%s</DataItem>\n"
           "%s</Topology>\n"
           "%s<Geometry GeometryType=\"XYZ\">\n"
           "%s  <DataItem Dimensions=\"%lld 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s:/positions</DataItem>\n"
           "%s</Geometry>\n",
           indent, name, time, in.c_str(), topo, (long long)ncells, k, in.c_str(), (long long)ncells, k, (int)sizeof(PetscInt), topology, in.c_str(), in.c_str(), in.c_str(), (long long)sys->nv, file.c_str(), in.c_str());
  std::string grid = buf;
  /* "fixed" first: the readers in runs/tools take the first attribute for it */
  grid += AttributeXML(in.c_str(), "fixed", false, "Node", sys->nv, true, "mesh.h5:/fixed");
  grid += AttributeXML(in.c_str(), "file_id", false, "Node", sys->nv, true, "mesh.h5:/file_id");
  grid += AttributeXML(in.c_str(), "velocity", true, "Node", sys->nv, false, file + ":/velocity");
  if (h->contact) grid += AttributeXML(in.c_str(), "contact_force", true, "Node", sys->nv, false, file + ":/contact_force");
  if (cellfield) grid += AttributeXML(in.c_str(), cellfield, false, "Cell", ncells, false, file + ":/" + cellfield);
  return grid + indent + "</Grid>\n";
}

/* the XDMF grid of one frame: one uniform grid, or for a mesh a spatial collection of its cells
   and its springs */
static std::string GridXML(const MSimHDF5Series *h, const char name[], PetscReal t, const std::string &file)
{
  const MSimSystem sys = h->sys;
  const int        k   = sys->out_cell_size;
  char             time[128], head[256];
  snprintf(time, sizeof(time), "      <Time Value=\"%.9g\"/>\n", (double)t);
  if (!sys->cell_size) return UniformXML(h, "    ", name, time, "cells", h->ncells, 2, "strain", file);
  snprintf(head, sizeof(head), "    <Grid Name=\"%s\" GridType=\"Collection\" CollectionType=\"Spatial\">\n%s", name, time);
  return head + UniformXML(h, "      ", "cells", "", "cells", h->ncells, k, k == 4 ? "volume_ratio" : NULL, file) + UniformXML(h, "      ", "springs", "", "springs", h->nsprings, 2, "strain", file) + "    </Grid>\n";
}

/* NAME.xdmf: one grid outside the series */
static std::string Document(const std::string &grid)
{
  return "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n" + grid + "  </Domain>\n</Xdmf>\n";
}

/* the frame's fields in input order to DIR/NAME.h5 */
static PetscErrorCode WriteFields(MSimHDF5Series *h, const std::string &name, PetscReal t, Vec X, Vec V)
{
  const MSimSystem   sys = h->sys;
  PetscViewer        v;
  const PetscScalar *x;
  PetscScalar       *f;

  PetscFunctionBeginUser;
  if (!h->mesh_written) PetscCall(WriteMesh(h));
  PetscCall(OpenTemporary(sys->comm, h->dir + "/" + name, &v));
  PetscCall(MSimSystemNaturalPositions(sys, t, X));
  PetscCall(VecView(sys->natural, v));
  /* the cells' own fields, from the positions of the vertices they touch */
  PetscCall(VecScatterBegin(h->fetch, sys->natural, h->xcell, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(h->fetch, sys->natural, h->xcell, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(h->xcell, &x));
  PetscCall(VecGetArray(h->strain, &f));
  MSimFrameStrain(sys->out_spring_L.size(), h->spring_ends.data(), sys->out_spring_L.data(), x, f);
  PetscCall(VecRestoreArray(h->strain, &f));
  if (h->ratio) {
    PetscCall(VecGetArray(h->ratio, &f));
    MSimFrameVolumeRatio(sys->out_cell_V0.size(), h->cell_ends.data(), sys->out_cell_V0.data(), x, f);
    PetscCall(VecRestoreArray(h->ratio, &f));
  }
  PetscCall(VecRestoreArrayRead(h->xcell, &x));
  PetscCall(VecView(h->strain, v));
  if (h->ratio) PetscCall(VecView(h->ratio, v));
  /* the velocities through the same natural Vec, under their own name */
  PetscCall(MSimSystemNaturalVelocities(sys, V));
  PetscCall(PetscObjectSetName((PetscObject)sys->natural, "velocity"));
  PetscCall(VecView(sys->natural, v));
  if (h->contact) { /* the obstacles' force on each vertex (zero at the fixed ones), likewise */
    Vec F;
    PetscCall(MSimSystemCreateVec(sys, &F));
    PetscCall(MSimContactForce(sys, t, X, F, NULL));
    PetscCall(MSimSystemNaturalVector(sys, F));
    PetscCall(VecDestroy(&F));
    PetscCall(PetscObjectSetName((PetscObject)sys->natural, "contact_force"));
    PetscCall(VecView(sys->natural, v));
  }
  PetscCall(PetscObjectSetName((PetscObject)sys->natural, "positions"));
  PetscCall(CloseAndRename(sys->comm, h->dir + "/" + name, &v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimHDF5SeriesWriteFrame(MSimHDF5Series *h, PetscInt step, PetscReal t, Vec X, Vec V)
{
  char name[64];

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(name, sizeof(name), "frame_%06" PetscInt_FMT, step));
  const std::string file = std::string(name) + ".h5";
  PetscCall(WriteFields(h, file, t, X, V));
  /* series.xdmf on rank 0, its outcome every rank's: a failed write is one error on all ranks
     (the others went on into the next step's collectives and waited there for ever) */
  PetscCall(MSimCallOnRankZero(h->sys->comm, [&]() { return MSimCollectionAppend(&h->xdmf, GridXML(h, name, t, file)); }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimHDF5SeriesWriteExtra(MSimHDF5Series *h, const char name[], PetscReal t, Vec X, Vec V)
{
  const std::string file = std::string(name) + ".h5";

  PetscFunctionBeginUser;
  PetscCall(WriteFields(h, file, t, X, V));
  PetscCall(MSimCallOnRankZero(h->sys->comm, [&]() {
    const std::string doc = Document(GridXML(h, name, t, file));
    return MSimWriteFileAtomic((h->dir + "/" + name + ".xdmf").c_str(), doc.data(), doc.size());
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}
