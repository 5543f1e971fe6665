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

template <typename T>
static void AppendBlock(std::string &blob, const std::vector<T> &v)
{
  uint64_t n = v.size() * sizeof(T);
  blob.append(reinterpret_cast<const char *>(&n), sizeof(n));
  blob.append(reinterpret_cast<const char *>(v.data()), n);
}

PetscErrorCode MSimWriteVTU(const char path[], PetscInt nv, const PetscReal *x, PetscInt ncell, int cell_size, const PetscInt *cells, const char *fixed, const char name[], const PetscReal *field)
{
  /* VTK cell types by vertex count: VTK_LINE, VTK_TRIANGLE, VTK_TETRA */
  const uint8_t        vtk_type = cell_size == 2 ? 3 : cell_size == 3 ? 5 : 10;
  std::vector<double>  pts(x, x + 3 * nv);
  std::vector<int64_t> conn(cells, cells + (size_t)cell_size * ncell), offs(ncell);
  std::vector<uint8_t> types(ncell, vtk_type), fix(fixed, fixed + nv);
  std::string          blob;
  char                 head[2048];

  PetscFunctionBeginUser;
  PetscCheck(cell_size >= 2 && cell_size <= 4, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "no VTK cell of %d vertices", cell_size);
  for (PetscInt c = 0; c < ncell; c++) offs[c] = (int64_t)cell_size * (c + 1);
  size_t o[5];
  o[0] = blob.size(); AppendBlock(blob, pts);
  o[1] = blob.size(); AppendBlock(blob, conn);
  o[2] = blob.size(); AppendBlock(blob, offs);
  o[3] = blob.size(); AppendBlock(blob, types);
  o[4] = blob.size(); AppendBlock(blob, fix);
  char extra[256] = "";
  if (field) {
    snprintf(extra, sizeof(extra), "<DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"3\" format=\"appended\" offset=\"%zu\"/>", name, blob.size());
    AppendBlock(blob, std::vector<double>(field, field + 3 * nv));
  }
  snprintf(head, sizeof(head),
           "<?xml version=\"1.0\"?>\n"
           "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
           "<UnstructuredGrid>\n<Piece NumberOfPoints=\"%lld\" NumberOfCells=\"%lld\">\n"
           "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"%zu\"/></Points>\n"
           "<Cells>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"%zu\"/>\n"
           "<DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"%zu\"/>\n"
           "<DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"%zu\"/>\n</Cells>\n"
           "<PointData><DataArray type=\"UInt8\" Name=\"fixed\" format=\"appended\" offset=\"%zu\"/>%s</PointData>\n"
           "</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_",
           (long long)nv, (long long)ncell, o[0], o[1], o[2], o[3], o[4], extra);
  std::string file = std::string(head) + blob + "\n</AppendedData>\n</VTKFile>\n";
  PetscCall(MSimWriteFileAtomic(path, file.data(), file.size()));
  PetscFunctionReturn(PETSC_SUCCESS);
}
