/* Polygons, hexahedra and prisms into triangles and tets, by one rule on the vertices' ids (the
   file's order, which readers keep until every cell is split): a polygon is a fan from its corner
   of smallest id; a hexahedron or a prism is the cone from its vertex of smallest id, v, over the
   triangles of its faces that do not hold v, each quadrangle cut by the diagonal through its own
   corner of smallest id. The cone's triangles on the faces that do hold v fan from v, which is the
   smallest corner of those faces too: so every quadrangle, wherever it lies, is cut through its
   smallest corner, and two cells that share a face cut it alike (Dompierre, Labbe, Vallet and
   Camarero 1999, "How to subdivide pyramids, prisms and hexahedra into tetrahedra"). A convex
   cell's cone has positive volume, 6 tets for a hexahedron (3 faces of 2 triangles) and 3 for a
   prism (a triangle and a quadrangle). */
#include <msim/mesh.h>
#include <algorithm>

/* Appends the triangles of polygon ids[0..n) as a fan from its smallest corner, in the polygon's
   own cyclic order (so the triangles keep its orientation); a triangle as it is given (TetGen's
   output depends on its facets' vertex order, and the tetgen program is given the file's). */
static void Fan(const PetscInt *ids, int n, std::vector<PetscInt> &tri)
{
  const int s = n == 3 ? 0 : (int)(std::min_element(ids, ids + n) - ids);
  for (int k = 1; k + 1 < n; k++) {
    tri.push_back(ids[s]);
    tri.push_back(ids[(s + k) % n]);
    tri.push_back(ids[(s + k + 1) % n]);
  }
}

void MSimMeshAddPolygon(MSimMesh *m, const PetscInt *ids, PetscInt n, PetscInt line)
{
  const size_t before = m->cell.size();
  Fan(ids, (int)n, m->cell);
  for (size_t c = before; c < m->cell.size(); c += 3) m->cline.push_back(line);
}

/* A cell given by its faces, each a list of local corners in the order that makes its normal
   point outward (counter-clockwise seen from outside): the tets (apex, a, b, c) with (a, b, c) an
   outward triangle of a face without the apex have positive volume for a convex cell. */
static void Cone(MSimMesh *m, const PetscInt *ids, int nvert, const int (*faces)[5], int nfaces, PetscInt line)
{
  const int             apex = (int)(std::min_element(ids, ids + nvert) - ids);
  std::vector<PetscInt> tri;
  for (int f = 0; f < nfaces; f++) {
    const int n = faces[f][0];
    PetscInt  corner[4];
    bool      holds = false;
    for (int k = 0; k < n; k++) {
      holds     = holds || faces[f][1 + k] == apex;
      corner[k] = ids[faces[f][1 + k]];
    }
    if (holds) continue;
    tri.clear();
    Fan(corner, n, tri);
    for (size_t t = 0; t < tri.size(); t += 3) {
      m->cell.push_back(ids[apex]);
      m->cell.insert(m->cell.end(), tri.begin() + t, tri.begin() + t + 3);
      m->cline.push_back(line);
    }
  }
}

void MSimMeshAddHexahedron(MSimMesh *m, const PetscInt *ids, PetscInt line)
{
  /* Gmsh's hexahedron: 0 1 2 3 counter-clockwise seen from above, 4 5 6 7 above them */
  static const int faces[6][5] = {{4, 0, 3, 2, 1}, {4, 4, 5, 6, 7}, {4, 0, 1, 5, 4}, {4, 3, 7, 6, 2}, {4, 0, 4, 7, 3}, {4, 1, 2, 6, 5}};
  Cone(m, ids, 8, faces, 6, line);
}

void MSimMeshAddPrism(MSimMesh *m, const PetscInt *ids, PetscInt line)
{
  /* Gmsh's prism: 0 1 2 counter-clockwise seen from above, 3 4 5 above them */
  static const int faces[5][5] = {{3, 0, 2, 1, 0}, {3, 3, 4, 5, 0}, {4, 0, 1, 4, 3}, {4, 0, 3, 5, 2}, {4, 1, 2, 5, 4}};
  Cone(m, ids, 6, faces, 5, line);
}
