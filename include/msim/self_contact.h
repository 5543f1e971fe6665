/* Self-contact (-msim_self_contact): IPC's distance barriers between the surface elements of a
   scene (point-triangle and edge-edge pairs that share no vertex), a conservative CCD (additive
   CCD, Li et al. 2021) for the line search's largest feasible step, a uniform-grid broad phase, and
   each rank's halo of surface elements from neighbouring ranks. The implicit term is
   src/implicit/terms/self_contact.cpp; the geometry is src/contact/self_*.cpp. */
#pragma once
#include <msim/system.h>
#include <msim/self_contact_options.h>
#include <vector>

/* Explicit integrators and PETSc's TS cannot keep a barrier's feasible set: with
   -msim_self_contact (the system's options) they are refused in one line (called by
   MSimIntegratorSetUp). */
PetscErrorCode MSimSelfContactCheckIntegrator(MSimSystem sys, const char type[], PetscBool implicit);

/* Closest points: squared distance d2 = |r|^2 with r = sum_k w[k] x_k over the pair's four
   points (point-triangle: p, a, b, c; edge-edge: a0, a1, b0, b1). The weights are those of the
   closest points (clamped to the elements), so by the envelope theorem grad d2 = 2 w_k r. */
PetscReal MSimPointTriangleDistance2(const PetscReal *p, const PetscReal *a, const PetscReal *b, const PetscReal *c, PetscReal w[4]);
PetscReal MSimEdgeEdgeDistance2(const PetscReal *a0, const PetscReal *a1, const PetscReal *b0, const PetscReal *b1, PetscReal w[4]);
/* Additive CCD (Li, Kaufman, Jiang 2021, Alg. 1, thickness 0): x (12: the pair's four points) moving
   by u (12) over t in [0, 1]; returns a t at which the pair is still at least s times its starting
   distance apart and before which it never touches (1 when it does not come that close). */
PetscReal MSimAdditiveCCD(const PetscReal x[12], const PetscReal u[12], PetscBool edge_edge, PetscReal s);

/* The broad phase's grid over boxes (6 each: lo, hi): a hierarchy of uniform grids, each box
   binned once, by its centre, in the level whose cell is the first at least as large as the box
   (cells of `cell` times 1, 2, 4, ...); Query(box, f) calls f(id) once for each box overlapping
   box. Since each box sits in one cell, a query needs no stamps to report a box once, and the
   boxes are kept in cell order, so a query reads them contiguously. */
struct MSimBoxGrid {
  struct Level {
    PetscReal             cell = 1, h[3] = {0, 0, 0}; /* cell side; the largest half extent per axis */
    PetscInt              begin = 0, end = 0;         /* its boxes in the cell-ordered arrays */
    std::vector<PetscInt> slot;                       /* open-addressing table: cell key -> run index */
  };
  std::vector<Level>                                   levels;
  std::vector<std::pair<unsigned long long, PetscInt>> order; /* (level and cell key, box), sorted */
  std::vector<unsigned long long>                      rkey;  /* runs of one cell: key, ... */
  std::vector<PetscInt>                                rstart; /* ... and first position (one past: the next run's) */
  std::vector<PetscInt>                                id;     /* boxes in cell order */
  std::vector<PetscReal>                               box;    /* their boxes, same order */
  std::vector<PetscInt>                                large;  /* boxes beyond the top level: every query tests them */
  std::vector<PetscReal>                               all;    /* the boxes as given */
  void Build(const std::vector<PetscReal> &boxes, PetscReal cell_size);
  template <class F>
  void Query(const PetscReal *q, F &&f);
  static int MaxLevels() { return 12; }
  static unsigned long long Key(int level, long long i, long long j, long long k)
  {
    return ((unsigned long long)level << 60) | ((unsigned long long)(i & 0xFFFFF) << 40) | ((unsigned long long)(j & 0xFFFFF) << 20) | (unsigned long long)(k & 0xFFFFF);
  }
  static size_t Hash(unsigned long long key) /* splitmix64's finalizer: every bit of the key mixes into the low ones */
  {
    key = (key ^ (key >> 30)) * 0xBF58476D1CE4E5B9ULL;
    key = (key ^ (key >> 27)) * 0x94D049BB133111EBULL;
    return (size_t)(key ^ (key >> 31));
  }
  PetscInt Find(const Level &L, unsigned long long key) const
  {
    const size_t mask = L.slot.size() - 1;
    for (size_t s = Hash(key) & mask;; s = (s + 1) & mask) {
      const PetscInt r = L.slot[s];
      if (r < 0 || rkey[r] == key) return r;
    }
  }
};

