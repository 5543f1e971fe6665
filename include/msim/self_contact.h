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

/* A uniform grid over boxes (the broad phase): Build hashes boxes (6 each: lo, hi) into cells of
   side `cell`; Query calls f(id) once for each box overlapping the query box. */
struct MSimBoxGrid {
  PetscReal                                     cell = 1;
  std::vector<std::pair<unsigned long long, PetscInt>> entries; /* (cell key, box), sorted */
  std::vector<PetscInt>                         stamp;          /* last query that saw each box */
  std::vector<PetscInt>                         large;          /* boxes over too many cells: every query tests them */
  std::vector<PetscReal>                        all;            /* the boxes (a query over too many cells tests each) */
  PetscInt                                      query = 0;
  void Build(const std::vector<PetscReal> &boxes, PetscReal cell_size);
  template <class F>
  void Query(const PetscReal *box, F &&f);
  static double MaxCells() { return 512; }
  unsigned long long Key(long long i, long long j, long long k) const
  {
    return ((unsigned long long)(i & 0x1FFFFF) << 42) | ((unsigned long long)(j & 0x1FFFFF) << 21) | (unsigned long long)(k & 0x1FFFFF);
  }
};

#include <algorithm>
#include <cmath>
template <class F>
void MSimBoxGrid::Query(const PetscReal *box, F &&f)
{
  long long lo[3], hi[3];
  double    ncell = 1;
  query++;
  for (int c = 0; c < 3; c++) {
    lo[c] = (long long)std::floor(box[c] / cell);
    hi[c] = (long long)std::floor(box[3 + c] / cell);
    ncell *= (double)(hi[c] - lo[c] + 1);
  }
  auto overlaps = [&](PetscInt b) {
    for (int c = 0; c < 3; c++)
      if (box[c] > all[6 * b + 3 + c] || box[3 + c] < all[6 * b + c]) return false;
    return true;
  };
  if (ncell > MaxCells()) { /* a box swept far: test every box (a few per line search at most) */
    for (PetscInt b = 0; b < (PetscInt)stamp.size(); b++)
      if (overlaps(b)) f(b);
    return;
  }
  for (PetscInt b : large)
    if (stamp[b] != query && overlaps(b)) {
      stamp[b] = query;
      f(b);
    }
  for (long long i = lo[0]; i <= hi[0]; i++)
    for (long long j = lo[1]; j <= hi[1]; j++)
      for (long long k = lo[2]; k <= hi[2]; k++) {
        const unsigned long long key = Key(i, j, k);
        auto it = std::lower_bound(entries.begin(), entries.end(), std::make_pair(key, (PetscInt)-1));
        for (; it != entries.end() && it->first == key; ++it)
          if (stamp[it->second] != query) {
            stamp[it->second] = query;
            f(it->second);
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
