/* VTK XML unstructured grid (.vtu), raw appended binary, UInt64 headers. FACTS: PetscViewerVTK
   writes nothing for a Vec without a DM, so msim writes the format itself. */
#include <msim/output.h>
#include <string>
#include <vector>
#include <cstdint>
#include <cstring>

PetscErrorCode MSimWriteFileAtomic(const char path[], const void *data, size_t n)
{
  std::string tmp = std::string(path) + ".tmp";
  FILE       *fp;

  PetscFunctionBeginUser;
  fp = fopen(tmp.c_str(), "wb");
  PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", tmp.c_str());
  size_t w = fwrite(data, 1, n, fp);
  int    c = fclose(fp);
  PetscCheck(w == n && c == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "write to %s failed (disk full?)", tmp.c_str());
  PetscCheck(rename(tmp.c_str(), path) == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "cannot rename %s to %s", tmp.c_str(), path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static void AppendBlock(std::string &blob, const void *data, size_t n)
{
  const uint64_t len = n;
  blob.append(reinterpret_cast<const char *>(&len), sizeof(len));
  blob.append(reinterpret_cast<const char *>(data), n);
}

template <typename T>
static void AppendBlock(std::string &blob, const std::vector<T> &v)
{
  AppendBlock(blob, v.data(), v.size() * sizeof(T));
}

/* the DataArray elements of one group (point or cell data), their values appended to blob */
static PetscErrorCode AppendArrays(std::string &xml, std::string &blob, size_t n, int count, const MSimVTUArray arrays[])
{
  PetscFunctionBeginUser;
  for (int a = 0; a < count; a++) {
    const MSimVTUArray &A    = arrays[a];
    const size_t        size = !strcmp(A.type, "Float64") || !strcmp(A.type, "Int64") ? 8 : !strcmp(A.type, "UInt8") ? 1 : 0;
    char                buf[256];
    PetscCheck(size, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "no VTK array type %s", A.type);
    /* attributes in the order msim's readers (runs/tools/vtu.py) expect */
    if (A.ncomp > 1) snprintf(buf, sizeof(buf), "<DataArray type=\"%s\" Name=\"%s\" NumberOfComponents=\"%d\" format=\"appended\" offset=\"%zu\"/>", A.type, A.name, A.ncomp, blob.size());
    else snprintf(buf, sizeof(buf), "<DataArray type=\"%s\" Name=\"%s\" format=\"appended\" offset=\"%zu\"/>", A.type, A.name, blob.size());
    xml += buf;
    AppendBlock(blob, A.data, n * A.ncomp * size);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimWriteVTUPiece(const char path[], PetscInt nv, const PetscReal *x, PetscInt ncell, int cell_size, const PetscInt *cells, int npoint, const MSimVTUArray point[], int ncelldata, const MSimVTUArray cell[])
{
  /* VTK cell types by vertex count: VTK_LINE, VTK_TRIANGLE, VTK_TETRA */
  const uint8_t        vtk_type = cell_size == 2 ? 3 : cell_size == 3 ? 5 : 10;
  std::vector<int64_t> conn(cells, cells + (size_t)cell_size * ncell), offs(ncell);
  std::vector<uint8_t> types(ncell, vtk_type);
  std::string          blob, pdata, cdata;
  char                 head[1024];

  PetscFunctionBeginUser;
  PetscCheck(cell_size >= 2 && cell_size <= 4, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "no VTK cell of %d vertices", cell_size);
  for (PetscInt c = 0; c < ncell; c++) offs[c] = (int64_t)cell_size * (c + 1);
  size_t o[4];
  o[0] = blob.size(); AppendBlock(blob, x, 3 * (size_t)nv * sizeof(PetscReal));
  o[1] = blob.size(); AppendBlock(blob, conn);
  o[2] = blob.size(); AppendBlock(blob, offs);
  o[3] = blob.size(); AppendBlock(blob, types);
  PetscCall(AppendArrays(pdata, blob, nv, npoint, point));
  PetscCall(AppendArrays(cdata, blob, ncell, ncelldata, cell));
  snprintf(head, sizeof(head),
           "<?xml version=\"1.0\"?>\n"
           "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
           "<UnstructuredGrid>\n<Piece NumberOfPoints=\"%lld\" NumberOfCells=\"%lld\">\n"
           "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"%zu\"/></Points>\n"
           "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"%zu\"/>\n"
           "<DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"%zu\"/>\n"
           "<DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"%zu\"/>\n</Cells>\n",
           (long long)nv, (long long)ncell, o[0], o[1], o[2], o[3]);
  std::string file = std::string(head) + "<PointData>" + pdata + "</PointData>\n" + (ncelldata ? "<CellData>" + cdata + "</CellData>\n" : "") + "</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_" + blob + "\n</AppendedData>\n</VTKFile>\n";
  PetscCall(MSimWriteFileAtomic(path, file.data(), file.size()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimWriteVTU(const char path[], PetscInt nv, const PetscReal *x, PetscInt ncell, int cell_size, const PetscInt *cells, const char *fixed, const char name[], const PetscReal *field)
{
  MSimVTUArray point[2] = {
    {"fixed", "UInt8",   1, fixed},
    {name,    "Float64", 3, field}
  };

  PetscFunctionBeginUser;
  PetscCall(MSimWriteVTUPiece(path, nv, x, ncell, cell_size, cells, field ? 2 : 1, point, 0, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}
