/* The self-contact surface's body, for src/contact/self_*.cpp and the implicit term
   (src/implicit/terms/self_contact.cpp); msim/self_contact.h holds the handle. */
#pragma once
#include <msim/self_contact.h>
#include <array>

/* A surface triangle: its three input ids, ascending (orientation plays no part in distances) */
typedef std::array<PetscInt, 3> MSimSelfTri;

/* The surface a rank sees: its own elements (every surface triangle with a vertex in its block of
   input ids) and the halo (other ranks' triangles within the contact distance plus a motion
   margin of its own), with their vertices' positions gathered from the natural-order Vec by one
   scatter. Built by MSimSelfSurfaceCreate; re-planned (collective) when a vertex has moved more
   than half the margin since the last plan. */
struct _n_MSimSelfSurface {
  MSimSystem               sys;
  PetscInt                 dstart, dcount; /* this rank's block of input ids */
  PetscBool                halo;
  PetscReal                dhat, margin0, margin;
  std::vector<MSimSelfTri> own_tris;       /* the rank's own triangles (sorted) */
  /* the current plan */
  std::vector<PetscInt>  vid;          /* local vertices: input ids (sorted) */
  std::vector<PetscInt>  gnum;         /* their global free numbers (-1: fixed) */
  std::vector<PetscInt>  tri;          /* local triangles: 3 local vertices each */
  std::vector<PetscInt>  edge;         /* local edges: 2 local vertices each (unique) */
  std::vector<PetscReal> xplan;        /* positions at the plan */
  VecScatter             scatter;      /* natural -> local vertices (plans) */
  VecScatter             xscatter;     /* state Vec -> the local free vertices (every query) */
  std::vector<PetscInt>  fixed;        /* local vertices that are fixed ... */
  std::vector<PetscReal> fixed_b0;     /* ... and their positions at t = 0 (b(t) = b0 + t v) */
  Vec                    xl, gl;       /* local positions (3 each), local gradient */
  Vec                    gnumnat;      /* natural-order global free numbers (as reals) */
  PetscInt               nplans;
  PetscInt               nhalo;        /* triangles from other ranks in the plan */
};

/* The surface of a mesh scene for self-contact, from the cells each rank holds (S.cells): a
   surface mesh's triangles, or a tet mesh's boundary faces (those of exactly one tet, found at the
   directory rank of their least vertex); each triangle goes to the directory rank of each of its
   vertices, so a rank ends with the triangles around its block of input ids (ascending triples,
   3 per triangle). Collective; called by the system while it holds the scene. */
PetscErrorCode MSimSelfSurfaceTriangles(MPI_Comm comm, const MSimSceneData &S, std::vector<PetscInt> &tris);

PetscErrorCode MSimSelfSurfaceCreate(MSimSystem sys, const MSimSelfContactOptions *o, MSimSelfSurface *s);
PetscErrorCode MSimSelfSurfaceDestroy(MSimSelfSurface *s);
/* Refuses (one line, collective) the state X at time t a run starts from where its surface
   crosses itself or has vertex-disjoint elements closer than -msim_self_contact_start_gap (dhat
   by default, 0 at a restart; src/contact/self_start.cpp); restart: NULL for the scene's start X0, else the
   checkpoint's state in words. Re-plans where X is far from the plan (a checkpoint's state). */
PetscErrorCode MSimSelfSurfaceCheckStart(MSimSelfSurface s, const MSimSelfContactOptions *o, PetscReal t, Vec X, const char *restart);
/* The positions of the local vertices at X (time t: the handles' b(t)) into x (3 per local
   vertex), and, when Y is not NULL, those of -Y into u (the line search's motion X - a Y is x + a
   u); re-plans first when any vertex (also at x + a u) would be further than margin/2 from its
   planned position. Collective. */
PetscErrorCode MSimSelfSurfaceGather(MSimSelfSurface s, PetscReal t, Vec X, Vec Y, PetscReal a, std::vector<PetscReal> &x, std::vector<PetscReal> *u);
/* G += the local gradient g (3 per local vertex), contributions to other ranks' vertices sent to
   them (ADD_VALUES). Collective. */
PetscErrorCode MSimSelfSurfaceAddGradient(MSimSelfSurface s, const std::vector<PetscReal> &g, Vec G);
