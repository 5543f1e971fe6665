/* Mesh layer: files in, validated simplices out. A mesh is read on rank 0 alone (MSimMeshRead),
   checked (MSimMeshCheck), and turned into springs by the scene layer. Every fault of a file is one
   error line naming the file, the line (or element) and the fault; the other ranks learn it by
   MSimCallOnRankZero (msim/errors.h), so it prints once whatever the rank count.

   Conventions: a vertex's id is its place in the file, from 0 (Medit's and OBJ's 1-based ids and
   Gmsh's tags are turned into that), for every format: the ids users type. Readers keep every
   vertex of the file; MSimMeshDropUnused (run by MSimMeshReadFile) then drops those no cell uses,
   with one note, and records each kept vertex's file id, so the mesh's own indices stay compact
   while the file's ids stay what users name. A tet (a, b, c, d) has positive volume
   det(b - a, c - a, d - a) / 6 > 0 (TetGen's and Gmsh's convention; PETSc's DMPlex stores tets the
   other way round and msim turns them back); triangles may have either orientation.
   Cells other than tets and triangles are split by one rule everywhere: a polygon (a quadrangle of
   OBJ, OFF, Gmsh or Medit) is a fan from its corner of smallest file id; a hexahedron (6 tets) or a
   prism (3 tets) is the cone from its vertex of smallest file id over the triangles of the faces
   that do not hold that vertex, each quadrangle cut through its corner of smallest id. Every
   quadrangle is then cut through its own smallest corner whichever cell holds it, so neighbouring
   cells share their faces' triangles (a conforming mesh). */
#pragma once
#include <msim/petsc_compat.h>
#include <string>
#include <vector>

typedef struct _n_MSimMesh {
  std::string            file;       /* for messages about cells */
  std::string            vertex_file; /* for messages about vertices, where it differs (.node) */
  PetscInt               nv = 0;
  std::vector<PetscReal> x;          /* 3 nv coordinates */
  int                    nper = 0;   /* vertices per cell: 3 triangles, 4 tets */
  PetscInt               ncell = 0;
  std::vector<PetscInt>  cell;       /* nper ncell vertex ids */
  /* where each vertex and cell came from, for messages: a line of the file (> 0), or 0 where
     the reader has no lines (binary STL and Gmsh, TetGen's output): then the
     message names the index */
  std::vector<PetscInt>  vline, cline;
  const char            *cell_name = "cell"; /* "face", "tet", "element", "facet" */
  const char            *vertex_name = "vertices"; /* "nodes" (Gmsh), "points" (TetGen), in notes */
  /* each vertex's id in the file (its place there, from 0) once MSimMeshDropUnused dropped some;
     empty where every vertex is its own id. nv_file: the ids in use, the file's vertices (dropped
     ones included) and then those msim adds (TetGen's new points); where file_id is empty, nv. */
  std::vector<PetscInt>  file_id;
  PetscInt               nv_file = 0;
  /* what the reader tolerated (vertices dropped, statements skipped): one line each, printed by
     MSimMeshPrintNotes once the mesh passed its checks, so a refused file prints its error alone */
  std::vector<std::string> notes;
} MSimMesh;

/* Readers (rank 0). Each fills x, cells and lines with every vertex of the file; faults are
   errors on PETSC_COMM_SELF whose message starts with "FILE line N: " or "FILE: ". Polygons,
   hexahedra and prisms are split into triangles and tets by the rule above. */
