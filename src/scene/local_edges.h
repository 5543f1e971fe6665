/* The unique edges of the cells one rank holds, found by bucketing every cell edge under its lower
   vertex and sorting within a vertex's few neighbours (never across the whole mesh). Each rank
   sends one record per unique edge, not one per cell edge: a tet mesh has about 6 cell edges per
   unique edge, so this cuts the records the directory receives by that much. */
#pragma once
#include <msim/scene.h>

struct MSimLocalEdges {
  std::vector<PetscInt> ids;        /* the vertices the cells name, ascending input ids */
  std::vector<PetscInt> local;      /* the cells, as indices into ids */
  std::vector<PetscInt> a, b;       /* unique edges as indices into ids, a < b, ascending by (a, b) */
  std::vector<PetscInt> ptr, cells; /* the cells around edge e: cells[ptr[e] .. ptr[e+1]) */
  std::vector<PetscInt> cell_edge;  /* edge of each cell's edge slot (6 per tet: 01 02 03 12 13 23; 3 per triangle: 01 02 12) */
};

/* From s->cells (cell_size 3 or 4). Local work only. */
PetscErrorCode MSimLocalEdgesBuild(const MSimSceneData *s, MSimLocalEdges &E);
