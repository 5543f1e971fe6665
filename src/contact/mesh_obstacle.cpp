/* A static triangle surface as an obstacle (-msim_contact_mesh F): read on rank 0 by msim's mesh
   readers and checked by MSimMeshCheck (their one-line errors: a malformed file, a triangle of zero
   area naming file and line), broadcast once, and held whole by every rank in CGAL's AABB tree
   (CGAL 5.5, header-only: Debian's libcgal-dev), so each rank answers the queries about its own
   vertices with no communication. CGAL stays inside this one file (its headers are slow to
   compile); msim/contact.h is the interface.
   - Distance: the tree's closest triangle, then the closest point on that triangle by Ericson's
     region test (Real-Time Collision Detection 5.1.5), which also says whether it lies inside the
     face, on an edge or at a vertex: the Hessian of the distance r = |x - p| is 0, (I - n n^T -
     e e^T)/r or (I - n n^T)/r there. The obstacle's distance is r - thickness.
   - Side: a closed surface (every edge in exactly two triangles) keeps the cloth outside. Inside
     is decided by the parity of a ray's crossings, for points in the surface's bounding box and
     within a band of it (thickness + dhat once the contact options are read: the barrier's reach;
     the line searches never let a vertex cross the surface, so none is deeper; the start check
     tests every vertex). The explicit penalty's vertices sink deeper (a landing's depth, m v /
     sqrt(kc m)): with MSimMeshObstacleSetPenalty a point of the box beyond the band takes its side
     from its cell's reference point or a ray too, and inside, its true depth (Deep), so that a
     closed mesh holds the cloth as the analytic box does; the barrier's queries are unchanged;
     a ray that passes within roundoff of an edge or vertex is thrown away and another direction
     tried (the degenerate cases that break parity). An open surface has no inside: either side,
     at distance >= thickness; the penalty keeps each vertex on the side it came from (ShellSide).
   - Safe step: with no thickness, 0.8 of the move's first crossing of the surface (a box query on
     the tree, then each triangle's exact crossing; a move along a triangle's plane, which crosses
     no plane, meets the triangle where it crosses an edge), as for the analytic shapes. With a thickness, conservative advancement (Li et al.
     2021, "Codimensional IPC", additive CCD without the additive part): the distance is
     1-Lipschitz, so moving by 0.9 d/|u| along u can never reach the shell; repeat until the step
     is covered or the gap is a tenth of the start's. The segment x -> x + t u then neither
     crosses the surface nor enters the shell.
   - Candidate cache (MeshCell below): the band's queries (distance, side, safe step) read the
     triangles near a grid cell's centre, collected once per cell, instead of the tree at every
     evaluation; the answers are exactly the tree's (the arguments are at MeshCell). */
#include <msim/contact.h>
#include <msim/mesh.h>
#include <msim/errors.h>
#include <msim/log.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_triangle_primitive.h>

typedef CGAL::Simple_cartesian<double>                  K;
typedef K::Point_3                                       Point;
typedef K::Triangle_3                                    Triangle;
typedef std::vector<Triangle>::const_iterator            TriIt;
typedef CGAL::AABB_triangle_primitive<K, TriIt>          Primitive;
typedef CGAL::AABB_traits<K, Primitive>                  Traits;
typedef CGAL::AABB_tree<Traits>                          Tree;

struct _n_MSimMeshObstacle {
  std::string           file;
  PetscReal             thickness = 0;
  std::vector<Triangle> tri;
  Tree                  tree;
  PetscBool             closed = PETSC_FALSE;
  PetscReal             lo[3], hi[3], diam = 0;
  PetscReal             ext = 0; /* the box's largest coordinate magnitude: a point's coordinates carry roundoff of that size */
  PetscReal             band = PETSC_MAX_REAL; /* the inside test only within this distance */
  /* the last query's answer: the next query's hint (the loops visit a rank's vertices in order,
     neighbours of a cloth or mesh follow each other, so it starts the tree's search close) */
  Tree::Point_and_primitive_id last;
  bool                         has_last = false;
  std::vector<Primitive::Id>   near; /* the cube query's triangles (kept: no allocation per query) */
  /* the candidate cache (MeshCell): cells of width cw from the origin org, keyed by their integer
     coordinates (21 bits each) in an open-addressing table of slots (a power of two, half full at
     most; std::unordered_map's node per cell and division per lookup were a fifth of a draped
     cloth's run, and a lookup is a cache miss: a slot holds what the queries read); a cell's
     candidates are pool[off, off + n), the triangles within band + smax of its centre (smax: the
     cell's half-diagonal) sorted by their distance dc to the centre; ref indexes refs (~0: none) */
  struct Candidate {
    const Triangle *T;
    PetscReal       dc;
  };
  struct Slot {
    uint64_t  key; /* ~0: empty */
    uint32_t  off, n, ref;
    PetscReal dz; /* the centre's distance to the surface (less roundoff): every triangle is at least dz from it (a coarse cell's: only where empty, else 0) */
  };
  struct Ref {
    PetscReal x[3]; /* a point of the cell whose side a ray has settled */
    bool      inside;
  };
  bool                   use_cells = true; /* MSimMeshObstacleSetCache (tests compare both) */
  PetscReal              cw = 0, smax = 0, org[3];
  std::vector<Slot>      slots;
  size_t                 ncells = 0;
  /* coarse cells of 8^3 cells, n = 1 where some triangle is within band of the coarse cell (the
     others are answered without a cell: most of a falling cloth's cells were empty, and they filled
     the table that every query reads) */
  std::vector<Slot>      cslots;
  size_t                 ncoarse = 0;
  uint64_t               last_key = ~(uint64_t)0; /* the last lookup (a safe step asks twice) */
  size_t                 last_slot = 0;
  std::vector<Candidate> pool;
  std::vector<Ref>       refs;
  /* the vertex queries' last answers (MSimMeshObstacleDistanceVertex): MEMO_SLOTS per vertex,
     each the point asked (bit for bit), its answer (d, n, H: H always computed) and when it was
     last used (0 or <= memo_epoch: empty) */
  struct Answer {
    PetscReal x[3];
    uint64_t  stamp;
    PetscReal d, n[3], H[9];
    int32_t   t; /* the nearest triangle where d is within band (-1: none), for its creases (CreaseContacts) */
  };
  std::vector<Answer> memo;
  uint64_t            clock = 0, memo_epoch = 0;
  /* per vertex: a point x of its last full query and a radius r such that every point within r
     of x is farther than band from the surface (0: none), and a second such ball (z, rz) around
     that query's cell's centre (MSimMeshObstacleDistanceVertex) */
  struct Far {
    PetscReal x[3], r, z[3], rz;
  };
  std::vector<Far> far;
  /* per vertex: the near set of its last full query within band (MSimMeshObstacleDistanceVertex's
     near shortcut): the point x, its cell's key and side, the triangles t[0, n) within r + tau / 2
     of x (r: its distance; indices into tri) in the cell's candidate order with their planes'
     signed distances s0 from x, the nearest one's place w in that list, and a lower bound L of every
     other triangle's distance from x (n = 0: none) */
  enum { NEAR_MAX = 8, PLANE_STRIDE = 16 };
  struct Near {
    PetscReal x[3], L, s0[NEAR_MAX];
    uint64_t  key;
    bool      inside;
    int       n, w;
    uint32_t  t[NEAR_MAX];
  };
  std::vector<Near> nearset;
  /* per triangle, PLANE_STRIDE numbers: its plane's unit normal and offset (the near side's quick
     test), then for each edge (a b, b c, c a) the unit normal and offset of the line in the plane,
     pointing out of the triangle (PlaneBound2) */
  std::vector<PetscReal> plane;
  /* concave creases (CreaseContacts): per triangle t and side s of its plane (0: its normal's side,
     1: the other), the triangles that can add a contact to a vertex whose nearest is t's face on
     that side, cr_tri[cr_at[4 t + 2 s], cr_at[4 t + 2 s + 1]), listed at t's first answer within
     band (CreasePartners; cr_at[4 t] = ~0: not yet) */
  std::vector<uint32_t> cr_at, cr_tri;
  /* per triangle: its vertices' indices in the file and, bit k, whether its edge k (vertex k to
     k + 1) is a boundary edge of the surface, in no other triangle (RimCorner) */
  std::vector<PetscInt>      tv;
  std::vector<unsigned char> rim;
  /* an open surface with an obtuse concave crease (FeatureSum): the features' weights, each feature
     counted at the first triangle holding it (0 elsewhere): edge k of triangle t (vertex k to k + 1)
     ew[3 t + k] = m - 1 for an edge of m triangles (a boundary edge 0), its vertex k vw[3 t + k] =
     1 - (its triangles) + (the sum of its edges' weights) (an interior vertex 1, a boundary one 0);
     bent[t]: an edge of t is a crease (its triangles not coplanar, or more than two); ie_near[t]:
     a bent triangle lies within 2 band of t (0: not yet known, 1: no, 2: yes), found at t's first
     answer within band */
  bool                       ie = false;
  std::vector<PetscReal>     ew, vw;
  std::vector<unsigned char> bent, ie_near;
  std::vector<uint32_t>      ie_hit; /* FeatureSum's triangles (kept: no allocation per query) */
  uint64_t          nvq[5] = {0, 0, 0, 0, 0}; /* vertex queries in the band's box: answered again, skipped as far, full, by the near set; of the far ones, by the centre's ball alone */
  /* the explicit penalty's queries (MSimMeshObstacleSetPenalty): a closed surface answers the
     inside at any depth (Deep); a shell keeps each vertex's side (Side, ShellSide) */
  bool penalty = false, sides = false; /* sides: penalty on an open surface (ShellSide) */
  struct Side {
    PetscReal m[3]; /* the unsigned gradient (x - p) / r at its last answer within band on its own side */
    char      state; /* SIDE_NEW, SIDE_OUT, SIDE_IN (within the shell or past the surface: m is the side it came from), SIDE_FAR */
  };
  enum { SIDE_NEW, SIDE_OUT, SIDE_IN, SIDE_FAR };
  std::vector<Side> side;
  PetscInt          lost = -1; /* the rank's first vertex that entered the shell from beyond band in one step (-1: none) */
  PetscReal         lost_x[3];
};

static PetscLogEvent MSIM_MeshCells; /* a cell's candidates collected (the cache's rebuilds) */

/* the absolute roundoff margin of the distances and plane offsets that the candidates' loops
   compare: far above a double's error at the mesh's size and at its coordinates' (ext) */
static inline PetscReal Roundoff(MSimMeshObstacle mo)
{
  return 1e-12 * (mo->diam + mo->band + mo->ext);
}

static const PetscReal CREASE_COS = 1e-6; /* right angles to roundoff; well below any obtuse crease's cosine */

