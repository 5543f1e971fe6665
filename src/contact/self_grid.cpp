/* The broad phase's grid (MSimBoxGrid, msim/self_contact.h): a hierarchy of uniform grids in
   which each box is binned once, by its centre, in the first level whose cell (cell_size times a
   power of 2) is at least the box's largest side. A query visits, on each level that holds boxes,
   the cells whose centres could belong to an overlapping box (its own box grown by the level's
   largest half extents): for a point query 8 cells per level, read as one contiguous run of boxes
   each. The previous grid put each box in every cell it overlapped (8 on average) and reported a
   box once by a per-box stamp: the stamp's random reads and the binary search per cell were the
   hottest lines of a 101 x 101 cloth's self-contact in perf. Boxes larger than the top level (a vertex that
   a trial step sends far) are tested by every query.
   msim's own rather than FCL's or CGAL's: the boxes change at every line-search trial (the swept
   boxes of CCD) and at every iterate, so the structure is rebuilt per query, and a sort of a few
   10^4 entries is cheaper than those libraries' per-object set-up (FCL's DynamicAABBTree allocates
   a node per object; CGAL's box_intersection_d copies its boxes), and needs no new dependency. */
#include <msim/self_contact.h>

void MSimBoxGrid::Build(const std::vector<PetscReal> &boxes, PetscReal cell_size)
{
  const PetscInt n = (PetscInt)(boxes.size() / 6);
  all              = boxes;
  levels.assign(MaxLevels(), Level());
  for (int l = 0; l < MaxLevels(); l++) levels[l].cell = cell_size * (PetscReal)(1LL << l);
  order.clear();
  large.clear();
  for (PetscInt b = 0; b < n; b++) {
    const PetscReal *x    = &boxes[6 * b];
    const PetscReal  side = PetscMax(x[3] - x[0], PetscMax(x[4] - x[1], x[5] - x[2]));
    int              l    = 0;
    while (l < MaxLevels() && levels[l].cell < side) l++;
    bool far = false; /* a centre beyond the cells' integer keys (or not finite): tested by every query */
    for (int q = 0; q < 3 && l < MaxLevels(); q++) far = far || !(std::fabs(0.5 * (x[q] + x[3 + q]) / levels[l].cell) < 1e15);
    if (l == MaxLevels() || !(side < PETSC_MAX_REAL) || far) {
      large.push_back(b);
      continue;
    }
    Level    &L = levels[l];
    long long c[3];
    for (int q = 0; q < 3; q++) {
      c[q]   = (long long)std::floor(0.5 * (x[q] + x[3 + q]) / L.cell);
      L.h[q] = PetscMax(L.h[q], 0.5 * (x[3 + q] - x[q]));
    }
    order.push_back({Key(l, c[0], c[1], c[2]), b});
  }
  std::sort(order.begin(), order.end());
  const PetscInt m = (PetscInt)order.size();
  id.resize(m);
  box.resize(6 * (size_t)m);
  rkey.clear();
  rstart.clear();
  for (PetscInt e = 0; e < m; e++) {
    id[e] = order[e].second;
    for (int q = 0; q < 6; q++) box[6 * e + q] = boxes[6 * order[e].second + q];
    if (!e || order[e].first != order[e - 1].first) {
      rkey.push_back(order[e].first);
      rstart.push_back(e);
    }
  }
  rstart.push_back(m);
  /* each level's runs and its hash table (at most half full) */
  PetscInt r = 0;
  for (int l = 0; l < MaxLevels(); l++) {
    Level   &L  = levels[l];
    PetscInt r0 = r;
    while (r < (PetscInt)rkey.size() && (int)(rkey[r] >> 60) == l) r++;
    L.begin = r0 < r ? rstart[r0] : 0;
    L.end   = r0 < r ? rstart[r] : 0;
    size_t cap = 1;
    while (cap < 2 * (size_t)(r - r0)) cap *= 2;
    L.slot.assign(cap, -1);
    const size_t mask = cap - 1;
    for (PetscInt k = r0; k < r; k++) {
      size_t s = Hash(rkey[k]) & mask;
      while (L.slot[s] >= 0) s = (s + 1) & mask;
      L.slot[s] = k;
    }
  }
}
