/* Mesh layer: files in, validated simplices out. A mesh is read on rank 0 alone (MSimMeshRead),
   checked (MSimMeshCheck), and turned into springs by the scene layer. Every fault of a file is one
   error line naming the file, the line (or element) and the fault; the other ranks learn it by
   MSimCallOnRankZero, so it prints once whatever the rank count.

   Conventions: vertex ids are 0-based in file order; a tet (a, b, c, d) has positive volume
   det(b - a, c - a, d - a) / 6 > 0 (TetGen's and Gmsh's convention; PETSc's DMPlex stores tets the
   other way round and msim turns them back); triangles may have either orientation. */
#pragma once
#include <msim/sys.h>
#include <functional>
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
} MSimMesh;

/* Readers (rank 0). Each fills x, cells and lines; faults are errors on PETSC_COMM_SELF whose
   message starts with "FILE line N: " or "FILE: ". Polygons are split into triangles (a fan from
   their first corner). */
PetscErrorCode MSimMeshReadOFF(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadOBJ(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadSTL(const char file[], MSimMesh *m); /* ASCII or binary, vertices merged */
/* TetGen .node/.ele pair; file names either (or their common stem). 0- or 1-based, attributes and
   boundary markers allowed. */
PetscErrorCode MSimMeshReadTetGen(const char file[], MSimMesh *m);
/* Gmsh .msh (2.2 and 4.1; ASCII or binary): the cells of the highest dimension, tets (dim 3) or
   triangles (dim 2), by msim's own readers, one per encoding (MSimMeshReadGmsh picks by the
   file's $MeshFormat line). */
PetscErrorCode MSimMeshReadGmsh(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadGmshASCII(const char file[], MSimMesh *m);
PetscErrorCode MSimMeshReadGmshBinary(const char file[], MSimMesh *m);
/* By extension: .off .obj .stl .node .ele .msh. want: 3 (a surface) or 4 (tets); a surface given
   where tets are wanted comes back as a surface (the caller tetrahedralizes it). */
PetscErrorCode MSimMeshReadFile(const char file[], int want, MSimMesh *m);

/* Validation (rank 0): every index in range, every vertex in some cell, no repeated vertex in a
   cell, no edge of zero length, no tet of zero or negative volume, no triangle of zero area. */
PetscErrorCode MSimMeshCheck(const MSimMesh *m);
/* A surface for TetGen must be closed: every edge in exactly two triangles. */
PetscErrorCode MSimMeshCheckClosed(const MSimMesh *m);
/* Multiplies every coordinate by s. */
void MSimMeshScale(MSimMesh *m, PetscReal s);
/* Appends a polygon of n corners (from file line `line`) as triangles: a fan from its first
   corner, which is exact for the convex faces of OFF and OBJ files. */
void MSimMeshAddPolygon(MSimMesh *m, const PetscInt *ids, PetscInt n, PetscInt line);

/* TetGen (rank 0): tetrahedralize the closed surface `surf` with the given switches (msim adds
   "z" for 0-based output and "Q" for quiet unless "V" is given). Fails with a message that names
   the file and TetGen's reason. Without TetGen in the build: an error that says so. */
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

/* Runs fn on rank 0 of comm while the others wait; an error raised inside fn becomes one error on
   all ranks of comm with fn's first message, so it prints once (and out-of-memory is an error, not
   a crash). */
PetscErrorCode MSimCallOnRankZero(MPI_Comm comm, const std::function<PetscErrorCode(void)> &fn);
/* Collective: if ok is false on any rank, one error on comm with the message of the lowest such
   rank (printed once). */
PetscErrorCode MSimCollectiveCheck(MPI_Comm comm, PetscBool ok, const std::string &message);