/* closest point p on triangle (a, b, c) to x; region 0 face, 1 edge (e its unit direction), 2 vertex */
static void ClosestOnTriangle(const PetscReal x[3], const Triangle &T, PetscReal p[3], int *region, PetscReal e[3])
{
  PetscReal a[3], b[3], c[3], ab[3], ac[3], ap[3], bp[3], cp[3];
  for (int k = 0; k < 3; k++) {
    a[k]  = T[0][k], b[k] = T[1][k], c[k] = T[2][k];
    ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = x[k] - a[k], bp[k] = x[k] - b[k], cp[k] = x[k] - c[k];
  }
  auto dot  = [](const PetscReal *u, const PetscReal *v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
  auto set  = [&](const PetscReal *q, int r) { for (int k = 0; k < 3; k++) p[k] = q[k]; *region = r; };
  auto edge = [&](const PetscReal *s, const PetscReal *dir, PetscReal t) {
    PetscReal len = std::sqrt(dot(dir, dir));
    for (int k = 0; k < 3; k++) p[k] = s[k] + t * dir[k], e[k] = dir[k] / len;
    *region = 1;
  };
  const PetscReal d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return set(a, 2);
  const PetscReal d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return set(b, 2);
  const PetscReal vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return edge(a, ab, d1 / (d1 - d3));
  const PetscReal d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return set(c, 2);
  const PetscReal vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return edge(a, ac, d2 / (d2 - d6));
  const PetscReal va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    PetscReal bc[3] = {c[0] - b[0], c[1] - b[1], c[2] - b[2]};
    return edge(b, bc, (d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  const PetscReal den = 1 / (va + vb + vc), v = vb * den, w = vc * den;
  for (int k = 0; k < 3; k++) p[k] = a[k] + ab[k] * v + ac[k] * w;
  *region = 0;
}

/* Moller-Trumbore: the ray o + t d (t > 0) crosses T; *degenerate when it passes within roundoff
   of an edge or vertex, or runs nearly in the triangle's plane (parity is unreliable there) */
static bool RayHits(const PetscReal o[3], const PetscReal d[3], const Triangle &T, bool *degenerate)
{
  PetscReal e1[3], e2[3], s[3], pv[3], qv[3];
  for (int k = 0; k < 3; k++) e1[k] = T[1][k] - T[0][k], e2[k] = T[2][k] - T[0][k], s[k] = o[k] - T[0][k];
  pv[0] = d[1] * e2[2] - d[2] * e2[1], pv[1] = d[2] * e2[0] - d[0] * e2[2], pv[2] = d[0] * e2[1] - d[1] * e2[0];
  const PetscReal det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
  const PetscReal n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const PetscReal nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (std::abs(det) <= 1e-10 * nn) { /* in the plane's direction */
    *degenerate = true;
    return false;
  }
  const PetscReal u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
  qv[0] = s[1] * e1[2] - s[2] * e1[1], qv[1] = s[2] * e1[0] - s[0] * e1[2], qv[2] = s[0] * e1[1] - s[1] * e1[0];
  const PetscReal v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det, t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
  const PetscReal tol = 1e-9;
  if (t <= 0) return false;
  if (u < -tol || v < -tol || u + v > 1 + tol) return false;
  if (u < tol || v < tol || u + v > 1 - tol) {
    *degenerate = true;
    return false;
  }
  return true;
}

/* a closed surface: x inside by the parity of a ray's crossings, retried on a degenerate ray;
   *ok false when all six rays were degenerate (x on the surface, to roundoff) */
static bool Inside(MSimMeshObstacle mo, const PetscReal x[3], bool *ok = NULL)
{
  static const PetscReal dirs[6][3] = {
    {0.5773, 0.5774, 0.5775}, {-0.2673, 0.5345, 0.8018}, {0.8729, -0.2182, 0.4364}, {-0.4082, -0.8165, 0.4082}, {0.3015, 0.3015, -0.9045}, {-0.7071, 0.0, -0.7071}};
  if (ok) *ok = true;
  for (int c = 0; c < 3; c++)
    if (x[c] < mo->lo[c] || x[c] > mo->hi[c]) return false;
  for (const auto &d : dirs) {
    K::Ray_3                ray(Point(x[0], x[1], x[2]), K::Vector_3(d[0], d[1], d[2]));
    std::vector<Primitive::Id> hit;
    bool                    degenerate = false;
    int                     count      = 0;
    mo->tree.all_intersected_primitives(ray, std::back_inserter(hit));
    for (const auto &id : hit) count += RayHits(x, d, *id, &degenerate);
    if (!degenerate) return count % 2 == 1;
  }
  if (ok) *ok = false;
  return false; /* six degenerate rays: a point on the surface itself, which distance 0 refuses anyway */
}

/* The segment o -> o + d (|d| = dl) crosses T in its interior; *degenerate when the crossing is
   within roundoff of an edge, a vertex or an end of the segment (lentol: a length), or the segment
   runs nearly in T's plane: there the count may be wrong and the caller asks a ray instead */
static bool SegmentCrosses(const PetscReal o[3], const PetscReal d[3], PetscReal dl, const Triangle &T, PetscReal lentol, bool *degenerate)
{
  PetscReal e1[3], e2[3], s[3], pv[3], qv[3];
  for (int k = 0; k < 3; k++) e1[k] = T[1][k] - T[0][k], e2[k] = T[2][k] - T[0][k], s[k] = o[k] - T[0][k];
  pv[0] = d[1] * e2[2] - d[2] * e2[1], pv[1] = d[2] * e2[0] - d[0] * e2[2], pv[2] = d[0] * e2[1] - d[1] * e2[0];
  const PetscReal det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
  const PetscReal n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const PetscReal nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (std::abs(det) <= 1e-10 * nn * dl) {
    *degenerate = true;
    return false;
  }
  const PetscReal u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
  qv[0] = s[1] * e1[2] - s[2] * e1[1], qv[1] = s[2] * e1[0] - s[0] * e1[2], qv[2] = s[0] * e1[1] - s[1] * e1[0];
  const PetscReal v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det, t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
  const PetscReal tol = 1e-9, tl = lentol / dl;
  if (u < -tol || v < -tol || u + v > 1 + tol) return false;
  if (t < -tl || t > 1 + tl) return false;
  if (t < tl || t > 1 - tl || u < tol || v < tol || u + v > 1 - tol) {
    *degenerate = true;
    return false;
  }
  return true;
}

/* The candidate cache. The band's queries come from the vertices near the surface, at every
   energy, gradient and safe-step evaluation, each of which asked the tree for the triangles meeting
   a box (its traversal from the root, 40% of a draped cloth's run) and cast a ray for the side.
   Space is cut into cells of width cw (the band); the first query in a cell collects,
   once, the triangles within R = band + smax of its centre c (smax = the cell's half-diagonal, so
   |x - c| <= smax for every x of the cell), with their distances dc to c, sorted by dc. The cell
   plays the reference position of a per-vertex cache, shared by every vertex that passes through
   it (the queries carry a position, not a vertex, so the cache is keyed by place), and a vertex
   "moves more than the margin" when it enters another cell. Memory: the cells visited (near the
   surface: the callers ask only within band of its box) times their candidates, in a hash map;
   cleared when the pool passes 2^22 candidates (a cloth that wanders over a large surface).
   Why the answers are exact, with s = |x - c| <= smax:
   - nearest: a triangle T within band of x is within band + s <= R of c (dist(c, T) <= |c - x| +
     dist(x, T)), so it is a candidate; and every T has dist(x, T) >= dc(T) - s (the same
     inequality the other way), so once dc - s exceeds the nearest distance found so far (or band,
     before one is found within band) no later candidate is nearer or within band. The nearest
     within band is the tree's cube query's (only the tie between triangles at the same distance
     may go to another triangle with the same point, distance and normal).
   - side: the cell's reference point ref got its side from a ray (as without the cache). x is on
     ref's side unless the segment ref -> x crosses the closed surface, and an odd number of
     crossings (each through a triangle's interior) means the other side. Every point of the
     segment is within max(|ref - c|, |x - c|) <= smax of c (a ball is convex), so only candidates
     with dc up to that can cross it. A degenerate crossing (near an edge, a vertex or the segment's
     ends, or along a triangle's plane) sends x to its own ray, as does any x within roundoff of the
     surface (1e-9 of its diameter, where a ray's answer is roundoff too); a ref is only taken
     farther than that. The argument is geometric: it holds for any move, so it needs neither the
     barrier nor the line search to keep vertices outside.
   - safe step: when the move's box lies within R of c, every triangle meeting the box is a
     candidate with dc up to the box's farthest point from c; those candidates go through CGAL's
     own triangle-box test, the one the tree applies to its leaves, so the triangles tested for a
     crossing are the tree query's, and the hit time is the same minimum. */
/* a cell as the queries see it: its centre, its candidates pool[off, off + n) and its slot
   (~0 in an empty coarse cell: no candidates, no side, and the safe step asks the tree) */
struct MeshCellT {
  PetscReal c[3];
  size_t    off, n, slot;
  PetscReal margin; /* an empty coarse cell (slot ~0): x's distance to its box's nearest face */
  PetscReal z[3], dz; /* a point near x (the fine or empty coarse cell's centre) and its distance to the surface less roundoff */
};

/* x's distance to the surface by the tree (its closest point), less a roundoff margin: a lower
   bound of every triangle's distance from x, for the far skip's balls (FarBall) */
static PetscReal TreeDistanceBelow(MSimMeshObstacle mo, const PetscReal x[3])
{
  const Point     pq(x[0], x[1], x[2]);
  const Point     p = mo->tree.closest_point(pq);
  const PetscReal d = std::sqrt(CGAL::squared_distance(pq, p));
  return d - 1e-12 * (mo->diam + mo->band + d);
}

/* the key's slot in the table: its own, or the empty one where it would go (Fibonacci hashing,
   linear probing) */
static size_t HashSlot(const std::vector<_n_MSimMeshObstacle::Slot> &slots, uint64_t key)
{
  const size_t mask = slots.size() - 1;
  size_t       s    = (size_t)((key * 0x9E3779B97F4A7C15ull) >> 32) & mask;
  while (slots[s].key != key && slots[s].key != ~(uint64_t)0) s = (s + 1) & mask;
  return s;
}

/* room for one more key in a table kept at most half full */
static void HashGrow(std::vector<_n_MSimMeshObstacle::Slot> &slots, size_t count)
{
  if (2 * (count + 1) <= slots.size()) return;
  std::vector<_n_MSimMeshObstacle::Slot> old;
  old.swap(slots);
  slots.assign(2 * old.size(), {~(uint64_t)0, 0, 0, 0, 0});
  for (const auto &o : old)
    if (o.key != ~(uint64_t)0) slots[HashSlot(slots, o.key)] = o;
}

static void ClearCells(MSimMeshObstacle mo)
{
  mo->slots.assign(1024, {~(uint64_t)0, 0, 0, 0, 0});
  mo->cslots.assign(1024, {~(uint64_t)0, 0, 0, 0, 0});
  mo->ncells = mo->ncoarse = 0;
  mo->last_key = ~(uint64_t)0;
  mo->pool.clear();
  mo->refs.clear();
}

/* A cell's candidates from the tree: the triangles within lim = R + slack of the centre c. Each lies
   in the cube of half-width lim around c, so the tree's boxes and the triangles' own boxes that miss
   the cube hold none, and the rest are kept by their distance dc <= lim: the same set, and sorted
   by (dc, triangle) the same list, as the exact triangle-cube test (CGAL's all_intersected_primitives)
   followed by the distance gave, without that test (half of a cell's collection) */
struct CollectTraits {
  MSimMeshObstacle mo;
  const PetscReal *c;
  PetscReal        lim;
  bool             go_further() const { return true; }
  bool             do_intersect(const CGAL::Bbox_3 &q, const CGAL::AABB_node<Traits> &node) const { return CGAL::do_overlap(q, node.bbox()); }
  void             intersection(const CGAL::Bbox_3 &q, const Primitive &pr)
  {
    const Triangle &T = *pr.id();
    if (!CGAL::do_overlap(q, T.bbox())) return;
    PetscReal p[3], e[3], dc = 0;
    int       region;
    ClosestOnTriangle(c, T, p, &region, e);
    for (int k = 0; k < 3; k++) dc += (c[k] - p[k]) * (c[k] - p[k]);
    dc = std::sqrt(dc);
    if (dc <= lim) mo->pool.push_back({&T, dc});
  }
};

/* x's cell (collected on its first query); false outside the grid, where the tree answers */
static bool MeshCell(MSimMeshObstacle mo, const PetscReal x[3], MeshCellT *C)
{
  const int64_t nmax = ((int64_t)1 << 21) - 1;
  int64_t       ijk[3];
  uint64_t      key = 0, ckey = 0;
  for (int c = 0; c < 3; c++) {
    const PetscReal f = std::floor((x[c] - mo->org[c]) / mo->cw);
    if (!(f >= 0 && f <= (PetscReal)nmax)) return false; /* outside the grid (or not finite) */
    ijk[c] = (int64_t)f;
    key |= (uint64_t)ijk[c] << (21 * c);
    ckey |= (uint64_t)(ijk[c] >> 3) << (21 * c);
    C->c[c] = mo->org[c] + ((PetscReal)ijk[c] + 0.5) * mo->cw;
  }
  const PetscReal slack = 1e-9 * (mo->diam + mo->band + mo->smax) + Roundoff(mo);
  size_t          slot  = key == mo->last_key ? mo->last_slot : HashSlot(mo->slots, key);
  if (mo->slots[slot].key != key) {
    /* the coarse cell: no triangle meets its box widened by band (a triangle within band of x meets
       the cube of half-width band around x, inside that box) means none is within band of x */
    size_t cs = HashSlot(mo->cslots, ckey);
    if (mo->cslots[cs].key != ckey) {
      PetscReal lo[3], hi[3];
      for (int c = 0; c < 3; c++) lo[c] = mo->org[c] + (PetscReal)((ijk[c] >> 3) << 3) * mo->cw - mo->band - slack, hi[c] = lo[c] + 8 * mo->cw + 2 * (mo->band + slack);
      HashGrow(mo->cslots, mo->ncoarse);
      cs              = HashSlot(mo->cslots, ckey);
      mo->cslots[cs] = {ckey, 0, mo->tree.do_intersect(K::Iso_cuboid_3(Point(lo[0], lo[1], lo[2]), Point(hi[0], hi[1], hi[2]))) ? 1u : 0u, 0, 0};
      if (!mo->cslots[cs].n) { /* empty: its centre's distance, for the far skip's ball (every point of the coarse cell asks it at most once) */
        PetscReal cc[3];
        for (int c = 0; c < 3; c++) cc[c] = mo->org[c] + ((PetscReal)((ijk[c] >> 3) << 3) + 4) * mo->cw;
        mo->cslots[cs].dz = TreeDistanceBelow(mo, cc);
      }
      mo->ncoarse++;
    }
    if (!mo->cslots[cs].n) {
      C->off = C->n = 0, C->slot = ~(size_t)0, C->margin = PETSC_MAX_REAL;
      for (int c = 0; c < 3; c++) {
        const PetscReal lo = mo->org[c] + (PetscReal)((ijk[c] >> 3) << 3) * mo->cw;
        C->margin = PetscMin(C->margin, PetscMin(x[c] - lo, lo + 8 * mo->cw - x[c]));
      }
      C->margin = PetscMax(C->margin, 0.0);
      for (int c = 0; c < 3; c++) C->z[c] = mo->org[c] + ((PetscReal)((ijk[c] >> 3) << 3) + 4) * mo->cw;
      C->dz = mo->cslots[cs].dz;
      return true;
    }
    /* a new cell: its candidates */
    PetscCallAbort(PETSC_COMM_SELF, PetscLogEventBegin(MSIM_MeshCells, 0, 0, 0, 0));
    if (mo->pool.size() > ((size_t)1 << 22) || mo->ncells > ((size_t)1 << 21)) ClearCells(mo); /* a cloth wandering over a large surface: start afresh */
    HashGrow(mo->slots, mo->ncells);
    slot              = HashSlot(mo->slots, key);
    const PetscReal R = mo->band + mo->smax;
    const size_t    off = mo->pool.size();
    CollectTraits collect{mo, C->c, R + slack};
    mo->tree.traversal(CGAL::Bbox_3(C->c[0] - R - slack, C->c[1] - R - slack, C->c[2] - R - slack, C->c[0] + R + slack, C->c[1] + R + slack, C->c[2] + R + slack), collect);
    std::sort(mo->pool.begin() + off, mo->pool.end(), [](const _n_MSimMeshObstacle::Candidate &a, const _n_MSimMeshObstacle::Candidate &b) { return a.dc < b.dc || (a.dc == b.dc && a.T < b.T); });
    /* the centre's distance: its nearest candidate's (the candidates hold every triangle within R),
       or where it has none, the tree's */
    const PetscReal dz = mo->pool.size() > off ? mo->pool[off].dc - 1e-12 * (mo->diam + mo->band + mo->pool[off].dc) : TreeDistanceBelow(mo, C->c);
    mo->slots[slot] = {key, (uint32_t)off, (uint32_t)(mo->pool.size() - off), ~(uint32_t)0, dz};
    mo->ncells++;
    PetscCallAbort(PETSC_COMM_SELF, PetscLogEventEnd(MSIM_MeshCells, 0, 0, 0, 0));
  }
  mo->last_key = key, mo->last_slot = slot;
  C->off = mo->slots[slot].off, C->n = mo->slots[slot].n, C->slot = slot;
  for (int c = 0; c < 3; c++) C->z[c] = C->c[c];
  C->dz = mo->slots[slot].dz;
  return true;
}

/* the side of x (in cell C, at distance r from the surface) by the argument above */
static bool CellInside(MSimMeshObstacle mo, const MeshCellT &C, const PetscReal x[3], PetscReal r)
{
  const PetscReal tol = 1e-9 * mo->diam;
  const uint32_t  ri  = mo->slots[C.slot].ref;
  if (r <= tol) return Inside(mo, x);
  if (ri != ~(uint32_t)0) {
    const _n_MSimMeshObstacle::Ref &ref = mo->refs[ri];
    PetscReal                       d[3], dl = 0, sx = 0, sr = 0;
    for (int c = 0; c < 3; c++) {
      d[c] = x[c] - ref.x[c];
      dl += d[c] * d[c], sx += (x[c] - C.c[c]) * (x[c] - C.c[c]), sr += (ref.x[c] - C.c[c]) * (ref.x[c] - C.c[c]);
    }
    if (dl == 0) return ref.inside;
    dl = std::sqrt(dl);
    const PetscReal reach = std::sqrt(PetscMax(sx, sr)) + tol;
    bool            degenerate = false;
    int             count      = 0;
    for (size_t k = C.off; k < C.off + C.n && mo->pool[k].dc <= reach && !degenerate; k++) count += SegmentCrosses(ref.x, d, dl, *mo->pool[k].T, tol, &degenerate);
    if (!degenerate) return ref.inside != (count % 2 == 1);
    return Inside(mo, x);
  }
  bool       ok;
  const bool in = Inside(mo, x, &ok);
  if (ok) {
    mo->slots[C.slot].ref = (uint32_t)mo->refs.size();
    mo->refs.push_back({{x[0], x[1], x[2]}, in});
  }
  return in;
}

static PetscErrorCode ReadOnRankZero(const char file[], std::vector<PetscReal> &x, std::vector<PetscInt> &tri)
{
  MSimMesh m;

  PetscFunctionBeginUser;
  PetscCall(MSimMeshReadFile(file, 3, &m));
  PetscCheck(m.nper == 3, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "-msim_contact_mesh %s: holds tets; an obstacle is a triangle surface", file);
  PetscCall(MSimMeshCheck(&m)); /* malformed cells and zero-area triangles: one line naming the file */
  PetscCall(MSimMeshPrintNotes(&m));
  x   = m.x;
  tri = m.cell;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* FeatureSum's data (_n_MSimMeshObstacle's ie, ew, vw, bent) from the file's vertices x, triangles
   tri and each edge's triangle count. An edge's two triangles (i, j, a) and (j, i, b) open at the
   angle theta with cos theta = uA . uB, uA and uB the unit directions from the edge's line to a and
   b: -1 flat, 0 a right angle (an open box's walls), between them an obtuse crease, concave on the
   side it opens to (an open surface is seen from both). Only such a surface takes the features'
   sum: the others (every closed surface, the open box, the fin) keep the nearest face and
   CreaseContacts, their numbers unchanged */
static PetscErrorCode FeatureWeights(MSimMeshObstacle mo, const std::vector<PetscReal> &x, const std::vector<PetscInt> &tri, const std::map<std::pair<PetscInt, PetscInt>, int> &edges)
{
  const size_t                                    nt = tri.size() / 3;
  std::map<std::pair<PetscInt, PetscInt>, size_t> first; /* an edge's first triangle */
  std::map<PetscInt, PetscReal>                   vsum;  /* a vertex's 1 - triangles + edges' weights */
  std::map<PetscInt, size_t>                      vfirst;

  PetscFunctionBeginUser;
  if (mo->closed) PetscFunctionReturn(PETSC_SUCCESS);
  mo->ew.assign(3 * nt, 0), mo->vw.assign(3 * nt, 0), mo->bent.assign(nt, 0);
  auto apex = [&](size_t t, PetscInt i, PetscInt j) { /* the vertex of t off the edge i j */
    for (int k = 0; k < 3; k++)
      if (tri[3 * t + k] != i && tri[3 * t + k] != j) return tri[3 * t + k];
    return (PetscInt)-1;
  };
  for (size_t t = 0; t < nt; t++) {
    for (int k = 0; k < 3; k++) {
      const PetscInt i = tri[3 * t + k], j = tri[3 * t + (k + 1) % 3];
      const auto     key = std::make_pair(PetscMin(i, j), PetscMax(i, j));
      const int      m   = edges.at(key);
      vsum[i] += vfirst.insert({i, t}).second ? 0.0 : -1.0; /* 1 for the vertex, -1 for each triangle */
      const auto f = first.insert({key, t});
      if (!f.second) { /* the edge's second (or later) triangle: t and its first */
        if (m != 2) mo->bent[t] = mo->bent[f.first->second] = 1;
        else {
          const PetscInt a = apex(f.first->second, i, j), b = apex(t, i, j);
          PetscReal      e[3], ua[3], ub[3], ee = 0, pa = 0, pb = 0, la = 0, lb = 0, c = 0;
          for (int q = 0; q < 3; q++) e[q] = x[3 * j + q] - x[3 * i + q], ee += e[q] * e[q];
          for (int q = 0; q < 3; q++) pa += (x[3 * a + q] - x[3 * i + q]) * e[q], pb += (x[3 * b + q] - x[3 * i + q]) * e[q];
          for (int q = 0; q < 3; q++) {
            ua[q] = x[3 * a + q] - x[3 * i + q] - pa / ee * e[q], ub[q] = x[3 * b + q] - x[3 * i + q] - pb / ee * e[q];
            la += ua[q] * ua[q], lb += ub[q] * ub[q];
          }
          for (int q = 0; q < 3; q++) c += ua[q] * ub[q] / std::sqrt(la * lb);
          if (c > -1 + 1e-9) mo->bent[t] = mo->bent[f.first->second] = 1;
          if (c > -1 + 1e-9 && c < -CREASE_COS) mo->ie = true;
        }
        continue;
      }
      mo->ew[3 * t + k] = m - 1;
      vsum[i] += m - 1, vsum[j] += m - 1;
    }
  }
  for (const auto &v : vfirst)
    for (int k = 0; k < 3; k++)
      if (tri[3 * v.second + k] == v.first) mo->vw[3 * v.second + k] = vsum[v.first];
  if (!mo->ie) mo->ew.clear(), mo->vw.clear(), mo->bent.clear();
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshObstacleCreate(MPI_Comm comm, const char file[], PetscReal thickness, MSimMeshObstacle *mesh)
{
  std::vector<PetscReal> x;
  std::vector<PetscInt>  tri;
  PetscInt               n[2] = {0, 0};
  PetscMPIInt            rank;

  PetscFunctionBeginUser;
  if (!MSIM_MeshCells) PetscCall(PetscLogEventRegister("MSimMeshCells", MSIM_CLASSID, &MSIM_MeshCells));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(MSimCallOnRankZero(comm, [&]() { return ReadOnRankZero(file, x, tri); }));
  n[0] = (PetscInt)x.size(), n[1] = (PetscInt)tri.size();
  PetscCallMPI(MPI_Bcast(n, 2, MPIU_INT, 0, comm));
  x.resize(n[0]), tri.resize(n[1]);
  PetscCallMPI(MPI_Bcast(x.data(), (PetscMPIInt)n[0], MPIU_REAL, 0, comm));
  PetscCallMPI(MPI_Bcast(tri.data(), (PetscMPIInt)n[1], MPIU_INT, 0, comm));

  MSimMeshObstacle mo = new _n_MSimMeshObstacle();
  mo->file            = file;
  mo->thickness       = thickness;
  for (int c = 0; c < 3; c++) mo->lo[c] = PETSC_MAX_REAL, mo->hi[c] = -PETSC_MAX_REAL;
  for (size_t v = 0; v < x.size() / 3; v++)
    for (int c = 0; c < 3; c++) mo->lo[c] = PetscMin(mo->lo[c], x[3 * v + c]), mo->hi[c] = PetscMax(mo->hi[c], x[3 * v + c]);
  mo->diam = std::sqrt((mo->hi[0] - mo->lo[0]) * (mo->hi[0] - mo->lo[0]) + (mo->hi[1] - mo->lo[1]) * (mo->hi[1] - mo->lo[1]) + (mo->hi[2] - mo->lo[2]) * (mo->hi[2] - mo->lo[2]));
  for (int c = 0; c < 3; c++) mo->ext = PetscMax(mo->ext, PetscMax(std::abs(mo->lo[c]), std::abs(mo->hi[c])));
  mo->tri.reserve(tri.size() / 3);
  for (size_t t = 0; t < tri.size() / 3; t++) {
    const PetscReal *a = &x[3 * tri[3 * t]], *b = &x[3 * tri[3 * t + 1]], *c = &x[3 * tri[3 * t + 2]];
    mo->tri.emplace_back(Point(a[0], a[1], a[2]), Point(b[0], b[1], b[2]), Point(c[0], c[1], c[2]));
  }
  /* closed: every (undirected) edge in exactly two triangles */
  std::map<std::pair<PetscInt, PetscInt>, int> edges;
  for (size_t t = 0; t < tri.size() / 3; t++)
    for (int k = 0; k < 3; k++) {
      PetscInt i = tri[3 * t + k], j = tri[3 * t + (k + 1) % 3];
      edges[{PetscMin(i, j), PetscMax(i, j)}]++;
    }
  mo->closed = PETSC_TRUE;
  for (const auto &e : edges)
    if (e.second != 2) mo->closed = PETSC_FALSE;
  mo->tv = tri;
  mo->rim.assign(tri.size() / 3, 0);
  for (size_t t = 0; t < tri.size() / 3; t++)
    for (int k = 0; k < 3; k++) {
      PetscInt i = tri[3 * t + k], j = tri[3 * t + (k + 1) % 3];
      if (edges[{PetscMin(i, j), PetscMax(i, j)}] == 1) mo->rim[t] |= (unsigned char)(1 << k);
    }
  PetscCall(FeatureWeights(mo, x, tri, edges));
  mo->plane.resize(_n_MSimMeshObstacle::PLANE_STRIDE * mo->tri.size());
  for (size_t t = 0; t < mo->tri.size(); t++) {
    PetscReal *pl = &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * t], v[3][3];
    for (int k = 0; k < 3; k++)
      for (int c = 0; c < 3; c++) v[k][c] = mo->tri[t].vertex(k)[c];
    const K::Vector_3 fn = CGAL::cross_product(mo->tri[t].vertex(1) - mo->tri[t].vertex(0), mo->tri[t].vertex(2) - mo->tri[t].vertex(0));
    const PetscReal   l  = std::sqrt(fn.squared_length());
    /* the computed normal's direction is off by about eps lmax^2 / |fn| (a cross product of two
       long edges, |fn| twice the area), so the plane and the edges' lines miss a thin triangle by
       that times |x - a|: past the bounds' margin (1e-12 of the mesh's size) once |fn| < ~1e-4
       lmax^2. A triangle thinner than |fn| = 1e-2 lmax^2 (its height under 1% of its longest edge:
       the loader accepts down to 1e-12) keeps all-zero numbers, a bound of 0 that never passes it
       over: it always takes its closest point and its exact crossing test (a sliver 1e-6 off its
       long edge gave a bound 4e-10 above its distance, and a nearer triangle was passed over) */
    PetscReal lmax2 = 0;
    for (int k = 0; k < 3; k++) lmax2 = PetscMax(lmax2, (mo->tri[t].vertex((k + 1) % 3) - mo->tri[t].vertex(k)).squared_length());
    if (!(l >= 1e-2 * lmax2)) {
      for (int c = 0; c < _n_MSimMeshObstacle::PLANE_STRIDE; c++) pl[c] = 0;
      continue;
    }
    for (int c = 0; c < 3; c++) pl[c] = fn[c] / l;
    pl[3] = -(pl[0] * v[0][0] + pl[1] * v[0][1] + pl[2] * v[0][2]);
    for (int k = 0; k < 3; k++) { /* edge v_k -> v_k+1: (v_k+1 - v_k) x normal points out of a counterclockwise triangle */
      const PetscReal *a = v[k], *b = v[(k + 1) % 3], d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      PetscReal       *m = pl + 4 * (k + 1);
      m[0]               = d[1] * pl[2] - d[2] * pl[1], m[1] = d[2] * pl[0] - d[0] * pl[2], m[2] = d[0] * pl[1] - d[1] * pl[0];
      const PetscReal ml = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
      for (int c = 0; c < 3; c++) m[c] /= ml;
      m[3] = -(m[0] * a[0] + m[1] * a[1] + m[2] * a[2]);
    }
  }
  mo->tree.insert(mo->tri.begin(), mo->tri.end());
  mo->tree.build();
  mo->tree.accelerate_distance_queries();
  *mesh = mo;
  PetscFunctionReturn(PETSC_SUCCESS);
}

void MSimMeshObstacleDestroy(MSimMeshObstacle *mesh)
{
  delete *mesh;
  *mesh = NULL;
}

void MSimMeshObstacleSetBand(MSimMeshObstacle mo, PetscReal band)
{
  mo->band       = band;
  mo->memo_epoch = mo->clock; /* the answers depend on the band */
  mo->far.clear();
  mo->nearset.clear(); /* their cells and sets are the band's */
  ClearCells(mo);
  mo->cr_at.assign(4 * mo->tri.size(), ~(uint32_t)0); /* the partners are the band's */
  mo->cr_tri.clear();
  if (mo->ie) mo->ie_near.assign(mo->tri.size(), 0); /* as the partners */
  if (!(band > 0 && band < PETSC_MAX_REAL)) return;
  /* cells one band wide (half-diagonal 0.87 band; a quarter band before the per-vertex queries,
     which now ask the cells ~8 x less often, so that the cells' collections weigh more: 101 x 101
     PD-10 on the 20,480-triangle ball 36,860 -> 8,974 collections, runs/contact/README.md), wider
     where the box over 2^21 cells would not fit the keys */
  PetscReal ext = 0;
  for (int c = 0; c < 3; c++) ext = PetscMax(ext, mo->hi[c] - mo->lo[c]);
  mo->cw = PetscMax(band, (ext + 2 * band) / (PetscReal)(((int64_t)1 << 21) - 8));
  mo->smax = 0.5 * std::sqrt(3.0) * mo->cw;
  for (int c = 0; c < 3; c++) mo->org[c] = mo->lo[c] - band - mo->cw;
}

void MSimMeshObstacleSetCache(MSimMeshObstacle mo, PetscBool use)
{
  mo->use_cells = use ? true : false;
}

void MSimMeshObstacleVertexCounts(MSimMeshObstacle mo, PetscInt64 counts[5])
{
  for (int k = 0; k < 5; k++) counts[k] = (PetscInt64)mo->nvq[k];
}

void MSimMeshObstacleInfo(MSimMeshObstacle mo, const char **file, PetscInt *ntri, PetscBool *closed)
{
  if (file) *file = mo->file.c_str();
  if (ntri) *ntri = (PetscInt)mo->tri.size();
  if (closed) *closed = mo->closed;
}

/* x's offset q from the surface's bounding box (0 inside it) and |q|^2: x - clamp(x, lo, hi), the
   same numbers as the branches x < lo ? x - lo : (x > hi ? x - hi : 0) (inside, x - x = +0), without
   them (every query starts here, and the branches were its costliest line) */
static inline PetscReal BoxOffset(MSimMeshObstacle mo, const PetscReal x[3], PetscReal q[3])
{
  PetscReal db2 = 0;
  for (int c = 0; c < 3; c++) {
    q[c] = x[c] - std::min(std::max(x[c], mo->lo[c]), mo->hi[c]);
    db2 += q[c] * q[c];
  }
  return db2;
}

/* cube_bound: beyond the band, the band itself may stand in as a lower bound (see below); the
   conservative advancement of MSimMeshObstacleSafeStep needs the true distance there (a constant
   lower bound would advance by 0.9 dhat a step and cut a long move short) */
/* the answer from x's nearest point p on triangle T (region, e: ClosestOnTriangle's) and its side
   (sign): n, H and the distance, the same operations for Distance and the near shortcut */
static PetscReal Answer(MSimMeshObstacle mo, const PetscReal q[3], PetscReal r, PetscReal sign, int region, const PetscReal e[3], const Triangle *T, PetscReal n[3], PetscReal H[9])
{
  if (r > 0)
    for (int c = 0; c < 3; c++) n[c] = sign * q[c] / r;
  else { /* on the surface: the triangle's normal */
    const K::Vector_3 fn = CGAL::cross_product(T->vertex(1) - T->vertex(0), T->vertex(2) - T->vertex(0));
    const PetscReal   l  = std::sqrt(fn.squared_length());
    for (int c = 0; c < 3; c++) n[c] = fn[c] / l;
  }
  if (H) {
    for (int k = 0; k < 9; k++) H[k] = 0;
    if (region > 0 && r > 0)
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) H[3 * a + b] = sign * ((a == b) - n[a] * n[b] - (region == 1 ? e[a] * e[b] : 0.0)) / r;
  }
  return sign * r - mo->thickness;
}

/* how far the point p of triangle pl's plane lies outside the triangle's farthest edge line (<= 0:
   p is in the triangle) */
static inline PetscReal EdgeExcess(const PetscReal *pl, const PetscReal p[3])
{
  PetscReal o = -PETSC_MAX_REAL;
  for (int k = 1; k < 4; k++) o = PetscMax(o, pl[4 * k] * p[0] + pl[4 * k + 1] * p[1] + pl[4 * k + 2] * p[2] + pl[4 * k + 3]);
  return o;
}

/* a lower bound of the squared distance from x to triangle pl (its plane's numbers, h: x's signed
   distance to the plane): the triangle lies in the plane, within each edge's line, so x's foot is at
   least its distance outside any of the three lines from it (exact where the foot is inside the
   triangle or the nearest point is on an edge) */
static inline PetscReal PlaneBound2(const PetscReal *pl, const PetscReal x[3], PetscReal h)
{
  const PetscReal o = PetscMax(0.0, EdgeExcess(pl, x));
  return h * h + o * o;
}

/* the cell key of x (MeshCell's), false outside the grid */
static inline bool CellKey(MSimMeshObstacle mo, const PetscReal x[3], uint64_t *key)
{
  const int64_t nmax = ((int64_t)1 << 21) - 1;
  *key               = 0;
  for (int c = 0; c < 3; c++) {
    const PetscReal f = std::floor((x[c] - mo->org[c]) / mo->cw);
    if (!(f >= 0 && f <= (PetscReal)nmax)) return false;
    *key |= (uint64_t)(int64_t)f << (21 * c);
  }
  return true;
}

/* the penalty's answer at a point x inside a closed surface, deeper than band: its true distance
   (the tree's closest point, the nearest triangle's region as Distance's), negative */
static __attribute__((noinline)) PetscReal Deep(MSimMeshObstacle mo, const PetscReal x[3], PetscReal n[3], PetscReal H[9])
{
  const auto hit = mo->tree.closest_point_and_primitive(Point(x[0], x[1], x[2]));
  PetscReal  p[3], e[3] = {0, 0, 0}, q[3], r = 0;
  int        region;
  ClosestOnTriangle(x, *hit.second, p, &region, e);
  for (int c = 0; c < 3; c++) q[c] = x[c] - p[c], r += q[c] * q[c];
  return Answer(mo, q, std::sqrt(r), -1.0, region, e, &*hit.second, n, H);
}

static PetscReal Distance(MSimMeshObstacle mo, const PetscReal x[3], PetscReal n[3], PetscReal H[9], bool cube_bound, PetscReal *lower = NULL, _n_MSimMeshObstacle::Near *ns = NULL, PetscReal zball[4] = NULL, int32_t *tri = NULL)
{
  if (tri) *tri = -1; /* the nearest triangle, where within band */
  /* beyond the band around the surface's bounding box, the distance to the box is a lower bound
     of the distance to the surface (which lies in the box), and it is all the callers need there:
     the barrier, friction and the contact force skip a vertex farther than dhat < band, a safe step
     shorter than the bound is the whole step, and conservative advancement stays safe on a lower
     bound. Skips the tree's query for most of a cloth draped over a small obstacle. */
  PetscReal q[3];
  const PetscReal db2 = BoxOffset(mo, x, q);
  if (lower) *lower = 0; /* *lower: a lower bound of x's distance to the surface, where it is > band (else 0) */
  if (zball) zball[3] = 0; /* beyond band in a cell: its centre z and z's distance less roundoff (else 0) */
  if (ns) ns->n = 0, ns->w = -1;
  if (db2 > mo->band * mo->band) {
    const PetscReal db = std::sqrt(db2);
    for (int c = 0; c < 3; c++) n[c] = q[c] / db;
    if (H)
      for (int k = 0; k < 9; k++) H[k] = 0;
    if (lower) *lower = db;
    return db - mo->thickness;
  }
  /* inside the box: the triangles that meet the cube of half-width band around x. The nearest
     one, if within band, lies in the cube's inscribed ball, so it is among them; if none of them is
     within band, neither is any other triangle, and band - thickness (= dhat: barrier, friction
     and contact force are zero there) is a lower bound the callers take as for the box above. A
     cube query discards the tree's far boxes at once and finds the few triangles near a contact
     vertex, where CGAL's closest-point search must settle the nearest triangle from scratch (90%
     of a cloth draped on a 20,480-triangle ball was that search, perf). */
  PetscReal  p[3], e[3] = {0, 0, 0}, r = 0;
  int        region;
  const Triangle *T = NULL;
  MeshCellT       cell, *C = NULL; /* the cache's cell of x, where the cube query is answered from it */
  if (cube_bound && mo->band < PETSC_MAX_REAL) {
    const PetscReal b = mo->band;
    PetscReal       best = PETSC_MAX_REAL, rbest = b;
    auto            consider = [&](const Triangle &Tk) {
      PetscReal pk[3], ek[3] = {0, 0, 0}, rk = 0;
      int       regk;
      ClosestOnTriangle(x, Tk, pk, &regk, ek);
      for (int c = 0; c < 3; c++) rk += (x[c] - pk[c]) * (x[c] - pk[c]);
      if (rk < best) {
        best = rk, T = &Tk, region = regk, rbest = PetscMin(b, std::sqrt(rk));
        for (int c = 0; c < 3; c++) p[c] = pk[c], e[c] = ek[c];
      }
    };
    if (mo->use_cells && MeshCell(mo, x, &cell)) C = &cell;
    PetscReal lb = b; /* what the candidates show of the distance beyond band (MSimMeshObstacleDistanceVertex) */
    if (C) { /* the candidates by their distance to the centre, while they can still be nearer */
      /* s: |x - c| plus roundoff (Roundoff: the coordinates' too, a mesh far from the origin has
         larger absolute errors in the distances and plane offsets computed here). A candidate is
         at least dc - s from x: the loops stop where that exceeds what they look for, and s rounded
         up makes them look a little further */
      const PetscReal peps = Roundoff(mo);
      PetscReal       s    = 0;
      for (int c = 0; c < 3; c++) s += (x[c] - C->c[c]) * (x[c] - C->c[c]);
      s = std::sqrt(s) + peps;
      size_t k = C->off;
      /* a candidate whose plane, or whose bound from its plane and edges' lines (PlaneBound2), is
         farther than rbest (less roundoff) is farther too and is passed over: it could only have
         been picked beyond band, where the pick changes no answer and rbest stays band; that bound
         bounds it below. A vertex just beyond band, the most
         frequent full query once the far balls took the rest, looked at every triangle within about
         band + |x - c| of the centre (~50 closest points on the benchmark ball, whose nearby facets'
         planes are all farther than band) */
      PetscReal below = PETSC_MAX_REAL; /* the passed-over candidates' least bound */
      for (; k < C->off + C->n && mo->pool[k].dc - s <= rbest; k++) {
        const Triangle  *Tk = mo->pool[k].T;
        const PetscReal *pl = &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * (size_t)(Tk - mo->tri.data())];
        const PetscReal  hs = pl[0] * x[0] + pl[1] * x[1] + pl[2] * x[2] + pl[3], h = std::abs(hs) - peps;
        if (h > rbest) {
          below = PetscMin(below, h);
          continue;
        }
        const PetscReal hb = std::sqrt(PlaneBound2(pl, x, hs)) - peps; /* the plane and the edges' lines */
        if (hb > rbest) below = PetscMin(below, hb);
        else consider(*Tk);
      }
      /* every triangle is at least min(dc, R) - |x - c| from x (R: the cell's reach, the
         non-candidates beyond it), those looked at their own distance; an empty coarse cell: band
         plus x's margin in it */
      if (C->slot == ~(size_t)0) lb = b + C->margin;
      else lb = PetscMin(PetscMin(std::sqrt(best), below), PetscMin(k < C->off + C->n ? mo->pool[k].dc : PETSC_MAX_REAL, b + mo->smax) - s);
      if (ns && T && best <= b * b && C->slot != ~(size_t)0) {
        /* the near set: the candidates within r + tau / 2 of x (r = sqrt(best)), found by looking on
           to r + tau; the others are farther than L, the least of the rest's distances and of the
           bound above for those not looked at. The loop above looked at a prefix of the same order
           that holds every nearest triangle, so looking on changes no answer. */
        /* tau: a set small enough to test at every iterate against a margin L - r that a contact
           vertex's moves between full queries stay within: 0.1 band (0.7 mm on the benchmark). The
           near answer takes a closest point only for the set's triangles that its bounds cannot
           rule out (NearAnswer), so a set member costs little; 0.05 band when each took one (101 x
           101 drape: 1,025 -> 914 full queries a step; 0.2 band overflows NEAR_MAX more often) */
        /* a candidate whose planes' bound (PlaneBound2) is beyond r + tau / 2 is not near, and that
           bound counts for L */
        const PetscReal tau = 0.1 * b, r0 = std::sqrt(best);
        PetscReal       L   = PETSC_MAX_REAL;
        size_t          j   = C->off;
        for (; j < C->off + C->n && mo->pool[j].dc - s <= r0 + tau; j++) {
          const Triangle  &Tj = *mo->pool[j].T;
          const uint32_t   tj = (uint32_t)(&Tj - mo->tri.data());
          const PetscReal *pl = &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * (size_t)tj];
          const PetscReal  sj = pl[0] * x[0] + pl[1] * x[1] + pl[2] * x[2] + pl[3], hb = std::sqrt(PlaneBound2(pl, x, sj)) - peps;
          if (hb > r0 + 0.5 * tau) {
            L = PetscMin(L, hb);
            continue;
          }
          PetscReal pj[3], ej[3], rj = 0;
          int       regj;
          ClosestOnTriangle(x, Tj, pj, &regj, ej);
          for (int c = 0; c < 3; c++) rj += (x[c] - pj[c]) * (x[c] - pj[c]);
          rj = std::sqrt(rj);
          if (rj > r0 + 0.5 * tau) L = PetscMin(L, rj);
          else if (ns->n < _n_MSimMeshObstacle::NEAR_MAX) {
            if (&Tj == T) ns->w = ns->n;
            ns->s0[ns->n] = sj, ns->t[ns->n++] = tj;
          } else {
            ns->n = -1; /* too many near: no set */
            break;
          }
        }
        if (ns->n > 0 && ns->w >= 0) {
          ns->L = PetscMin(L, PetscMin(j < C->off + C->n ? mo->pool[j].dc : PETSC_MAX_REAL, b + mo->smax) - s);
          ns->key = mo->last_key;
        } else ns->n = 0;
      }
    } else {
      mo->near.clear();
      mo->tree.all_intersected_primitives(K::Iso_cuboid_3(Point(x[0] - b, x[1] - b, x[2] - b), Point(x[0] + b, x[1] + b, x[2] + b)), std::back_inserter(mo->near));
      for (const auto &id : mo->near) consider(*id);
    }
    if (!T || best > b * b) {
      /* the penalty's vertices sink deeper than band (the barrier's never do): a closed surface's
         inside at any depth, by x's cell's reference point or a ray (Inside: false outside the
         surface's box). Inside, no far ball (lower, zball stay 0): the depth changes with x */
      if (mo->penalty && mo->closed && (C && C->slot != ~(size_t)0 ? CellInside(mo, *C, x, PETSC_MAX_REAL) : Inside(mo, x))) return Deep(mo, x, n, H);
      for (int c = 0; c < 3; c++) n[c] = db2 > 0 ? q[c] / std::sqrt(db2) : (c == 2);
      if (H)
        for (int k = 0; k < 9; k++) H[k] = 0;
      if (lower) *lower = lb;
      if (zball && C)
        for (int c = 0; c < 4; c++) zball[c] = c < 3 ? C->z[c] : C->dz;
      return b - mo->thickness;
    }
  } else {
    const Point pq(x[0], x[1], x[2]);
    const auto  hit = mo->has_last ? mo->tree.closest_point_and_primitive(pq, mo->last) : mo->tree.closest_point_and_primitive(pq);
    mo->last        = hit;
    mo->has_last    = true;
    T               = &*hit.second;
    ClosestOnTriangle(x, *T, p, &region, e);
  }
  for (int c = 0; c < 3; c++) q[c] = x[c] - p[c], r += q[c] * q[c];
  r = std::sqrt(r);
  const PetscReal sign = mo->closed && r <= mo->band && (C ? CellInside(mo, *C, x, r) : Inside(mo, x)) ? -1.0 : 1.0;
  if (ns && ns->n > 0) {
    for (int c = 0; c < 3; c++) ns->x[c] = x[c];
    ns->inside = sign < 0;
  }
  if (tri && r <= mo->band) *tri = (int32_t)(T - mo->tri.data());
  return Answer(mo, q, r, sign, region, e, T, n, H);
}

/* Concave creases. The barrier takes one distance per vertex, the nearest triangle's. Inside a
   concave crease (a box's floor meeting its wall, a fin standing on a plate) that distance is the
   least of two smooth ones, kinked on the bisector, where its gradient flips from one face's normal
   to the other's: a vertex pressed into the corner was pushed by the floor alone, then by the wall
   alone, each Newton step undoing the last (an open box: a cloth's vertices in its corners closed
   their gap 5 x a step and the run diverged). IPC sums the barrier over every triangle within dhat
   (Li et al. 2020), which also counts a flat or convex surface's edges twice and would change every
   mesh scene. Here a vertex x whose nearest triangle is A (x on side s of A's plane) also takes, as
   a contact of its own, each other triangle B whose plane is within band with x's foot on it inside
   B (so |h_B| is x's distance to B, Hessian 0) when
     - the foot lies on side s of A's plane, beyond roundoff: on a convex surface (or a thin plate's
       far side) every other triangle lies behind A's plane as x sees it, so none qualifies there
       and the answers are the nearest's alone, bit for bit; a coplanar neighbour of A is in its
       plane and is passed over too;
     - and B's normal towards x makes an angle of at least 90 degrees with A's (right or acute
       creases: boxes, fins, slots). Then the foot is on side s wherever x is (its height over A's
       plane is at least x's), so it cannot leave B through the crease: the sum b(d_A) + b(d_B) is
       smooth through the bisector. An obtuse crease would switch B on where the foot crosses the
       crease, at d_B < dhat: a jump of b(d_B) in the energy, worse than the kink it removes, which
       is milder there (the normals turn by less than 90 degrees); obtuse creases keep the nearest
       triangle alone (but on an open surface that has one, where FeatureSum below replaces this
       rule).
   Where the foot passes to a coplanar neighbour (a wall's other triangle) the contact goes on, the
   same plane counted once; where it leaves B through an edge of the surface's boundary (the rim of
   an open box's wall) the contact leaves with b(d_B) still > 0 if d_B < dhat there: a jump in the
   energy that the full point-triangle distance would avoid, at the cost of a contact that comes and
   goes as a vertex lying on the rim crosses the wall's plane; except where B's edge meets one of
   A's boundary edges at a vertex (an open box's rim corner), where the contact goes on past the rim
   as RimCorner's. Each contact adds the barrier b(|h_B| - thickness)
   along B's unit normal towards x, as the nearest does: energy, gradient, Hessian (b'' n n^T), PD's
   weight and friction's lagged normal force sum over the contacts (IPC's point-triangle terms).
   The safe step and the anchors keep the nearest distance, the least of them. The triangles that
   can be such a B for a triangle A and side s are listed once per band, at A's first answer within
   band (CreasePartners): those within 2 band of A with a vertex strictly on side s of A's plane
   and, for a side s' of B's plane whose normal makes 90 degrees or more with s's, A having a vertex
   strictly on side s' (where x is in the crease, A's nearest point is). The lists are empty for
   every triangle of a convex surface seen from outside and for the shallow creases of a smooth
   curved one, so the vertices there cost one comparison of two offsets. */

static inline PetscReal PlaneHeight(const PetscReal *pl, const PetscReal x[3])
{
  return pl[0] * x[0] + pl[1] * x[1] + pl[2] * x[2] + pl[3];
}

/* the triangles whose boxes meet a box (CollectTraits' traversal without its distances) */
struct OverlapTraits {
  std::vector<uint32_t> *ids;
  const Triangle        *base;
  bool                   go_further() const { return true; }
  bool                   do_intersect(const CGAL::Bbox_3 &q, const CGAL::AABB_node<Traits> &node) const { return CGAL::do_overlap(q, node.bbox()); }
  void                   intersection(const CGAL::Bbox_3 &q, const Primitive &pr)
  {
    if (CGAL::do_overlap(q, pr.id()->bbox())) ids->push_back((uint32_t)(&*pr.id() - base));
  }
};

/* triangle a's partner lists (see above), on its first answer within band: listing every
   triangle's at once was half the run of a 24-step drape on the 20,480-triangle ball. A triangle of
   all-zero plane numbers (too thin, MSimMeshObstacleCreate) is in none and has none. Out of line,
   as RimCorner: both run rarely, and inlined into CreaseContacts, which every query within band
   calls, they made it dearer (0.1 M instructions a step of the ball drape) */
static __attribute__((noinline)) void CreasePartners(MSimMeshObstacle mo, size_t a)
{
  const PetscReal       tol = 1e-9 * (mo->diam + mo->band), reach = 2 * mo->band + tol;
  std::vector<uint32_t> hit;
  auto                  plane = [&](size_t t) { return &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * t]; };
  auto                  thin  = [&](size_t t) { return plane(t)[0] == 0 && plane(t)[1] == 0 && plane(t)[2] == 0; };
  /* the least and largest heights over triangle t's plane of triangle u's vertices */
  auto heights = [&](size_t t, size_t u, PetscReal *lo, PetscReal *hi) {
    *lo = PETSC_MAX_REAL, *hi = -PETSC_MAX_REAL;
    for (int k = 0; k < 3; k++) {
      const PetscReal y[3] = {mo->tri[u].vertex(k)[0], mo->tri[u].vertex(k)[1], mo->tri[u].vertex(k)[2]}, h = PlaneHeight(plane(t), y);
      *lo = PetscMin(*lo, h), *hi = PetscMax(*hi, h);
    }
  };
  if (!thin(a)) {
    const CGAL::Bbox_3 bb = mo->tri[a].bbox();
    OverlapTraits      overlap{&hit, mo->tri.data()};
    mo->tree.traversal(CGAL::Bbox_3(bb.xmin() - reach, bb.ymin() - reach, bb.zmin() - reach, bb.xmax() + reach, bb.ymax() + reach, bb.zmax() + reach), overlap);
  }
  /* each candidate's heights once, its sides' lists side[0], side[1] then in the order found */
  std::vector<uint32_t> side[2];
  const PetscReal      *pa = plane(a);
  for (const uint32_t b : hit) {
    PetscReal lo, hi;
    if (b == a || thin(b)) continue;
    heights(a, b, &lo, &hi);
    const bool on[2] = {hi > tol, -lo > tol}; /* a vertex of b strictly on side s */
    if (!on[0] && !on[1]) continue;
    const PetscReal *pb = plane(b), c = pa[0] * pb[0] + pa[1] * pb[1] + pa[2] * pb[2];
    heights(b, a, &lo, &hi);
    for (int s = 0; s < 2; s++) {
      const PetscReal sa = s ? -1.0 : 1.0;
      if (on[s] && ((sa * c <= CREASE_COS && hi > tol) || (-sa * c <= CREASE_COS && -lo > tol))) side[s].push_back(b);
    }
  }
  for (int s = 0; s < 2; s++) {
    mo->cr_at[4 * a + 2 * s] = (uint32_t)mo->cr_tri.size();
    mo->cr_tri.insert(mo->cr_tri.end(), side[s].begin(), side[s].end());
    mo->cr_at[4 * a + 2 * s + 1] = (uint32_t)mo->cr_tri.size();
  }
}

