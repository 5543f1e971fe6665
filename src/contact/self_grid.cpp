/* The broad phase's uniform grid (a spatial hash kept as a sorted array of (cell, box) entries):
   each box goes into every cell it overlaps, a query visits the cells of its box and reports each
   box once. A box over more than MaxCells() cells (a vertex a trial step sends far) is kept in a
   list every query tests, and a query box that large tests every box: the cost stays bounded by
   the boxes' count, not the cells' volume. Building is a sort of O(boxes x cells per box); a query costs a binary search per
   cell. msim's own rather than FCL's or CGAL's: the boxes change at every line-search trial (the
   swept boxes of CCD) and at every iterate, so the structure is rebuilt per query, and a sort of
   a few 10^4 entries is cheaper than those libraries' per-object set-up (FCL's DynamicAABBTree
   allocates a node per object; CGAL's box_intersection_d copies its boxes), and needs no new
   dependency. */
#include <msim/self_contact.h>

void MSimBoxGrid::Build(const std::vector<PetscReal> &boxes, PetscReal cell_size)
{
  const PetscInt n = (PetscInt)(boxes.size() / 6);
  cell             = cell_size;
  entries.clear();
  large.clear();
  all = boxes;
  stamp.assign(n, -1);
  query = 0;
  for (PetscInt b = 0; b < n; b++) {
    const PetscReal *box = &boxes[6 * b];
    long long        lo[3], hi[3];
    double           ncell = 1;
    for (int c = 0; c < 3; c++) {
      lo[c] = (long long)std::floor(box[c] / cell);
      hi[c] = (long long)std::floor(box[3 + c] / cell);
      ncell *= (double)(hi[c] - lo[c] + 1);
    }
    if (ncell > MaxCells()) { /* swept far along a line search: tested by every query instead */
      large.push_back(b);
      continue;
    }
    for (long long i = lo[0]; i <= hi[0]; i++)
      for (long long j = lo[1]; j <= hi[1]; j++)
        for (long long k = lo[2]; k <= hi[2]; k++) entries.push_back({Key(i, j, k), b});
  }
  std::sort(entries.begin(), entries.end());
}
