/* The series at scale: every rank writes its part at once through PETSc's HDF5 viewer (MPI-IO),
   nothing is gathered. DIR/mesh.h5 holds the cells ("/cells", n x k input vertex ids) and the
   fixed flags ("/fixed"), written once; each frame is DIR/frame_NNNNNN.h5 with "/positions" (nv x
   3, input order, from the natural Vec); DIR/series.xdmf lists them for ParaView (XDMF 3, a
   temporal collection). Each file is written under a temporary name and renamed once closed, and
   series.xdmf is rewritten whole after each frame: a killed run leaves no truncated file and a
   collection of exactly the frames on disk. */
#include "hdf5_series.h"
#include <petscviewerhdf5.h>
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

PetscErrorCode MSimHDF5SeriesSetUp(MSimHDF5Series *h, MSimSystem sys, const char dir[])
{
  PetscViewer    v;
  IS             cells, fixed;
  std::vector<PetscInt> flags(sys->nat_fixed_flag.begin(), sys->nat_fixed_flag.end());

  PetscFunctionBeginUser;
  h->sys = sys;
  h->dir = dir;
  PetscCall(ISCreateGeneral(sys->comm, (PetscInt)sys->out_cells.size(), sys->out_cells.data(), PETSC_USE_POINTER, &cells));
  PetscCall(ISSetBlockSize(cells, sys->out_cell_size));
  PetscCall(PetscObjectSetName((PetscObject)cells, "cells"));
  PetscCall(ISCreateGeneral(sys->comm, (PetscInt)flags.size(), flags.data(), PETSC_USE_POINTER, &fixed));
  PetscCall(PetscObjectSetName((PetscObject)fixed, "fixed"));
  PetscCall(OpenTemporary(sys->comm, h->dir + "/mesh.h5", &v));
  PetscCall(ISView(cells, v));
  PetscCall(ISView(fixed, v));
  PetscCall(CloseAndRename(sys->comm, h->dir + "/mesh.h5", &v));
  PetscCall(ISDestroy(&cells));
  PetscCall(ISDestroy(&fixed));
  h->ncells = (PetscInt)(sys->out_cells.size() / sys->out_cell_size);
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &h->ncells, 1, MPIU_INT, MPI_SUM, sys->comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the XDMF grid of one frame */
static std::string GridXML(const MSimHDF5Series *h, const char name[], PetscReal t, const std::string &file)
{
  const MSimSystem sys = h->sys;
  const char      *topo = sys->out_cell_size == 4 ? "Tetrahedron" : sys->out_cell_size == 3 ? "Triangle" : "Polyline";
  char             buf[2048];
  snprintf(buf, sizeof(buf),
           "    <Grid Name=\"%s\" GridType=\"Uniform\">\n"
           "      <Time Value=\"%.9g\"/>\n"
           "      <Topology TopologyType=\"%s\" NumberOfElements=\"%lld\" NodesPerElement=\"%d\">\n"
           "        <DataItem Dimensions=\"%lld %d\" NumberType=\"Int\" Precision=\"%d\" Format=\"HDF\">mesh.h5:/cells</DataItem>\n"
           "      </Topology>\n"
           "      <Geometry GeometryType=\"XYZ\">\n"
           "        <DataItem Dimensions=\"%lld 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s:/positions</DataItem>\n"
           "      </Geometry>\n"
           "      <Attribute Name=\"fixed\" AttributeType=\"Scalar\" Center=\"Node\">\n"
           "        <DataItem Dimensions=\"%lld 1\" NumberType=\"Int\" Precision=\"%d\" Format=\"HDF\">mesh.h5:/fixed</DataItem>\n"
           "      </Attribute>\n"
           "    </Grid>\n",
           name, (double)t, topo, (long long)h->ncells, sys->out_cell_size, (long long)h->ncells, sys->out_cell_size, (int)sizeof(PetscInt), (long long)sys->nv, file.c_str(), (long long)sys->nv, (int)sizeof(PetscInt));
  return buf;
}

static std::string Document(const std::string &grids, bool temporal)
{
  return std::string("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n") + (temporal ? "  <Grid Name=\"msim\" GridType=\"Collection\" CollectionType=\"Temporal\">\n" : "") + grids + (temporal ? "  </Grid>\n" : "") + "  </Domain>\n</Xdmf>\n";
}

/* positions in input order to DIR/NAME.h5 */
static PetscErrorCode WritePositions(MSimHDF5Series *h, const std::string &name, PetscReal t, Vec X)
{
  PetscViewer v;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemNaturalPositions(h->sys, t, X));
  PetscCall(OpenTemporary(h->sys->comm, h->dir + "/" + name, &v));
  PetscCall(VecView(h->sys->natural, v));
  PetscCall(CloseAndRename(h->sys->comm, h->dir + "/" + name, &v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimHDF5SeriesWriteFrame(MSimHDF5Series *h, PetscInt step, PetscReal t, Vec X)
{
  char file[64];

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(file, sizeof(file), "frame_%06" PetscInt_FMT ".h5", step));
  PetscCall(WritePositions(h, file, t, X));
  h->grids += GridXML(h, file, t, file);
  if (h->sys->rank == 0) {
    const std::string doc = Document(h->grids, true);
    PetscCall(MSimWriteFileAtomic((h->dir + "/series.xdmf").c_str(), doc.data(), doc.size()));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimHDF5SeriesWriteExtra(MSimHDF5Series *h, const char name[], PetscReal t, Vec X)
{
  const std::string file = std::string(name) + ".h5";

  PetscFunctionBeginUser;
  PetscCall(WritePositions(h, file, t, X));
  if (h->sys->rank == 0) {
    const std::string doc = Document(GridXML(h, name, t, file), false);
    PetscCall(MSimWriteFileAtomic((h->dir + "/" + name + ".xdmf").c_str(), doc.data(), doc.size()));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