/* Rim corners. Where two walls of an open surface meet in a concave crease and end at boundary
   edges (an open box's rim), their edges eA and eB meet at a boundary vertex V. Above the rim the
   feet of x leave both faces, so the crease's second face gave no contact and the nearest edge
   alone was left: its distance is kinked on the bisector, where the vertices dropped on the corner
   settle (an 11 x 11 cloth in the open box of tests/contact_mesh.py with a thickness: Newton could
   not bring its gradient down there, took steps of 50 iterations, and diverged at step 24). With
   both walls' point-triangle distances rA, rB the sum b(rA) + b(rB) is smooth across the bisector
   and meets the faces' sum where the feet cross the rim, but on the corner's convex side (x beyond
   A's plane, where B is no partner) it must fall to b(rA) alone, and there B's nearest point is V:
   so the pair counts
     E = b(rA) + b(rB) - (1 - w) b(rV),   w = S(alpha) S(beta),
   rV = |x - V|, alpha = (x - V).uB / rA and beta = (x - V).uA / rB (uA, uB: the edges' directions
   from V), S the C2 step from 0 (at or below 0) to 1 (at or above 1). In an open box's corner
   (walls at right angles, each rim edge along the other wall's normal) alpha and beta are the
   cosines of x's directions from the two edges with the walls' normals: 1 where the feet cross the
   rim (w = 1: the faces' sum, unchanged), 0 where x crosses a wall's plane above the rim, where
   B's nearest point is V (rB = rV: E = b(rA), the convex side's), and E is symmetric in A and B,
   so the same whichever is nearest. E >= b(rA) (rB <= rV), so the barrier still stops x at the
   nearest distance. The nearest's contact is b(rA) as before; B's contact carries the rest, E -
   b(rA), as the distance d with b(d) equal to it and the vector n = grad(E - b(rA)) / b'(d) (not a
   unit vector): the callers' b(d), b'(d) n and b''(d) n n^T are then its energy, its gradient and
   a PSD Hessian (exact for a face's contact, where n is the unit normal). At other rim corners
   (walls not at right angles, or a rim edge off the other wall's normal) the same E is taken;
   there w need not vanish where x crosses a wall's plane above the rim, so the contact can still
   start or end with some energy there. Sets d and n (false: none; B's nearest point is on no
   boundary edge of B that meets one of A's at a vertex) */
