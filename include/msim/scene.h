/* Scene layer: the spring graph in input vertex order, built identically on every rank from the
   options (generators are deterministic and cheap). MSimSystemCreate distributes it and the caller
   frees it, so only the setup phase holds the whole graph on each rank. */
#pragma once
#include <msim/sys.h>
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
  std::vector<PetscInt>     corners, edge; /* what -msim_fix corners|edge means for this scene */
  std::string               name;    /* scene type, for messages */
  PetscReal                 diameter; /* bounding-box diagonal of the rest state */
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

/* Generators */
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Cloth(MPI_Comm, MSimSceneData *);
PETSC_EXTERN PetscErrorCode MSimSceneGenerate_Chain(MPI_Comm, MSimSceneData *);
