/* What MSimSystemDistribute leaves on each rank for MSimSystemCreate to build on. */
#pragma once
#include <msim/system.h>
#include <msim/partition.h>

/* A spring as its owner (or, a halo copy, the owner of its other end) receives it: ends by global
   free number (-1: fixed) and input id. 32 bytes: whether a copy is the halo one follows from who
   owns its first free end, so it is not sent. */
struct MSimRoutedSpring {
  PetscInt  va, vb, ga, gb;
  PetscReal k, L;
};

/* A tet as the rank that computes it receives it (msim/volume.h): vertices by input id and global
   free number (-1: fixed), signed rest volume */
struct MSimRoutedTet {
  PetscInt  v[4], g[4];
  PetscReal V0;
};

/* what the directory tells about a vertex once it is partitioned */
struct MSimVertexOwner {
  PetscMPIInt owner; /* -1: fixed */
  PetscInt    gnum;
};

struct MSimLocalPart {
  PetscInt               nfree = 0, nfix_global = 0, nown = 0, rstart = 0;
  std::vector<PetscInt>  ranges;            /* size + 1: rank r owns global free numbers [ranges[r], ranges[r+1]) */
  std::vector<PetscInt>  own_vid;           /* owned vertices by global number: input ids, ... */
  std::vector<PetscReal> own_x0, own_mass;  /* ... rest positions (3 each) and masses */
  std::vector<MSimRoutedSpring> owned, halo;
  std::vector<PetscInt>  dir_gnum;          /* the directory block's global numbers (-1: fixed) */
  std::vector<PetscInt>  fixed_vid;         /* the fixed ends of owned springs, ascending input ids ... */
  std::vector<PetscReal> fixed_x0;          /* ... and their rest positions */
  PetscInt               nspring_moving = 0, between_free = 0, cut = 0;
  std::vector<MSimRoutedTet> tets;          /* the tets this rank computes (-msim_volume), then its halo */
  PetscInt               ntet_own = 0;      /* the first of tets: those this rank computes */
  PetscInt               ntet = 0;          /* tets with a free vertex, all ranks */
  PetscReal              modulus = 0;       /* the springs' equivalent Young's modulus (volume.cpp) */
};

/* The tets to the ranks that compute them (the owner of each tet's free vertex of least global
   number), halo copies to the other owners of their free vertices, and the springs' modulus, before the springs are routed. Collective. */
PetscErrorCode MSimSystemDistributeTets(MPI_Comm comm, const MSimSceneData &S, const std::vector<MSimVertexOwner> &table, MSimLocalPart &L);

/* morton: number each rank's vertices along a Z-order curve (else in input order). The scene's
   spring lists (si, sj, sk, sL) are handed over: empty on return. */
PetscErrorCode MSimSystemDistribute(MPI_Comm comm, MSimSceneData &S, MSimPartitioner partitioner, PetscBool morton, MSimLocalPart &L);