#include <algorithm>
#include <cmath>
template <class F>
void MSimBoxGrid::Query(const PetscReal *q, F &&f)
{
  auto test = [&](const PetscReal *b) {
    for (int c = 0; c < 3; c++)
      if (q[c] > b[3 + c] || q[3 + c] < b[c]) return false;
    return true;
  };
  for (PetscInt b : large)
    if (test(&all[6 * b])) f(b);
  for (int l = 0; l < (int)levels.size(); l++) {
    const Level &L = levels[l];
    if (L.begin == L.end) continue;
    long long lo[3] = {0, 0, 0}, hi[3] = {-1, -1, -1};
    double    dlo[3], dhi[3], ncell = 1;
    /* a box overlapping q has its centre within q grown by the level's half extents; the cell
       range in double first (a trial point sent far or to NaN must not overflow the cast) */
    for (int c = 0; c < 3; c++) {
      dlo[c] = std::floor((q[c] - L.h[c]) / L.cell);
      dhi[c] = std::floor((q[3 + c] + L.h[c]) / L.cell);
      ncell *= dhi[c] - dlo[c] + 1;
    }
    if (!(ncell < (double)(L.end - L.begin)) || !(ncell <= 1e6)) { /* q spans the level (a box swept far), or is not finite: test its boxes */
      for (PetscInt e = L.begin; e < L.end; e++)
        if (test(&box[6 * e])) f(id[e]);
      continue;
    }
    for (int c = 0; c < 3; c++) lo[c] = (long long)dlo[c], hi[c] = (long long)dhi[c];
    for (long long i = lo[0]; i <= hi[0]; i++)
      for (long long j = lo[1]; j <= hi[1]; j++)
        for (long long k = lo[2]; k <= hi[2]; k++) {
          const PetscInt r = Find(L, Key(l, i, j, k));
          if (r < 0) continue;
          for (PetscInt e = rstart[r]; e < rstart[r + 1]; e++)
            if (test(&box[6 * e])) f(id[e]);
        }
  }
}

/* The surface a rank sees (its elements and the halo from other ranks) is private:
   msim/private/selfcontactimpl.h. */
typedef struct _n_MSimSelfSurface *MSimSelfSurface;

extern PetscLogEvent MSIM_SelfBroad, MSIM_SelfHalo, MSIM_SelfNarrow, MSIM_SelfCCD;
PetscErrorCode MSimSelfContactLogRegister(void);

/* A pair within dhat, for self-friction's lag (src/implicit/terms/self_friction.cpp): its four
   vertices' global free numbers (-1: fixed), the closest points' weights w (r = sum_k w_k x_k),
   the unit normal n = r / |r|, and the barrier's normal force |dE/dd| = 2 C |b'(d^2)| d in Phi's
   units (beta h^2 times newtons) */
typedef struct {
  PetscInt  gnum[4];
  PetscReal w[4], n[3], force;
} MSimSelfContactPair;
typedef struct _n_MSimImplicitTerm *MSimImplicitTerm;
/* The pairs within dhat at X (time t) that this rank computes, from the self-contact term's
   candidate list (collective: the surface's gather) */
PetscErrorCode MSimSelfContactGetPairs(MSimImplicitTerm self_contact, PetscReal t, Vec X, std::vector<MSimSelfContactPair> &pairs);

/* The pairs' 12 x 12 Hessian blocks into a Mat, each rank adding to the rows it owns only. A pair
   is computed by one rank and its vertices' rows may be other ranks': PETSc's assembly would add
   what several ranks send to one row in the order their messages arrive, so at 3 ranks two runs of
   one scene differed in the last bits. Here the rows of a block that another rank owns go to it
   point to point (over the neighbours of the scatter that brought the pair's positions: each free
   vertex of a pair is a leaf of it, so its owner is one of its root ranks, and a rank that sends
   here one of its leaf ranks), and the owner adds them after its own blocks, in the senders' rank
   order and each sender's order: every entry's sum in one order, whatever the timing. Usage:
   Begin, Add per block, End (collective: exchanges, adds, assembles). */
typedef struct {
  PetscInt    row, col[4]; /* a vertex's global free number; the block's vertices' (-1: fixed) */
  PetscScalar v[36];       /* the vertex's 3 rows of the block */
} MSimSelfRows;
struct MSimSelfHessian {
  MPI_Comm                  comm = MPI_COMM_NULL; /* PETSc's inner communicator, with two tags of its own */
  PetscMPIInt               tag[2] = {0, 0}, rank = 0, size = 1;
  MPI_Datatype              type = MPI_DATATYPE_NULL; /* one MSimSelfRows */
  Mat                       J = NULL;
  const PetscInt           *ranges = NULL; /* J's row ownership */
  std::vector<MSimSelfRows> send, recv;    /* rows for other ranks (grouped by End) and from them */
  std::vector<PetscMPIInt>  dest;          /* send's owners */
};
PetscErrorCode MSimSelfHessianCreate(MPI_Comm comm, MSimSelfHessian *h);
PetscErrorCode MSimSelfHessianDestroy(MSimSelfHessian *h);
PetscErrorCode MSimSelfHessianBegin(MSimSelfHessian *h, Mat J);
/* gnum: the block's vertices' global free numbers (-1: fixed, no row or column) */
PetscErrorCode MSimSelfHessianAdd(MSimSelfHessian *h, const PetscInt gnum[4], const PetscScalar H[144]);
PetscErrorCode MSimSelfHessianEnd(MSimSelfHessian *h, VecScatter neighbours);