static inline void Smooth(PetscReal u, PetscReal *s, PetscReal *ds)
{
  if (u <= 0) *s = *ds = 0;
  else if (u >= 1) *s = 1, *ds = 0;
  else *s = u * u * u * (10 + u * (6 * u - 15)), *ds = 30 * u * u * (1 - u) * (1 - u);
}

/* the distance d with b(d) = eb > 0 (dh: b's dhat) and b'(d): Newton from d0 with b(d0) >= eb,
   which climbs to the root without passing it, b being convex and decreasing; false where b' is
   not negative there (eb too small to resolve) */
static bool BarrierLevel(PetscReal eb, PetscReal d0, PetscReal dh, PetscReal *d, PetscReal *db)
{
  PetscReal dd = d0, be, dbe, d2e;
  for (int it = 0; it < 200; it++) {
    MSimBarrier(dd, dh, &be, &dbe, &d2e);
    const PetscReal step = dbe < 0 ? (be - eb) / -dbe : 0;
    if (!(step > 1e-15 * dd)) break;
    dd += step;
  }
  *d = dd, *db = dbe;
  return dbe < 0;
}

static __attribute__((noinline)) bool RimCorner(MSimMeshObstacle mo, const PetscReal x[3], size_t a, size_t b, PetscReal *d, PetscReal n[3])
{
  if (!mo->rim[a] || !mo->rim[b]) return false;
  PetscReal pb[3], e[3], rb2 = 0;
  int       region;
  ClosestOnTriangle(x, mo->tri[b], pb, &region, e);
  for (int c = 0; c < 3; c++) rb2 += (x[c] - pb[c]) * (x[c] - pb[c]);
  const PetscReal tol = Roundoff(mo);
  for (int k = 0; k < 3; k++) {
    if (!(mo->rim[b] >> k & 1)) continue;
    /* B's edge k, if B's nearest point is on it: its point q, x's distance rB from it */
    PetscReal p0[3], p1[3], f[3], ff = 0, s = 0, q[3], rb = 0;
    for (int c = 0; c < 3; c++) p0[c] = mo->tri[b][k][c], p1[c] = mo->tri[b][(k + 1) % 3][c], f[c] = p1[c] - p0[c], ff += f[c] * f[c], s += (x[c] - p0[c]) * f[c];
    s = PetscMin(1.0, PetscMax(0.0, s / ff));
    for (int c = 0; c < 3; c++) q[c] = p0[c] + s * f[c], rb += (x[c] - q[c]) * (x[c] - q[c]);
    rb = std::sqrt(rb);
    if (rb > std::sqrt(rb2) + tol) continue;
    for (int end = 0; end < 2; end++) {
      const PetscInt iv = mo->tv[3 * b + (k + end) % 3]; /* V: this end of B's edge */
      for (int ka = 0; ka < 3; ka++) { /* A's boundary edge from V */
        if (!(mo->rim[a] >> ka & 1)) continue;
        const PetscInt j0 = mo->tv[3 * a + ka], j1 = mo->tv[3 * a + (ka + 1) % 3];
        if (j0 != iv && j1 != iv) continue;
        const int wa = j0 == iv ? (ka + 1) % 3 : ka; /* A's edge's other end */
        PetscReal V[3], uA[3], uB[3], la = 0, lb = 0, pa[3], ea[3], ra = 0, rv = 0, ta = 0, tb = 0;
        int       rega;
        for (int c = 0; c < 3; c++) {
          V[c]  = mo->tri[b][(k + end) % 3][c];
          uB[c] = mo->tri[b][(k + 1 - end) % 3][c] - V[c], uA[c] = mo->tri[a][wa][c] - V[c];
          la += uA[c] * uA[c], lb += uB[c] * uB[c];
        }
        la = std::sqrt(la), lb = std::sqrt(lb);
        ClosestOnTriangle(x, mo->tri[a], pa, &rega, ea);
        for (int c = 0; c < 3; c++) {
          uA[c] /= la, uB[c] /= lb;
          ra += (x[c] - pa[c]) * (x[c] - pa[c]), rv += (x[c] - V[c]) * (x[c] - V[c]);
          ta += (x[c] - V[c]) * uA[c], tb += (x[c] - V[c]) * uB[c];
        }
        ra = std::sqrt(ra), rv = std::sqrt(rv);
        const PetscReal th = mo->thickness, dh = mo->band - th, alpha = tb / ra, beta = ta / rb;
        PetscReal       sa, dsa, sb, dsb, bb, dbb, bv, dbv, d2;
        Smooth(alpha, &sa, &dsa);
        Smooth(beta, &sb, &dsb);
        MSimBarrier(rb - th, dh, &bb, &dbb, &d2);
        MSimBarrier(rv - th, dh, &bv, &dbv, &d2);
        const PetscReal w = sa * sb, eb = bb - (1 - w) * bv; /* E - b(rA), B's contact's */
        if (!(eb > 0)) return false;
        PetscReal dd, dbe;
        if (!BarrierLevel(eb, rb - th, dh, &dd, &dbe)) return false; /* (b(rB - thickness) >= eb) */
        for (int c = 0; c < 3; c++) {
          const PetscReal nb = (x[c] - q[c]) / rb, nv = (x[c] - V[c]) / rv, na = (x[c] - pa[c]) / ra;
          const PetscReal gw = dsa * sb * (uB[c] - alpha * na) / ra + sa * dsb * (uA[c] - beta * nb) / rb;
          n[c]               = (dbb * nb - (1 - w) * dbv * nv + bv * gw) / dbe;
        }
        *d = dd;
        return true;
      }
    }
  }
  return false;
}