typedef PetscErrorCode (*MSimMeshReader)(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadOFF(const char file[], MSimMesh *m);
/* OBJ: statements msim has no use for (vt, vn, g, usemtl, t, ...) are skipped with one note */
PetscErrorCode MSimMeshReadOBJ(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadSTL(const char file[], MSimMesh *m); /* ASCII or binary, vertices merged in order of first appearance */
/* TetGen .node/.ele pair; file names either (or their common stem). 0- or 1-based, attributes and
   boundary markers allowed. */
PetscErrorCode MSimMeshReadTetGen(const char file[], MSimMesh *m);
/* Gmsh .msh (2.2 and 4.1; ASCII or binary): the cells of the highest dimension, tets, hexahedra
   and prisms (dim 3) or triangles and quadrangles (dim 2), by msim's own readers, one per
   encoding (MSimMeshReadGmsh picks by the file's $MeshFormat line). Ids: the nodes' order in
   $Nodes, whatever their tags. Pyramids and higher-order elements are refused by name. */
PetscErrorCode MSimMeshReadGmsh(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadGmshASCII(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadGmshBinary(const char file[], MSimMesh *m);
/* Medit .mesh (ASCII): Vertices, Tetrahedra, Triangles and Quadrilaterals (1-based ids, a
   reference number each); Edges, Corners, Ridges, Normals and the other sections are skipped. */
PetscErrorCode MSimMeshReadMedit(const char file[], MSimMesh *m);

/* The readers by name, each with its file extensions (comma-separated, lower case): off, obj,
   stl, tetgen (node, ele), gmsh (msh), medit (mesh). -msim_mesh_format picks one by name, -help
   lists them; otherwise the file's extension does. */
PetscErrorCode MSimMeshReaderRegister(const char name[], const char extensions[], MSimMeshReader read);
PetscErrorCode MSimMeshReaderList(PetscFunctionList *list);
PetscErrorCode MSimMeshReaderFinalize(void);
/* Reads a file by the reader `format` (NULL, "" or "auto": by extension; a stem with a .node beside
   it: TetGen), drops the vertices no cell uses (MSimMeshDropUnused). want: 3 (a surface) or 4
   (tets); a surface given where tets are wanted comes back as a surface (the caller
   tetrahedralizes it). */
PetscErrorCode MSimMeshReadFileAs(const char file[], const char format[], int want, MSimMesh *m);
PetscErrorCode MSimMeshReadFile(const char file[], int want, MSimMesh *m);
/* Drops the vertices no cell uses, keeping the order of the rest, records each kept vertex's
   file id (file_id, nv_file) and adds a note saying how many were dropped. A cell naming a vertex
   out of range is an error (MSimMeshCheck's). */
PetscErrorCode MSimMeshDropUnused(MSimMesh *m);
/* The notes a mesh collected, as "msim: note: ..." lines on stderr (rank 0, which reads files) */
PetscErrorCode MSimMeshPrintNotes(const MSimMesh *m);
/* Vertex v's id in the file */
static inline PetscInt MSimMeshFileId(const MSimMesh *m, PetscInt v)
{
  return m->file_id.empty() ? v : m->file_id[v];
}

/* Validation (rank 0): every index in range, no repeated vertex in a cell, no edge of zero
   length, no tet of zero or negative volume, no triangle of zero area, no cell listed twice (the
   same vertices in any order: its measure would count twice). Vertices no cell uses are
   allowed (MSimMeshDropUnused drops them first); messages name vertices by their file ids. */
PetscErrorCode MSimMeshCheck(const MSimMesh *m);
/* A surface for TetGen must be closed: every edge in exactly two triangles. */
PetscErrorCode MSimMeshCheckClosed(const MSimMesh *m);
/* Multiplies every coordinate by s. */
void MSimMeshScale(MSimMesh *m, PetscReal s);
/* Appends a polygon of n corners (from file line `line`) as triangles: a fan from its corner of
   smallest id (exact for convex polygons; a quadrangle is cut as a hexahedron's face is). */
void MSimMeshAddPolygon(MSimMesh *m, const PetscInt *ids, PetscInt n, PetscInt line);
/* Appends a hexahedron (8 ids: a quadrangle, then the one above it, corner over corner, in Gmsh's
   and VTK's order) as 6 tets, or a prism (6 ids: a triangle, then the one above it) as 3 tets,
   by the rule above. A positively oriented cell (Gmsh's convention) gives positive tets. */
void MSimMeshAddHexahedron(MSimMesh *m, const PetscInt *ids, PetscInt line);
void MSimMeshAddPrism(MSimMesh *m, const PetscInt *ids, PetscInt line);

/* TetGen (rank 0): tetrahedralize the closed surface `surf` with the given switches (msim adds
   "z" for 0-based output and "Q" for quiet unless "V" is given). Fails with a message that names
   the file and TetGen's reason. Without TetGen in the build: an error that says so. The surface's
   vertices come first with their file ids; TetGen's new points are numbered on from the file's. */
PetscErrorCode MSimMeshTetrahedralize(const MSimMesh *surf, const char switches[], MSimMesh *tets);
PetscBool      MSimHaveTetGen(void);

/* Signed volume of tet (a, b, c, d), area of triangle (a, b, c). */
PetscReal MSimTetVolume(const PetscReal *a, const PetscReal *b, const PetscReal *c, const PetscReal *d);
PetscReal MSimTriangleArea(const PetscReal *a, const PetscReal *b, const PetscReal *c);

/* The unique edges of the cells (each as i < j, sorted by i then j) and, for each, the sum of the
   measures (volume or area) of the cells that contain it; with `opposite`, for every edge shared by
   exactly two triangles, the pair of vertices opposite it (the bending springs of a surface).
   Work and memory grow with the number of cells. */
PetscErrorCode MSimMeshEdges(const MSimMesh *m, std::vector<PetscInt> &ei, std::vector<PetscInt> &ej, std::vector<PetscReal> *edge_measure, std::vector<PetscInt> *opposite);
/* Each vertex's share of the cells' measure (a quarter of each tet's volume, a third of each
   triangle's area) and the total measure. */
PetscErrorCode MSimMeshVertexMeasure(const MSimMesh *m, std::vector<PetscReal> &share, PetscReal *total);
