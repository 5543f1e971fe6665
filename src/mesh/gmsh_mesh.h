/* What msim's two Gmsh readers (read_gmsh_ascii.cpp, read_gmsh_binary.cpp) share: Gmsh's element
   types, and the nodes and elements gathered while reading, turned into an MSimMesh at the end.
   msim keeps the elements of the highest dimension (tets, hexahedra and prisms of a volume mesh,
   triangles and quadrangles of a surface mesh; the edges and points before them are their
   boundaries), split into tets or triangles (mesh.h's rule), and every node, in the file's order:
   a node's id is its place in $Nodes, and nodes on no kept element are dropped later
   (MSimMeshDropUnused) without shifting the others' ids. Tets keep Gmsh's orientation. */
#pragma once
#include <msim/mesh.h>
#include <cstdint>
#include <unordered_map>
#include <vector>

/* A Gmsh element type: its nodes and dimension (nodes 0: a type msim does not read; then name
   says what it is where msim knows, e.g. "second-order tetrahedron (10 nodes)", for the message) */
struct MSimGmshType {
  int         nodes, dim;
  const char *name;
};
MSimGmshType MSimGmshTypeOf(int64_t type);
/* The message's end for a type msim does not read: what msim reads instead */
#define MSIM_GMSH_READS "msim reads first-order elements: tets, hexahedra and prisms (split into tets), triangles and quadrangles, and their edges and points; Gmsh writes them with -order 1"

class MSimGmshMesh {
public:
  /* where: the file line of the record (ASCII) or its byte offset (binary), for messages */
  explicit MSimGmshMesh(bool lines) : lines_(lines) { }
  /* Room for n more nodes (n bounded by what the rest of the file can hold) */
  void ReserveNodes(size_t n)
  {
    x_.reserve(x_.size() + 3 * n);
    xwhere_.reserve(xwhere_.size() + n);
    index_.reserve(index_.size() + n);
  }
  /* False when the tag was seen before. */
  bool AddNode(int64_t tag, const PetscReal x[3], int64_t where);
  /* An element of a type msim reads (MSimGmshTypeOf(type).nodes > 0) with its node tags. False
     for a pyramid (the one element of the highest dimension msim does not split). */
  bool AddElement(int64_t type, const int64_t *nodes, int64_t where);
  /* The kept elements, split into tets or triangles, and every node, into m; faults (no tets or
     triangles, a node not in $Nodes) name the file and the line or byte. */
  PetscErrorCode Finish(const char file[], MSimMesh *m);

private:
  bool                                   lines_;
  std::unordered_map<int64_t, PetscInt> index_; /* node tag -> position in the file */
  std::vector<PetscReal>                 x_;
  std::vector<int64_t>                   xwhere_;
  int                                    top_ = -1; /* highest element dimension seen */
  std::vector<int8_t>                    types_; /* the elements of dimension top_: their types ... */
  std::vector<int64_t>                   cells_; /* ... and node tags */
  std::vector<int64_t>                   cwhere_;
};
