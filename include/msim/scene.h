/* Scene layer: the spring graph, distributed from the start. A generator makes, on each rank, some
   vertices (input id and rest position; every vertex on one rank), some springs (each on one
   rank) and some cells (a mesh's tets or triangles); a file is read on rank 0 alone, which holds
   it transiently. MSimSceneCreateFromOptions then moves every vertex to its *directory* rank (a
   block layout of input ids, msim/exchange.h), refines a tet mesh (-msim_refine), makes a mesh's
   springs from its cells' unique edges, and sets fixed vertices and masses there. No rank holds
   more than its part (but rank 0 holding a file it read). MSimSystemCreate partitions it. */
#pragma once
#include <msim/petsc_compat.h>
#include <msim/options.h>
#include <msim/mesh.h>
#include <msim/exchange.h>
#include <msim/self_contact_options.h>
#include <vector>
#include <string>

enum MSimSpringFamily { MSIM_STRUCTURAL = 0, MSIM_SHEAR = 1, MSIM_BENDING = 2, MSIM_EDGE = 3 };

typedef struct _n_MSimSceneData {
  /* read by MSimSceneCreateFromOptions before the generator runs: -msim_stiffness, the spring
     constant of every spring a generator makes unless one of its families overrides it
     (MSimSceneOptionsFamilyStiffness); the default here is the one default of every scene */
  PetscReal              stiffness = 1000.0;
  /* made by the generator on this rank */
  PetscInt               nv = 0;       /* vertices of the whole scene (every rank knows it) */
  std::vector<PetscInt>  vid;          /* vertices made here: input ids ... */
  std::vector<PetscReal> vx;           /* ... and rest positions, 3 each */
  std::vector<PetscInt>  vfile;        /* ... and their ids in the file (where nv_file > 0) */
  /* where a file's ids differ from the input ids (it had vertices no cell uses, which are
     dropped): the ids in the file's numbering in use, its vertices (dropped ones included) and then
     those msim added (TetGen's new points, refinement's midpoints, numbered on from the file's);
     0 where the two numberings are the same. Every rank knows it. */
  PetscInt               nv_file = 0;
  std::vector<PetscInt>  si, sj;       /* springs held here, input ids (each spring on one rank) */
  std::vector<PetscReal> sk, sL;       /* stiffness and rest length */
  int                    cell_size = 0; /* 4 tets, 3 triangles, 0 none */
  std::vector<PetscInt>  cells;        /* cells held here, input ids */
  /* each cell's place in the scene's order of its cells (the file's element order, a generator's
     order; a refined tet's children at 8 x its place + 0..7), the same at any rank count; empty
     where the cells held on ranks 0, 1, ... in turn are in that order (as a generator makes them,
     before MSimSceneSpreadCells moves them) */
  std::vector<PetscInt>  cell_id;
  /* the last nbend springs held here are a mesh's bending springs (MSimSceneCellSprings). The
     scene's order of its springs: every rank's others in rank order, then every rank's bending
     ones (the order at one rank, where each group is sorted by its ends) */
  PetscInt               nbend = 0;
  /* a mesh's springs come from its cells' edges: stiffness k_cell each, or with young > 0
     E V_e / L_e^2 (V_e: the volume of the tets around edge e); with k_bend > 0 a bending spring
     across every edge two triangles share */
  PetscReal              k_cell = 0, young = 0, k_bend = 0;
  /* the generator made a mesh's springs, measure and shares itself (the box), and placed each cell
     at the directory of its first vertex: the scene needs neither spread nor edge search unless
     it refines */
  PetscBool              springs_made = PETSC_FALSE;
  /* -msim_volume: a tet scene keeps its cells for the system's volume term (msim/volume.h); off by
     default: it costs more than the 20% per step on the bunny that would have made it the default
     (runs/self_contact/volume) */
  PetscBool              volume = PETSC_FALSE;
  /* -msim_self_contact's block, read here once (a mesh keeps its cells for the surface when on);
     the system carries it to the implicit term */
  MSimSelfContactOptions self_contact;
  std::vector<PetscInt>  corners, edge; /* what -msim_fix corners|edge means (grids and chains) */
  std::string            name;         /* scene type, for messages */
  std::string            source;       /* where a mesh came from, for views */
  PetscBool              options_only = PETSC_FALSE; /* -help: read the options, build nothing */
  /* false when nothing after the generator reads the cells (no refinement, nothing drawn, no
     -msim_scene_keep_cells): a generator that makes its springs itself then counts its cells
     instead of storing them */
  PetscBool              cells_wanted = PETSC_TRUE;
  PetscInt               cells_not_stored = 0; /* cells made here and not stored */

  /* the directory, after MSimSceneCreateFromOptions: this rank's block of input ids */
  MSimBlockLayout        dir;
  std::vector<PetscReal> x0;           /* 3 per block vertex: rest positions */
  std::vector<PetscReal> mass;         /* lumped masses */
  std::vector<char>      fixed;        /* fixed flags */
  std::vector<PetscReal> share;        /* each block vertex's share of the cells' volume or area */
  /* each block vertex's id in the file it was read from (the ids users type and frames carry);
     empty where the two are the same (generated scenes, files with no dropped vertices: nv_file
     0). A vertex msim added has the id nv_file had before it plus its place among the added ones,
     as its input id does, so ids stay unique and the same at any rank count. */
  std::vector<PetscInt>  file_id;
  /* global figures */
  PetscReal              diameter = 0; /* bounding-box diagonal of the rest state */
  PetscReal              measure = 0;  /* total volume or area of the cells */
  PetscInt               nspring = 0, ncell = 0;
  /* the options that define the scene: those the user set that its creation (the scene's own
     block, the generator, fixed vertices, the mesh readers) read, one "-name value" line each,
     sorted; a checkpoint stores them and a restart compares them */
  std::string            identity;
} MSimSceneData;