/* Obtuse creases. Where two faces meet at an obtuse concave crease (a tray's wall sloping at 120 or
   135 degrees to its floor, a faceted bowl's panels) the nearest face's distance is kinked on the
   bisector too, and the rule above keeps it alone there (a second face counted as such would switch
   on with b(d) > 0 where its foot crosses the crease): a cloth dropped into an open tray with 120
   or 135 degree walls made Newton diverge (runs/contact/README.md). On an open surface with such a
   crease (FeatureWeights) the barrier is instead the sum over the surface's features, as in IPC's
   convergent formulation (Li et al.), each at its true distance r (to the closed triangle, segment,
   point) less the thickness,
     E(x) = sum_faces b(r_F) - sum_edges w_E b(r_E) + sum_vertices w_V b(r_V),
   w_E = m - 1 for an edge of m triangles (1 inside, 0 on the boundary) and w_V = 1 - (the vertex's
   triangles) + (its edges' weights) (1 inside, 0 on the boundary): each term is C1 away from the
   surface, so E is too, and where the surface within dhat of x is flat or convex the terms cancel
   to b(nearest) (the foot in a face: the neighbours' distances are their shared edges'; near a
   vertex of k faces, k - k + 1). In a crease it is b(r_A) + b(r_B) - b(r_E) >= b(nearest), the
   same whichever face is nearest: smooth across the bisector, and across a rim corner (the walls'
   edge ends at a boundary vertex, weight 0), with no rule on the angle. It is taken only where the
   nearest triangle ta has a bent one within 2 band (every feature within band of x is then within
   2 band of ta), the nearest face alone elsewhere, where the sum is that face's: the switch is
   continuous (but where the flat pieces within band of x are two, a thin gap or a notch in an open
   edge, which the sum counts twice and the nearest once). The nearest keeps its contact (its
   distance, normal and Hessian), and the rest, E - b(nearest), is one contact as RimCorner's: the
   distance d with b(d) equal to it and n = grad / b'(d), so the callers' energy, gradient, PD
   weight and friction take it as they are, its Hessian b''(d) n n^T PSD (exact where the rest is one
   face's, its foot inside); the safe step and the anchors keep the nearest distance. Where the
   rest is not positive (the features within band circling a hole, or roundoff: below 1e-12 of the
   terms' sum) there is none. Sets cr (none where ta has no bent triangle near) */
