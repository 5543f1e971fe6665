/* Validation of a mesh before it becomes springs, and the geometry it needs. Thresholds are
   relative to the cell's own size, so they hold at any unit up to a bounding-box diagonal of
   DBL_MAX^(1/4): an edge is of zero length below 1e-12 of the mesh's bounding-box diagonal, a
   tet of zero volume below 1e-12 of its longest edge cubed, a triangle of zero area below 1e-12
   of its longest edge squared. */
#include <msim/mesh.h>
#include <msim/log.h>
#include <algorithm>
#include <cmath>

PetscReal MSimTetVolume(const PetscReal *a, const PetscReal *b, const PetscReal *c, const PetscReal *d)
{
  const PetscReal u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]}, w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
  return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])) / 6.0;
}

PetscReal MSimTriangleArea(const PetscReal *a, const PetscReal *b, const PetscReal *c)
{
  const PetscReal u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const PetscReal n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  return 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

static PetscReal Dist(const PetscReal *a, const PetscReal *b)
{
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

void MSimMeshScale(MSimMesh *m, PetscReal s)
{
  for (PetscReal &x : m->x) x *= s;
}

/* "FILE line L: the tet" or "FILE: tet N (counting from 1)" */
static std::string WhereCell(const MSimMesh *m, PetscInt c)
{
  char buf[64];
  if (m->cline.size() > (size_t)c && m->cline[c] > 0) {
    snprintf(buf, sizeof(buf), " line %lld: the %s", (long long)m->cline[c], m->cell_name);
    return m->file + buf;
  }
  snprintf(buf, sizeof(buf), ": %s %lld (counting from 1)", m->cell_name, (long long)c + 1);
  return m->file + buf;
}

static std::string WhereVertex(const MSimMesh *m, PetscInt v)
{
  char               buf[64];
  const std::string &f = m->vertex_file.empty() ? m->file : m->vertex_file;
  const long long    id = (long long)MSimMeshFileId(m, v);
  if (m->vline.size() > (size_t)v && m->vline[v] > 0) snprintf(buf, sizeof(buf), " line %lld: vertex %lld", (long long)m->vline[v], id);
  else snprintf(buf, sizeof(buf), ": vertex %lld (counting from 0)", id);
  return f + buf;
}

/* A cell listed twice (the same vertices, in any order: an OBJ's "f 1 2 3" repeated, an STL facet
   whose three corners weld to those of another) would count its area or volume twice in the
   lumped masses and in the stiffness of the springs on its edges, and a closed surface with one
   would be refused as open. Refused, naming the later cell and the first: the repeat found
   earliest in the file. Sorting the cells' vertex sets costs 20 bytes a tet, transient. */
static PetscErrorCode CheckRepeatedCells(const MSimMesh *m)
{
  struct Key {
    PetscInt v[4];
    PetscInt c;
  };
  const int        k = m->nper;
  std::vector<Key> key(m->ncell);
  PetscInt         first = -1, again = -1;

  PetscFunctionBeginUser;
  for (PetscInt c = 0; c < m->ncell; c++) {
    Key &q = key[c];
    q.v[3] = -1;
    for (int a = 0; a < k; a++) q.v[a] = m->cell[(size_t)k * c + a];
    std::sort(q.v, q.v + k);
    q.c = c;
  }
  std::sort(key.begin(), key.end(), [](const Key &a, const Key &b) { return std::lexicographical_compare(a.v, a.v + 4, b.v, b.v + 4) || (std::equal(a.v, a.v + 4, b.v) && a.c < b.c); });
  /* within a group of equal vertex sets the cells are in file order: its first two are the cell
     and its earliest repeat */
  for (size_t q = 0, r; q < key.size(); q = r) {
    for (r = q + 1; r < key.size() && std::equal(key[r].v, key[r].v + 4, key[q].v);) r++;
    if (r - q > 1 && (again < 0 || key[q + 1].c < again)) {
      first = key[q].c;
      again = key[q + 1].c;
    }
  }
  if (again >= 0) {
    char            was[64], ids[96];
    const PetscInt *id = &m->cell[(size_t)k * again];
    if (m->cline.size() > (size_t)first && m->cline[first] > 0) snprintf(was, sizeof(was), "line %lld", (long long)m->cline[first]);
    else snprintf(was, sizeof(was), "%s %lld", m->cell_name, (long long)first + 1);
    if (k == 4) snprintf(ids, sizeof(ids), "%lld %lld %lld %lld", (long long)MSimMeshFileId(m, id[0]), (long long)MSimMeshFileId(m, id[1]), (long long)MSimMeshFileId(m, id[2]), (long long)MSimMeshFileId(m, id[3]));
    else snprintf(ids, sizeof(ids), "%lld %lld %lld", (long long)MSimMeshFileId(m, id[0]), (long long)MSimMeshFileId(m, id[1]), (long long)MSimMeshFileId(m, id[2]));
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s repeats %s: the same vertices %s (its %s would count twice in the masses and springs)", WhereCell(m, again).c_str(), was, ids, k == 4 ? "volume" : "area");
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshCheck(const MSimMesh *m)
{
  const int         k = m->nper;
  PetscReal         lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL};

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_MeshCheck, 0, 0, 0, 0));
  PetscCheck(m->nv > 0 && m->ncell > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no %ss", m->file.c_str(), m->cell_name);
  for (PetscInt v = 0; v < m->nv; v++)
    for (int c = 0; c < 3; c++) {
      PetscCheck(std::isfinite(m->x[3 * v + c]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: a coordinate is not finite", WhereVertex(m, v).c_str());
      lo[c] = std::min(lo[c], m->x[3 * v + c]);
      hi[c] = std::max(hi[c], m->x[3 * v + c]);
    }
  const PetscReal diam = Dist(lo, hi);
  /* a triangle's area takes the fourth power of its edges: past DBL_MAX^(1/4) (1e77) the lengths
     and areas overflow, and an edge of coordinates 1e300 was refused as "of zero length" */
  PetscCheck(diam <= std::pow(PETSC_MAX_REAL, 0.25), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: the coordinates span [%g, %g] x [%g, %g] x [%g, %g], a diagonal beyond %g (DBL_MAX^(1/4)), where edge lengths and areas overflow", m->file.c_str(), (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1], (double)lo[2], (double)hi[2], (double)std::pow(PETSC_MAX_REAL, 0.25));
  for (PetscInt c = 0; c < m->ncell; c++) {
    const PetscInt *id = &m->cell[(size_t)k * c];
    PetscReal       lmax = 0;
    for (int a = 0; a < k; a++) {
      PetscCheck(id[a] >= 0 && id[a] < m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s names vertex %lld, outside [0, %lld]", WhereCell(m, c).c_str(), (long long)id[a], (long long)m->nv - 1);
      for (int b = 0; b < a; b++) {
        PetscCheck(id[a] != id[b], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s uses vertex %lld twice", WhereCell(m, c).c_str(), (long long)MSimMeshFileId(m, id[a]));
        const PetscReal l = Dist(&m->x[3 * id[a]], &m->x[3 * id[b]]);
        PetscCheck(l > 1e-12 * diam, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s has an edge of zero length: vertices %lld and %lld are at the same place (a spring of zero length)", WhereCell(m, c).c_str(), (long long)MSimMeshFileId(m, id[b]), (long long)MSimMeshFileId(m, id[a]));
        lmax = std::max(lmax, l);
      }
    }
    if (k == 4) {
      const PetscReal vol = MSimTetVolume(&m->x[3 * id[0]], &m->x[3 * id[1]], &m->x[3 * id[2]], &m->x[3 * id[3]]);
      PetscCheck(std::abs(vol) > 1e-12 * lmax * lmax * lmax, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s has zero volume (%.3e): its four vertices lie in one plane", WhereCell(m, c).c_str(), (double)vol);
      PetscCheck(vol > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s is inverted: negative volume %.6e (a tet a b c d needs det(b-a, c-a, d-a) > 0)", WhereCell(m, c).c_str(), (double)vol);
    } else {
      const PetscReal area = MSimTriangleArea(&m->x[3 * id[0]], &m->x[3 * id[1]], &m->x[3 * id[2]]);
      PetscCheck(area > 1e-12 * lmax * lmax, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s has zero area (%.3e): its three vertices lie on one line", WhereCell(m, c).c_str(), (double)area);
    }
  }
  PetscCall(CheckRepeatedCells(m));
  PetscCall(PetscLogEventEnd(MSIM_MeshCheck, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