/* The body is private (msim/private/sceneimpl.h). */
typedef struct _n_MSimScene *MSimScene;

typedef PetscErrorCode (*MSimSceneGenerator)(MPI_Comm, MSimSceneData *);
PetscErrorCode MSimSceneRegister(const char name[], MSimSceneGenerator gen);
PetscErrorCode MSimSceneRegisterAll(void);
PetscErrorCode MSimSceneFinalizePackage(void);

/* Build from options (-msim_scene, stiffness, mass, fixed vertices). Collective. */
PetscErrorCode MSimSceneCreateFromOptions(MPI_Comm comm, MSimScene *scene);
PetscErrorCode MSimSceneDestroy(MSimScene *scene);
/* The scene's data as the generators and the directory left it (read only). */
PetscErrorCode MSimSceneGetData(MSimScene scene, const MSimSceneData **data);

PetscReal      MSimSceneHash(PetscInt v, PetscInt c);

/* Helpers for generators */
/* -msim_stiffness_<family>, inside the generator's options block: the family's spring constant, N/m
   (s->stiffness where not set); errors name the option */
PetscErrorCode MSimSceneOptionsFamilyStiffness_Private(PetscOptionItems *PetscOptionsObject, const MSimSceneData *s, const char family[], const char help[], PetscReal *k);
#define MSimSceneOptionsFamilyStiffness(s, family, help, k) MSimSceneOptionsFamilyStiffness_Private(PetscOptionsObject, s, family, help, k)

/* Fixed vertices from -msim_fix, -msim_fix_list, -msim_fix_plane, -msim_fix_box. */
PetscErrorCode MSimSceneSelectFixed(MPI_Comm comm, MSimSceneData *s);

/* A mesh read on this rank is checked (MSimMeshCheck), its notes printed, and it becomes this
   rank's vertices and cells (input ids: the mesh's compact indices; the file's ids, where they
   differ, in vfile and nv_file). */
PetscErrorCode MSimSceneTakeMesh(MSimMesh *mesh, MSimSceneData *s);

/* The distributed steps (distribute.cpp, refine.cpp). Collective. */
PetscErrorCode MSimSceneToDirectory(MPI_Comm comm, MSimSceneData *s);   /* vertices to their directory rank */
PetscErrorCode MSimSceneSpreadCells(MPI_Comm comm, MSimSceneData *s);   /* cells to the directory rank of their first vertex */
PetscErrorCode MSimSceneRefine(MPI_Comm comm, MSimSceneData *s);        /* one regular refinement of the tets (1 into 8) */
PetscErrorCode MSimSceneCellSprings(MPI_Comm comm, MSimSceneData *s);   /* a mesh's springs and measure shares from its cells */
/* What output draws, in the scene's order at any rank count, each rank a block of it (the layout
   of msim/exchange.h): its cells (input ids, cell_size each) and its springs (input-id pairs and
   rest lengths). */
PetscErrorCode MSimSceneDrawnCells(MPI_Comm comm, const MSimSceneData *s, std::vector<PetscInt> &cells);
PetscErrorCode MSimSceneDrawnSprings(MPI_Comm comm, const MSimSceneData *s, std::vector<PetscInt> &ends, std::vector<PetscReal> &L);
/* The rest positions of any vertices, from the directory. */
PetscErrorCode MSimSceneFetchPositions(MPI_Comm comm, const MSimSceneData *s, const std::vector<PetscInt> &ids, std::vector<PetscReal> &x);

/* Generators */
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Cloth(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Chain(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Tet(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Mesh(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Box(MPI_Comm, MSimSceneData *);

/* -msim_mesh_file, -msim_mesh_format and -msim_mesh_scale, shared by the tet and the surface scenes */
PetscErrorCode MSimSceneMeshFileOptions(PetscOptionItems *PetscOptionsObject, char file[], size_t len, PetscReal *scale, PetscBool *set, char format[], size_t flen);