static __attribute__((noinline)) void FeatureSum(MSimMeshObstacle mo, const PetscReal x[3], size_t ta, MSimMeshCreases *cr)
{
  const PetscReal band = mo->band, th = mo->thickness, dh = band - th;
  if (!mo->ie_near[ta]) { /* ta's first answer within band */
    const PetscReal tol = 1e-9 * (mo->diam + band), reach = 2 * band + tol;
    const CGAL::Bbox_3 bb = mo->tri[ta].bbox();
    OverlapTraits      overlap{&mo->ie_hit, mo->tri.data()};
    mo->ie_hit.clear();
    mo->tree.traversal(CGAL::Bbox_3(bb.xmin() - reach, bb.ymin() - reach, bb.zmin() - reach, bb.xmax() + reach, bb.ymax() + reach, bb.zmax() + reach), overlap);
    mo->ie_near[ta] = 1;
    for (const uint32_t t : mo->ie_hit)
      if (mo->bent[t]) mo->ie_near[ta] = 2;
  }
  if (mo->ie_near[ta] != 2) return;
  OverlapTraits overlap{&mo->ie_hit, mo->tri.data()};
  mo->ie_hit.clear();
  mo->tree.traversal(CGAL::Bbox_3(x[0] - band, x[1] - band, x[2] - band, x[0] + band, x[1] + band, x[2] + band), overlap);
  PetscReal sum = 0, mag = 0, g[3] = {0, 0, 0}, rmin = PETSC_MAX_REAL, nmin[3] = {0, 0, 0};
  /* w b(r - th) for the feature's nearest point p, its gradient; r */
  auto term = [&](PetscReal w, const PetscReal p[3]) {
    const PetscReal q[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]}, r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    if (w != 0 && r < band) {
      PetscReal b, db, d2b;
      MSimBarrier(r - th, dh, &b, &db, &d2b);
      sum += w * b, mag += std::abs(w) * b;
      for (int c = 0; c < 3; c++) g[c] += w * db * q[c] / r;
    }
    return r;
  };
  for (const uint32_t t : mo->ie_hit) {
    PetscReal p[3], e[3];
    int       region;
    ClosestOnTriangle(x, mo->tri[t], p, &region, e);
    const PetscReal r = term(1, p);
    if (r < rmin) {
      rmin = r;
      for (int c = 0; c < 3; c++) nmin[c] = (x[c] - p[c]) / r;
    }
    for (int k = 0; k < 3; k++) {
      const PetscReal *w = &mo->ew[3 * t];
      if (w[k] != 0) { /* edge k's nearest point */
        PetscReal a[3], f[3], ff = 0, s = 0;
        for (int c = 0; c < 3; c++) a[c] = mo->tri[t][k][c], f[c] = mo->tri[t][(k + 1) % 3][c] - a[c], ff += f[c] * f[c], s += (x[c] - a[c]) * f[c];
        s = PetscMin(1.0, PetscMax(0.0, s / ff));
        for (int c = 0; c < 3; c++) p[c] = a[c] + s * f[c];
        term(-w[k], p);
      }
      if (mo->vw[3 * t + k] != 0) {
        for (int c = 0; c < 3; c++) p[c] = mo->tri[t][k][c];
        term(mo->vw[3 * t + k], p);
      }
    }
  }
  if (!(rmin < band && rmin > th)) return;
  PetscReal bm, dbm, d2m, dd, dbe;
  MSimBarrier(rmin - th, dh, &bm, &dbm, &d2m);
  const PetscReal rest = sum - bm;
  if (!(rest > 1e-12 * mag)) return;
  PetscReal d0 = rmin - th; /* b(d0) >= rest: BarrierLevel's start */
  while (bm < rest) {
    d0 *= 0.5;
    MSimBarrier(d0, dh, &bm, &dbm, &d2m);
  }
  MSimBarrier(rmin - th, dh, &bm, &dbm, &d2m);
  if (!BarrierLevel(rest, d0, dh, &dd, &dbe)) return;
  cr->k    = 1;
  cr->d[0] = dd;
  for (int c = 0; c < 3; c++) cr->n[0][c] = (g[c] - dbm * nmin[c]) / dbe;
}

/* the creases' contacts of the answer d at x whose nearest triangle is ta (-1: none within band) */
static void CreaseContacts(MSimMeshObstacle mo, const PetscReal x[3], int32_t ta, PetscReal d, MSimMeshCreases *cr)
{
  cr->k = 0;
  if (ta < 0 || mo->cr_at.empty() || !(d > 0)) return;
  if (mo->ie) return FeatureSum(mo, x, (size_t)ta, cr);
  const uint32_t *at = &mo->cr_at[4 * (size_t)ta];
  if (at[0] == ~(uint32_t)0) CreasePartners(mo, (size_t)ta);
  if (at[0] == at[1] && at[2] == at[3]) return; /* no partner on either side (convex surfaces) */
  const PetscReal *pa = &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * (size_t)ta], ha = PlaneHeight(pa, x), sa = ha > 0 ? 1.0 : -1.0;
  const size_t     k0 = at[ha > 0 ? 0 : 2], k1 = at[ha > 0 ? 1 : 3];
  const PetscReal  tol = 1e-9 * (mo->diam + mo->band), peps = Roundoff(mo);
  if (k0 == k1 || !(sa * ha > tol)) return;
  PetscReal gn[MSIM_MESH_CREASE_MAX][3]; /* the contacts' walls' normals (cr->n: a rim corner's is not) */
  for (size_t k = k0; k < k1; k++) {
    const PetscReal *pb = &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * (size_t)mo->cr_tri[k]], hb = PlaneHeight(pb, x), sb = hb > 0 ? 1.0 : -1.0;
    if (!(std::abs(hb) < mo->band) || sa * sb * (pa[0] * pb[0] + pa[1] * pb[1] + pa[2] * pb[2]) > CREASE_COS) continue;
    const PetscReal foot[3] = {x[0] - hb * pb[0], x[1] - hb * pb[1], x[2] - hb * pb[2]}, nb[3] = {sb * pb[0], sb * pb[1], sb * pb[2]};
    PetscReal       db = std::abs(hb) - mo->thickness, nc[3] = {nb[0], nb[1], nb[2]};
    if (EdgeExcess(pb, foot) > peps) { /* the foot off B: only at a rim corner */
      if (!RimCorner(mo, x, (size_t)ta, (size_t)mo->cr_tri[k], &db, nc)) continue;
    } else if (!(sa * PlaneHeight(pa, foot) > tol)) continue;
    /* one contact per wall: faces whose normals are less than 90 degrees apart (a wall's coplanar
       triangles, the panels of a faceted cylinder's side, a thin fin's near and far faces) give the
       nearest of them alone. Counted each, a panel's contact would switch on with b(d) > 0 where
       the foot enters it across its obtuse edge with the next panel (a 16-panel cup: the energy
       jumped 20% there), and a fin's far face would count through the fin only while the floor is
       the nearest. Their least distance is continuous: where the foot enters a panel across an
       edge, its distance is that edge's, no less than the neighbour panel's. */
    PetscInt j = 0;
    while (j < cr->k && gn[j][0] * nb[0] + gn[j][1] * nb[1] + gn[j][2] * nb[2] <= CREASE_COS) j++;
    if (j == cr->k && cr->k == MSIM_MESH_CREASE_MAX) continue;
    if (j == cr->k) cr->k++;
    else if (!(db < cr->d[j])) continue;
    cr->d[j] = db;
    for (int c = 0; c < 3; c++) cr->n[j][c] = nc[c], gn[j][c] = nb[c];
  }
}

