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
     tests every vertex);
     a ray that passes within roundoff of an edge or vertex is thrown away and another direction
     tried (the degenerate cases that break parity). An open surface has no inside: either side,
     at distance >= thickness.
   - Safe step: with no thickness, 0.8 of the move's first crossing of the surface (a box query on
     the tree, then each triangle's exact crossing), as for the analytic shapes. With a thickness, conservative advancement (Li et al.
     2021, "Codimensional IPC", additive CCD without the additive part): the distance is
     1-Lipschitz, so moving by 0.9 d/|u| along u can never reach the shell; repeat until the step
     is covered or the gap is a tenth of the start's. The segment x -> x + t u then neither
     crosses the surface nor enters the shell. */
#include <msim/contact.h>
#include <msim/mesh.h>
#include <msim/errors.h>
#include <cmath>
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
  PetscReal             band = PETSC_MAX_REAL; /* the inside test only within this distance */
  /* the last query's answer: the next query's hint (the loops visit a rank's vertices in order,
     neighbours of a cloth or mesh follow each other, so it starts the tree's search close) */
  Tree::Point_and_primitive_id last;
  bool                         has_last = false;
  std::vector<Primitive::Id>   near; /* the cube query's triangles (kept: no allocation per query) */
};

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

/* a closed surface: x inside by the parity of a ray's crossings, retried on a degenerate ray */
static bool Inside(MSimMeshObstacle mo, const PetscReal x[3])
{
  static const PetscReal dirs[6][3] = {
    {0.5773, 0.5774, 0.5775}, {-0.2673, 0.5345, 0.8018}, {0.8729, -0.2182, 0.4364}, {-0.4082, -0.8165, 0.4082}, {0.3015, 0.3015, -0.9045}, {-0.7071, 0.0, -0.7071}};
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
  return false; /* six degenerate rays: a point on the surface itself, which distance 0 refuses anyway */
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

PetscErrorCode MSimMeshObstacleCreate(MPI_Comm comm, const char file[], PetscReal thickness, MSimMeshObstacle *mesh)
{
  std::vector<PetscReal> x;
  std::vector<PetscInt>  tri;
  PetscInt               n[2] = {0, 0};
  PetscMPIInt            rank;

  PetscFunctionBeginUser;
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
  mo->band = band;
}

void MSimMeshObstacleInfo(MSimMeshObstacle mo, const char **file, PetscInt *ntri, PetscBool *closed)
{
  if (file) *file = mo->file.c_str();
  if (ntri) *ntri = (PetscInt)mo->tri.size();
  if (closed) *closed = mo->closed;
}

/* cube_bound: beyond the band, the band itself may stand in as a lower bound (see below); the
   conservative advancement of MSimMeshObstacleSafeStep needs the true distance there (a constant
   lower bound would advance by 0.9 dhat a step and cut a long move short) */
static PetscReal Distance(MSimMeshObstacle mo, const PetscReal x[3], PetscReal n[3], PetscReal H[9], bool cube_bound)
{
  /* beyond the band around the surface's bounding box, the distance to the box is a lower bound
     of the distance to the surface (which lies in the box), and it is all the callers need there:
     the barrier, friction and the contact force skip a vertex farther than dhat < band, a safe step
     shorter than the bound is the whole step, and conservative advancement stays safe on a lower
     bound. Skips the tree's query for most of a cloth draped over a small obstacle. */
  PetscReal db2 = 0, q[3];
  for (int c = 0; c < 3; c++) {
    q[c] = x[c] < mo->lo[c] ? x[c] - mo->lo[c] : (x[c] > mo->hi[c] ? x[c] - mo->hi[c] : 0.0);
    db2 += q[c] * q[c];
  }
  if (db2 > mo->band * mo->band) {
    const PetscReal db = std::sqrt(db2);
    for (int c = 0; c < 3; c++) n[c] = q[c] / db;
    if (H)
      for (int k = 0; k < 9; k++) H[k] = 0;
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
  if (cube_bound && mo->band < PETSC_MAX_REAL) {
    const PetscReal b = mo->band;
    PetscReal       best = PETSC_MAX_REAL;
    mo->near.clear();
    mo->tree.all_intersected_primitives(K::Iso_cuboid_3(Point(x[0] - b, x[1] - b, x[2] - b), Point(x[0] + b, x[1] + b, x[2] + b)), std::back_inserter(mo->near));
    for (const auto &id : mo->near) {
      PetscReal pk[3], ek[3] = {0, 0, 0}, rk = 0;
      int       regk;
      ClosestOnTriangle(x, *id, pk, &regk, ek);
      for (int c = 0; c < 3; c++) rk += (x[c] - pk[c]) * (x[c] - pk[c]);
      if (rk < best) {
        best = rk, T = &*id, region = regk;
        for (int c = 0; c < 3; c++) p[c] = pk[c], e[c] = ek[c];
      }
    }
    if (!T || best > b * b) {
      for (int c = 0; c < 3; c++) n[c] = db2 > 0 ? q[c] / std::sqrt(db2) : (c == 2);
      if (H)
        for (int k = 0; k < 9; k++) H[k] = 0;
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
  const PetscReal sign = mo->closed && r <= mo->band && Inside(mo, x) ? -1.0 : 1.0;
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

PetscReal MSimMeshObstacleDistance(MSimMeshObstacle mo, const PetscReal x[3], PetscReal n[3], PetscReal H[9])
{
  return Distance(mo, x, n, H, true);
}

/* Moller-Trumbore: the time t >= 0 at which o + t d meets T, edges and corners included (within
   roundoff: a segment through an edge counts as a hit, the conservative side); infinity if none */
static PetscReal SegmentHitTime(const PetscReal o[3], const PetscReal d[3], const Triangle &T)
{
  PetscReal e1[3], e2[3], s[3], pv[3], qv[3];
  for (int k = 0; k < 3; k++) e1[k] = T[1][k] - T[0][k], e2[k] = T[2][k] - T[0][k], s[k] = o[k] - T[0][k];
  pv[0] = d[1] * e2[2] - d[2] * e2[1], pv[1] = d[2] * e2[0] - d[0] * e2[2], pv[2] = d[0] * e2[1] - d[1] * e2[0];
  const PetscReal det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
  if (det == 0) return PETSC_INFINITY; /* parallel to the plane: a point outside never meets it */
  const PetscReal u = (s[0] * pv[0] + s[1] * pv[1] + s[2] * pv[2]) / det;
  qv[0] = s[1] * e1[2] - s[2] * e1[1], qv[1] = s[2] * e1[0] - s[0] * e1[2], qv[2] = s[0] * e1[1] - s[1] * e1[0];
  const PetscReal v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det, t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
  const PetscReal tol = 1e-9;
  if (u < -tol || v < -tol || u + v > 1 + tol) return PETSC_INFINITY;
  return t >= 0 ? t : PETSC_INFINITY;
}

PetscReal MSimMeshObstacleSafeStep(MSimMeshObstacle mo, const PetscReal x[3], const PetscReal u[3], PetscReal tmax)
{
  const PetscReal ulen = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  PetscReal       n[3], y[3] = {x[0], x[1], x[2]}, t = 0;

  if (ulen == 0) return PETSC_INFINITY;
  const PetscReal d0 = MSimMeshObstacleDistance(mo, x, n, NULL);
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
    std::vector<Primitive::Id> hit;
    PetscReal                  th = PETSC_INFINITY, lo[3], hi[3];
    const PetscReal            te = PetscMin(tmax, 2 * (mo->diam + d0) / ulen), eps = 1e-9 * (mo->diam + te * ulen);
    for (int c = 0; c < 3; c++) lo[c] = PetscMin(x[c], x[c] + te * u[c]) - eps, hi[c] = PetscMax(x[c], x[c] + te * u[c]) + eps;
    mo->tree.all_intersected_primitives(K::Iso_cuboid_3(Point(lo[0], lo[1], lo[2]), Point(hi[0], hi[1], hi[2])), std::back_inserter(hit));
    for (const auto &id : hit) th = PetscMin(th, SegmentHitTime(x, u, *id));
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
