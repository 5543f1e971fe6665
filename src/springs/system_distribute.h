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
};

/* morton: number each rank's vertices along a Z-order curve (else in input order). The scene's
   spring lists (si, sj, sk, sL) are handed over: empty on return. */
PetscErrorCode MSimSystemDistribute(MPI_Comm comm, MSimSceneData &S, MSimPartitioner partitioner, PetscBool morton, MSimLocalPart &L);