PetscReal MSimMeshObstacleDistance(MSimMeshObstacle mo, const PetscReal x[3], PetscReal n[3], PetscReal H[9])
{
  return Distance(mo, x, n, H, true);
}

/* A vertex asks again at the very point it asked before, most of the time: friction's lagged
   normal at x_n at every evaluation of a time step, PD's right-hand side and energy at the same
   iterate, the energy at a point its gradient was taken at. Each vertex keeps its last MEMO_SLOTS
   answers (three: x_n, the iterate, a trial point) keyed by the point's bits, and a point asked
   again gets its answer back: the same numbers, as the query is a function of the point (the
   cells only save work; their state changes no answer, test_mesh_obstacle.cpp). Points beyond the
   band around the bounding box are answered directly, that test being cheaper than the memo's.
   A vertex that is far (beyond band) and moves little needs no query either: its full query at
   y also gives a lower bound L of y's distance (Distance's *lower: the cell's candidates bound
   every triangle's distance), and the distance is 1-Lipschitz, so every x with |x - y| < L - band
   is beyond band, where Distance's answer is the band itself with the box's direction, computed
   here by the same operations. The margin (1e-9 of the surface's size) covers the roundoff of the
   distances compared, ~1e-16 of it: a skipped x is one the full query would also have found beyond
   band, so the answers stay the same bit for bit.
   That ball (y, L - band) is small where it matters: L is what y's cell loop saw, which stops at the
   first candidate farther than band, so for a vertex just beyond band it is barely more than band
   (median 0.2 band on the benchmark drape), and 86% of the full queries were vertices of the
   cloth's skirt falling past the ball beyond band, each re-queried after a move of a fraction of a
   band. So each far vertex keeps a second ball: around its cell's centre z, of radius dz - band,
   where dz is z's own distance to the surface (the cell's nearest candidate's distance to z, which
   the cell holds; where the cell has no candidate, or x is in an empty coarse cell, the tree's
   closest point from z, once per cell). It holds (y, L - band) where L comes from dz (L >= dz - |y - z|)
   and reaches farther on the side of z; the median vertex beyond band had 2.7 bands of true
   clearance. The same 1e-9 margin, the same answers. */
enum { MEMO_SLOTS = 3 };

/* the vertex query within the band around the box (kept out of line: most calls, a cloth's vertices
   far from a small obstacle and friction's at x_n, end at the box test, and this part's register
   saves and stack frame were a third of their cost; callgrind, runs/contact/README.md) */
static PetscReal DistanceVertexNear(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], const PetscReal q[3], PetscReal db2, PetscReal n[3], PetscReal H[9], MSimMeshCreases *cr);

static inline __attribute__((always_inline)) PetscReal VertexDistance(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], PetscReal n[3], PetscReal H[9], MSimMeshCreases *cr)
{
  PetscReal       q[3];
  const PetscReal db2 = BoxOffset(mo, x, q);
  if (cr) cr->k = 0; /* beyond band: none */
  if (db2 > mo->band * mo->band) { /* Distance's first answer, the same operations */
    const PetscReal db = std::sqrt(db2);
    for (int c = 0; c < 3; c++) n[c] = q[c] / db;
    if (H)
      for (int k = 0; k < 9; k++) H[k] = 0;
    return db - mo->thickness;
  }
  if (v >= 0 && (size_t)v < mo->far.size() && mo->use_cells) { /* the far skip, here too: DistanceVertexNear's frame (its saves and restores) cost more than the test */
    const _n_MSimMeshObstacle::Far &f = mo->far[v];
    const PetscReal dx[3] = {x[0] - f.x[0], x[1] - f.x[1], x[2] - f.x[2]}, dz[3] = {x[0] - f.z[0], x[1] - f.z[1], x[2] - f.z[2]};
    const bool      inx = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2] < f.r * f.r; /* (r, rz >= 0) */
    if (inx || dz[0] * dz[0] + dz[1] * dz[1] + dz[2] * dz[2] < f.rz * f.rz) { /* Distance's answer beyond band */
      for (int c = 0; c < 3; c++) n[c] = db2 > 0 ? q[c] / std::sqrt(db2) : (c == 2);
      if (H)
        for (int k = 0; k < 9; k++) H[k] = 0;
      mo->nvq[1]++;
      mo->nvq[4] += !inx;
      return mo->band - mo->thickness;
    }
  }
  return DistanceVertexNear(mo, v, x, q, db2, n, H, cr);
}

PetscReal MSimMeshObstacleVertexClearance(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3])
{
  if (v < 0 || (size_t)v >= mo->far.size()) return PETSC_MIN_REAL;
  const _n_MSimMeshObstacle::Far &f = mo->far[v];
  PetscReal mx = 0, mz = 0;
  for (int c = 0; c < 3; c++) mx += (x[c] - f.x[c]) * (x[c] - f.x[c]), mz += (x[c] - f.z[c]) * (x[c] - f.z[c]);
  /* every point within r of f.x is farther than band (Far), so x is farther than band + r - |x - f.x|;
     the same for (z, rz) */
  const PetscReal depth = PetscMax(f.r - std::sqrt(mx), f.rz - std::sqrt(mz));
  return depth > 0 ? mo->band + depth - mo->thickness : PETSC_MIN_REAL;
}

/* The near shortcut. A vertex's full query within band at y also finds the few triangles within
   r + tau / 2 of y (its near set, r its distance) and a lower bound L of every other triangle's
   distance from y (Distance). At a point x with |x - y| = delta: every other triangle is at least
   L - delta from x (the distance to a triangle is 1-Lipschitz), so where the near set's nearest is
   closer than that, by a margin above roundoff, the nearest triangle is in the set and the set's
   closest points, the least by (squared distance, place in the cell's candidate order), pick the
   triangle (and so the point, the region and the normal) that the cell's loop picks; the
   side is y's unless the segment y -> x crosses one of the set's triangles (below). The answer is
   then Distance's, by the same operations (Answer), without the cell's lookup, its candidates' loop
   or the cell's side test. A closest point costs ~100 instructions, and the set holds 3.7
   triangles on average on the benchmark drape (a vertex near a facet's edge or corner has its
   neighbours within tau / 2), so the set's triangles are first bounded below by their planes
   (PlaneBound2, ~20 instructions, exact where the foot of x is inside the triangle), the least
   bound's triangle gets its closest point, and only those whose bound does not exceed that
   distance get theirs: 1.4 closest points per answer there (3.5 before). The list's order breaks
   ties; it is the order of y's cell, so a tie is answered here only in y's cell, while a single
   nearest triangle is the cell loop's in any cell (the others are farther by more than roundoff). */
static bool NearAnswer(MSimMeshObstacle mo, const _n_MSimMeshObstacle::Near &ns, const PetscReal x[3], _n_MSimMeshObstacle::Answer *use)
{
  if (ns.n <= 0) return false;
  PetscReal delta = 0;
  for (int c = 0; c < 3; c++) delta += (x[c] - ns.x[c]) * (x[c] - ns.x[c]);
  delta = std::sqrt(delta);
  const PetscReal margin = 1e-9 * (mo->diam + mo->band) + Roundoff(mo);
  /* x's signed distances to the set's planes (the side test) and the lower bounds of its squared
     distances to the triangles (PlaneBound2: exact where the nearest point is inside a triangle or
     on an edge) */
  PetscReal h[_n_MSimMeshObstacle::NEAR_MAX], lb2[_n_MSimMeshObstacle::NEAR_MAX];
  int       first = 0;
  for (int k = 0; k < ns.n; k++) {
    const PetscReal *pl = &mo->plane[_n_MSimMeshObstacle::PLANE_STRIDE * (size_t)ns.t[k]];
    h[k]                = pl[0] * x[0] + pl[1] * x[1] + pl[2] * x[2] + pl[3];
    lb2[k]              = PlaneBound2(pl, x, h[k]);
    if (lb2[k] < lb2[first]) first = k;
  }
  /* the set's nearest by (squared distance, place in the list): what the scan in the list's order
     with a strict comparison picks. The least bound's triangle first (most often the nearest); then
     every other triangle whose bound exceeds its distance (plus roundoff) is farther and is passed
     over without its closest point */
  PetscReal p[3], e[3] = {0, 0, 0}, best = 0;
  int       region, bi = first;
  bool      tie = false; /* another triangle at the same squared distance */
  ClosestOnTriangle(x, mo->tri[ns.t[bi]], p, &region, e);
  for (int c = 0; c < 3; c++) best += (x[c] - p[c]) * (x[c] - p[c]);
  const PetscReal cut = std::sqrt(best) + Roundoff(mo), cut2 = cut * cut;
  for (int k = 0; k < ns.n; k++) {
    if (k == first || lb2[k] > cut2) continue;
    PetscReal pk[3], ek[3] = {0, 0, 0}, rk = 0;
    int       regk;
    ClosestOnTriangle(x, mo->tri[ns.t[k]], pk, &regk, ek);
    for (int c = 0; c < 3; c++) rk += (x[c] - pk[c]) * (x[c] - pk[c]);
    if (rk == best) tie = true;
    if (rk < best || (rk == best && k < bi)) {
      tie = tie && rk == best;
      best = rk, bi = k, region = regk;
      for (int c = 0; c < 3; c++) p[c] = pk[c], e[c] = ek[c];
    }
  }
  if (!(best <= mo->band * mo->band && std::sqrt(best) < ns.L - delta - margin)) return false;
  /* a tie is broken by the candidate order of x's cell, which is y's list order only in y's cell;
     a single nearest is the same triangle in any order */
  if (tie) {
    uint64_t key;
    if (!CellKey(mo, x, &key) || key != ns.key) return false;
  }
  PetscReal q[3], r = 0;
  for (int c = 0; c < 3; c++) q[c] = x[c] - p[c], r += q[c] * q[c];
  r = std::sqrt(r);
  /* the side: y's, unless the segment y -> x crosses the surface. Every point of it is within
     delta of y, so only the near set's triangles can meet it (the others are farther than L -
     delta > 0), and an odd number of crossings of their interiors means the other side; a
     degenerate crossing, or x within roundoff of the surface, is left to the full query (its ray),
     as CellInside does with its cell's reference point */
  bool inside = ns.inside;
  if (mo->closed) {
    const PetscReal tol = 1e-9 * mo->diam;
    if (r <= tol) return false;
    const PetscReal d[3] = {x[0] - ns.x[0], x[1] - ns.x[1], x[2] - ns.x[2]};
    bool            degenerate = false;
    int             count      = 0;
    for (int k = 0; k < ns.n && !degenerate; k++) {
      /* both ends clearly on one side of the triangle's plane (by far more than its roundoff):
         no crossing, without the exact test */
      if ((ns.s0[k] > tol && h[k] > tol) || (ns.s0[k] < -tol && h[k] < -tol)) continue;
      count += SegmentCrosses(ns.x, d, delta, mo->tri[ns.t[k]], tol, &degenerate);
    }
    if (degenerate) return false;
    inside = inside != (count % 2 == 1);
  }
  use->d = Answer(mo, q, r, inside ? -1.0 : 1.0, region, e, &mo->tri[ns.t[bi]], use->n, use->H);
  use->t = (int32_t)ns.t[bi];
  return true;
}

static __attribute__((noinline)) PetscReal DistanceVertexNear(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], const PetscReal q[3], PetscReal db2, PetscReal n[3], PetscReal H[9], MSimMeshCreases *cr)
{
  if (v < 0 || !mo->use_cells) { /* the kept answers are the cache path's */
    int32_t         t;
    const PetscReal d = Distance(mo, x, n, H, true, NULL, NULL, NULL, &t);
    if (cr) CreaseContacts(mo, x, t, d, cr);
    return d;
  }
  if (mo->memo.size() < MEMO_SLOTS * (size_t)(v + 1)) mo->memo.resize(MEMO_SLOTS * (size_t)(v + 1), _n_MSimMeshObstacle::Answer{{0, 0, 0}, 0, 0, {0, 0, 0}, {0}, -1});
  if (mo->far.size() <= (size_t)v) mo->far.resize((size_t)v + 1, _n_MSimMeshObstacle::Far{{0, 0, 0}, 0, {0, 0, 0}, 0});
  _n_MSimMeshObstacle::Far &f = mo->far[v]; /* (its skip was tested by the caller) */
  _n_MSimMeshObstacle::Answer *a = &mo->memo[MEMO_SLOTS * (size_t)v], *use = NULL, *old = a;
  for (int k = 0; k < MEMO_SLOTS && !use; k++) {
    if (a[k].stamp > mo->memo_epoch && !std::memcmp(a[k].x, x, sizeof(a[k].x))) use = &a[k];
    else if (a[k].stamp < old->stamp) old = &a[k];
  }
  if (!use) { /* the least recently used slot takes the new point */
    use = old;
    if (mo->nearset.size() <= (size_t)v) mo->nearset.resize((size_t)v + 1);
    _n_MSimMeshObstacle::Near &ns = mo->nearset[v];
    if (NearAnswer(mo, ns, x, use)) {
      for (int c = 0; c < 3; c++) use->x[c] = f.x[c] = x[c];
      f.r = f.rz = 0; /* within band: no far skip */
      mo->nvq[3]++;
    } else {
      PetscReal lower, zb[4] = {0, 0, 0, 0}; /* zb[0..2] are set only for a beyond-band answer in a cell; rz = 0 otherwise */
      use->d = Distance(mo, x, use->n, use->H, true, &lower, &ns, zb, &use->t);
      for (int c = 0; c < 3; c++) use->x[c] = f.x[c] = x[c], f.z[c] = zb[c];
      f.r  = PetscMax(lower - mo->band - 1e-9 * (mo->diam + mo->band) - Roundoff(mo), 0.0); /* (0: none; a negative radius would pass the squared test) */
      f.rz = lower > 0 ? PetscMax(zb[3] - mo->band - 1e-9 * (mo->diam + mo->band) - Roundoff(mo), 0.0) : 0;
      mo->nvq[2]++;
    }
  } else mo->nvq[0]++;
  use->stamp = ++mo->clock;
  for (int c = 0; c < 3; c++) n[c] = use->n[c];
  if (H)
    for (int k = 0; k < 9; k++) H[k] = use->H[k];
  if (cr) CreaseContacts(mo, x, use->t, use->d, cr);
  return use->d;
}

