/* Scene layer: the spring graph in input vertex order, the same on every rank: generators are
   deterministic and run on every rank; a mesh file is read (and tetrahedralized) on rank 0 alone
   and the graph broadcast. MSimSystemCreate distributes it and the caller frees it, so only the
   setup phase holds the whole graph on each rank. */
#pragma once
#include <msim/sys.h>
#include <msim/mesh.h>
#include <vector>
#include <string>

enum MSimSpringFamily { MSIM_STRUCTURAL = 0, MSIM_SHEAR = 1, MSIM_BENDING = 2, MSIM_EDGE = 3 };

typedef struct {
  PetscInt                  nv;      /* vertices */
  std::vector<PetscReal>    x0;      /* 3 nv positions of the rest state */
  std::vector<PetscReal>    mass;    /* nv lumped masses */
  std::vector<PetscInt>     si, sj;  /* spring endpoints (input ids) */
  std::vector<PetscReal>    sk, sL;  /* stiffness and rest length */
  std::vector<char>         fixed;   /* nv flags */
  std::vector<PetscInt>     corners, edge; /* what -msim_fix corners|edge means (grids and chains) */
  std::string               name;    /* scene type, for messages */
  PetscReal                 diameter; /* bounding-box diagonal of the rest state */
  /* meshes: the cells (tets, or the triangles of a surface) in input vertex ids, which output
     draws; each vertex's share of their volume or area, by which masses are lumped (empty: equal
     masses); the total volume or area */
  int                       cell_size = 0; /* 4 tets, 3 triangles, 0 none */
  std::vector<PetscInt>     cells;
  std::vector<PetscReal>    share;
  PetscReal                 measure = 0;
  std::string               source;  /* where a mesh came from, for views */
  PetscBool                 options_only = PETSC_FALSE; /* -help: read the options, build nothing */
} MSimSceneData;

typedef struct _n_MSimScene *MSimScene;
struct _n_MSimScene {
  MSimSceneData data;
  PetscReal     fix_velocity[3]; /* fixed vertices translate with this velocity */
  PetscReal     prestretch;      /* initial positions = prestretch * rest positions */
  PetscReal     perturb;         /* plus a deterministic pseudo-random displacement of this size */
};

typedef PetscErrorCode (*MSimSceneGenerator)(MPI_Comm, MSimSceneData *);
PetscErrorCode MSimSceneRegister(const char name[], MSimSceneGenerator gen);
PetscErrorCode MSimSceneRegisterAll(void);
PetscErrorCode MSimSceneFinalizePackage(void);

/* Build from options (-msim_scene, stiffness, mass, fixed vertices). Collective. */
PetscErrorCode MSimSceneCreateFromOptions(MPI_Comm comm, MSimScene *scene);
PetscErrorCode MSimSceneDestroy(MSimScene *scene);

PetscReal      MSimSceneHash(PetscInt v, PetscInt c);

/* Helpers for generators */
void           MSimSceneAddSpring(MSimSceneData *s, PetscInt i, PetscInt j, PetscReal k);
PetscErrorCode MSimSceneGetStiffness(const char family[], PetscReal *k);

/* Fixed vertices from -msim_fix, -msim_fix_list, -msim_fix_plane, -msim_fix_box. */
PetscErrorCode MSimSceneSelectFixed(MPI_Comm comm, MSimSceneData *s);

/* Meshes to scenes (mesh_scene.cpp): springs on the unique edges of tets, stiffness k each or,
   with young > 0, E (sum of the volumes of the tets around the edge) / L^2; of triangles, with
   bending springs across each edge two triangles share when kbend > 0. Masses by volume or area. */
PetscErrorCode MSimSceneFromTets(const MSimMesh *mesh, PetscReal k, PetscReal young, MSimSceneData *s);
PetscErrorCode MSimSceneFromSurface(const MSimMesh *mesh, PetscReal kedge, PetscReal kbend, MSimSceneData *s);
/* Rank 0's scene to every rank. */
PetscErrorCode MSimSceneDataBcast(MPI_Comm comm, MSimSceneData *s);

/* Generators */
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Cloth(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Chain(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Tet(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Mesh(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Box(MPI_Comm, MSimSceneData *);