/* Moller-Trumbore: the time t >= 0 at which o + t d meets T, edges and corners included (within
   roundoff: a segment through an edge counts as a hit, the conservative side); infinity if none.
   A move along T's plane (d within 1e-10 of it) from a point within lentol of the plane (a cloth
   vertex exactly in an open wall's plane, falling along it) never crosses the plane, so the
   crossing above cannot see it enter T through an edge: there the first time the move meets one
   of T's edges (in the plane) is a hit too */
static PetscReal SegmentHitTime(const PetscReal o[3], const PetscReal d[3], const Triangle &T, PetscReal lentol)
{
  PetscReal e1[3], e2[3], s[3], pv[3], qv[3], th = PETSC_INFINITY;
  for (int k = 0; k < 3; k++) e1[k] = T[1][k] - T[0][k], e2[k] = T[2][k] - T[0][k], s[k] = o[k] - T[0][k];
  pv[0] = d[1] * e2[2] - d[2] * e2[1], pv[1] = d[2] * e2[0] - d[0] * e2[2], pv[2] = d[0] * e2[1] - d[1] * e2[0];
  const PetscReal det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
  const PetscReal tol = 1e-9;
  if (det != 0) { /* (det = 0: parallel to the plane, no crossing) */
    const PetscReal u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
    qv[0] = s[1] * e1[2] - s[2] * e1[1], qv[1] = s[2] * e1[0] - s[0] * e1[2], qv[2] = s[0] * e1[1] - s[1] * e1[0];
    const PetscReal v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det, t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
    if (!(u < -tol || v < -tol || u + v > 1 + tol) && t >= 0) th = t;
  }
  const PetscReal n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const PetscReal nn = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), dl = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (std::abs(det) <= 1e-10 * nn * dl && std::abs(s[0] * n[0] + s[1] * n[1] + s[2] * n[2]) <= lentol * nn) {
    /* edge a -> a + f against the line o + t d, both in the plane: with w = a - o, o + t d = a + r f
       at t = (w x f).n / (d x f).n, r = (w x d).n / (d x f).n; an edge parallel to d is met, if at
       all, at its ends, which the other two edges' crossings find */
    auto tri = [&](const PetscReal *p, const PetscReal *q) { /* (p x q).n */
      return (p[1] * q[2] - p[2] * q[1]) * n[0] + (p[2] * q[0] - p[0] * q[2]) * n[1] + (p[0] * q[1] - p[1] * q[0]) * n[2];
    };
    for (int k = 0; k < 3; k++) {
      PetscReal a[3], f[3], w[3];
      for (int c = 0; c < 3; c++) a[c] = T[k][c], f[c] = T[(k + 1) % 3][c] - a[c], w[c] = a[c] - o[c];
      const PetscReal den = tri(d, f);
      if (den == 0) continue;
      const PetscReal t = tri(w, f) / den, r = tri(w, d) / den;
      if (r >= -tol && r <= 1 + tol && t >= 0) th = PetscMin(th, t);
    }
  }
  return th;
}

PetscReal MSimMeshObstacleSafeStep(MSimMeshObstacle mo, const PetscReal x[3], const PetscReal u[3], PetscReal tmax)
{
  return MSimMeshObstacleSafeStepVertex(mo, -1, x, u, tmax);
}

PetscReal MSimMeshObstacleSafeStepVertex(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], const PetscReal u[3], PetscReal tmax)
{
  const PetscReal ulen = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  PetscReal       n[3], y[3] = {x[0], x[1], x[2]}, t = 0;

  if (ulen == 0) return PETSC_INFINITY;
  const PetscReal d0 = MSimMeshObstacleDistanceVertex(mo, v, x, n, NULL); /* v's answer at x (its iterate, asked already) */
  if (d0 <= 0) return 0;
  if (d0 > tmax * ulen) return PETSC_INFINITY; /* the shell is farther than the whole step */
  if (mo->thickness == 0) {
    /* no shell: the surface itself is the limit, and the move's first crossing of it is exact (a
       ray query, cut to 0.8 of the hit time as the analytic shapes are). Conservative advancement
       stalled on a vertex sliding along the surface at a small gap d0: steps of 0.9 d0 never
       covered the move within its 100 iterations, and the short step it returned cut max_step's
       common alpha for the whole cloth, so PD never pushed the contact vertices back out, the
       first iterate's clamp parked them ten times closer every step, and the contact force grew
       tenfold a step (5e6 N on a 31 x 31 cloth by step 10, m g = 9.81 N) */
    /* the candidates: every triangle meeting the move's box, widened by roundoff (a move through
       an edge or a vertex shared by several triangles, where an inexact ray-triangle predicate can
       miss them all: the centre of a cloth falling on a box's diagonal edge went through) */
    PetscReal       th = PETSC_INFINITY, lo[3], hi[3];
    const PetscReal te = PetscMin(tmax, 2 * (mo->diam + d0) / ulen), eps = 1e-9 * (mo->diam + te * ulen);
    for (int c = 0; c < 3; c++) lo[c] = PetscMin(x[c], x[c] + te * u[c]) - eps, hi[c] = PetscMax(x[c], x[c] + te * u[c]) + eps;
    const K::Iso_cuboid_3 box(Point(lo[0], lo[1], lo[2]), Point(hi[0], hi[1], hi[2]));
    MeshCellT             cell, *C = mo->use_cells && mo->band < PETSC_MAX_REAL && MeshCell(mo, x, &cell) && cell.slot != ~(size_t)0 ? &cell : NULL;
    PetscReal             far = 0;
    if (C) { /* the box's farthest corner from the centre: the cell answers if within R of it */
      for (int c = 0; c < 3; c++) {
        const PetscReal f = PetscMax(std::abs(lo[c] - C->c[c]), std::abs(hi[c] - C->c[c]));
        far += f * f;
      }
      far = std::sqrt(far) + 1e-9 * (mo->diam + mo->band) + Roundoff(mo);
      if (far > mo->band + mo->smax) C = NULL;
    }
    if (C) {
      for (size_t k = C->off; k < C->off + C->n && mo->pool[k].dc <= far; k++)
        if (CGAL::do_intersect(box, *mo->pool[k].T)) th = PetscMin(th, SegmentHitTime(x, u, *mo->pool[k].T, eps));
    } else {
      std::vector<Primitive::Id> hit;
      mo->tree.all_intersected_primitives(box, std::back_inserter(hit));
      for (const auto &id : hit) th = PetscMin(th, SegmentHitTime(x, u, *id, eps));
    }
    return 0.8 * th < tmax ? 0.8 * th : PETSC_INFINITY;
  }
  const PetscReal d0x = Distance(mo, x, n, NULL, false);
  PetscReal       d   = d0x;
  for (int it = 0; it < 100 && d > 0.1 * d0x; it++) {
    const PetscReal dt = 0.9 * d / ulen;
    t += dt;
    if (t >= tmax) return PETSC_INFINITY;
    for (int c = 0; c < 3; c++) y[c] = x[c] + t * u[c];
    d = Distance(mo, y, n, NULL, false);
  }
  return t;
}

/* A shell's side for the penalty. The penalty pushes a vertex within the thickness shell out along
   the unsigned distance's gradient, towards the nearer side; one that sinks past the surface (a
   landing deeper than the thickness) was pushed out the far side and the cloth passed through.
   Each vertex keeps the gradient m of its last answer within band on its own side: an answer whose
   gradient turns against m (by more than 90 degrees) has passed the surface, and takes the side it
   came from, distance -(r + thickness) along -(x - p) / r, as a closed surface's inside does; past
   band on the far side (deeper than band + thickness below the surface it came from) too, from the
   tree's closest point. A vertex going round the surface's rim outside the shell turns m a little
   at each answer, and keeps its side; one that entered the shell from beyond band in one query
   (moved more than dhat) has no known side: it takes the nearer, and MSimMeshObstacleKeepsSides
   says so. A vertex's first answer (the start, which has every vertex outside) takes the nearer
   side; a checkpoint carries the sides (MSimMeshObstacleGetSides), so a restart goes on with each
   vertex's, past the surface too. */
static inline PetscReal ShellSide(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], PetscReal d, PetscReal n[3], PetscReal H[9])
{
  typedef _n_MSimMeshObstacle M;
  if (mo->side.size() <= (size_t)v) mo->side.resize((size_t)v + 1, M::Side{{0, 0, 0}, M::SIDE_NEW});
  M::Side        &s  = mo->side[(size_t)v];
  const PetscReal th = mo->thickness;
  auto            back = [&](PetscReal r) { /* past the surface: the side it came from */
    for (int c = 0; c < 3; c++) n[c] = -n[c];
    if (H)
      for (int k = 0; k < 9; k++) H[k] = -H[k];
    s.state = M::SIDE_IN;
    return -r - th;
  };
  auto against = [&](const PetscReal *u) { return u[0] * s.m[0] + u[1] * s.m[1] + u[2] * s.m[2] < 0; };
  if (!(d + th < mo->band)) { /* beyond band: on its side, or past the surface by more than band */
    if (s.state == M::SIDE_IN) {
      PetscReal       nu[3], Hu[9];
      const PetscReal du = Distance(mo, x, nu, H ? Hu : NULL, false);
      if (against(nu)) {
        for (int c = 0; c < 3; c++) n[c] = nu[c];
        if (H)
          for (int k = 0; k < 9; k++) H[k] = Hu[k];
        return back(du + th);
      }
    }
    s.state = M::SIDE_FAR;
    return d;
  }
  if ((s.state == M::SIDE_OUT || s.state == M::SIDE_IN) && against(n)) return back(d + th);
  if (d < 0 && s.state == M::SIDE_FAR && mo->lost < 0) {
    mo->lost = v;
    for (int c = 0; c < 3; c++) mo->lost_x[c] = x[c];
  }
  s.state = d < 0 ? M::SIDE_IN : M::SIDE_OUT;
  for (int c = 0; c < 3; c++) s.m[c] = n[c];
  return d;
}

/* a shell's vertex query with its side (out of line: wrapped around every query, the side's work
   kept the query's registers across it, a tenth more instructions a query where no mesh keeps
   sides, callgrind) */
static __attribute__((noinline)) PetscReal ShellVertex(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], PetscReal n[3], PetscReal H[9], MSimMeshCreases *cr)
{
  return ShellSide(mo, v, x, VertexDistance(mo, v, x, n, H, cr), n, H);
}

PetscReal MSimMeshObstacleDistanceVertex(MSimMeshObstacle mo, PetscInt v, const PetscReal x[3], PetscReal n[3], PetscReal H[9], MSimMeshCreases *cr)
{
  if (mo->sides && v >= 0) return ShellVertex(mo, v, x, n, H, cr);
  return VertexDistance(mo, v, x, n, H, cr);
}

void MSimMeshObstacleSetPenalty(MSimMeshObstacle mo, PetscBool on)
{
  mo->penalty    = on ? true : false;
  mo->sides      = mo->penalty && !mo->closed;
  mo->memo_epoch = mo->clock; /* the kept answers and the far balls are the other mode's */
  mo->far.clear();
  mo->nearset.clear();
  mo->side.clear();
  mo->lost = -1;
}

PetscBool MSimMeshObstacleKeepsSides(MSimMeshObstacle mo, PetscBool *lost, PetscReal x[3])
{
  *lost = (PetscBool)(mo->lost >= 0);
  if (mo->lost >= 0)
    for (int c = 0; c < 3; c++) x[c] = mo->lost_x[c];
  return (PetscBool)mo->sides;
}

/* The sides go into a checkpoint as two vectors shaped like X: each vertex's m, and its state in
   the first of its three numbers (a small integer, exact in a double). A vertex no query has
   reached yet is SIDE_NEW, as its entry would be when created. */
void MSimMeshObstacleGetSides(MSimMeshObstacle mo, PetscInt n, PetscScalar m[], PetscScalar state[])
{
  typedef _n_MSimMeshObstacle M;
  for (PetscInt v = 0; v < n; v++) {
    const M::Side s = (size_t)v < mo->side.size() ? mo->side[(size_t)v] : M::Side{{0, 0, 0}, M::SIDE_NEW};
    for (int c = 0; c < 3; c++) {
      m[3 * v + c]     = s.m[c];
      state[3 * v + c] = c ? 0 : (PetscScalar)s.state;
    }
  }
}

void MSimMeshObstacleSetSides(MSimMeshObstacle mo, PetscInt n, const PetscScalar m[], const PetscScalar state[])
{
  typedef _n_MSimMeshObstacle M;
  mo->side.assign((size_t)n, M::Side{{0, 0, 0}, M::SIDE_NEW});
  for (PetscInt v = 0; v < n; v++) {
    const PetscScalar code = state[3 * v];
    M::Side          &s    = mo->side[(size_t)v];
    s.state                = code == M::SIDE_OUT ? M::SIDE_OUT : code == M::SIDE_IN ? M::SIDE_IN : code == M::SIDE_FAR ? M::SIDE_FAR : M::SIDE_NEW; /* any other number (a damaged file): no side known */
    for (int c = 0; c < 3; c++) s.m[c] = m[3 * v + c];
  }
}
