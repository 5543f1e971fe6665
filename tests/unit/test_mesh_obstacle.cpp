/* The mesh obstacle's candidate cache (src/contact/mesh_obstacle.cpp, MeshCell) against the tree
   query it replaces and against brute force over every triangle. Random walks of points near a
   closed non-convex surface (examples/meshes/bunny.off, 3,674 triangles) and an open one
   (tests/data/meshes/sheet.obj), with moves from 1e-5 to 2 bands long (so a point stays in its cell,
   crosses into the next or jumps far, and crosses the surface), and with thickness 0 and 0.3 band:
   - the cached distance, normal and Hessian equal the tree path's (MSimMeshObstacleSetCache off) to
     roundoff (the cells' candidates are gathered by box overlap and their distance to the cell's
     centre, the tree path by CGAL's exact triangle-cube test: the same triangles);
   - the distance equals brute force's: the nearest of all triangles (the closest point computed
     here by another method: the plane's foot if inside the triangle, else the nearest of the three
     edges), signed by the parity of a ray's crossings counted over all triangles, where within the
     band; the band itself (the documented lower bound) beyond it;
   - the safe step of random moves from outside points equals the tree path's exactly;
   - the cache is reused: far fewer rebuilds (the MSimMeshCells event) than queries;
   - the per-vertex queries (MSimMeshObstacleDistanceVertex, SafeStepVertex: each walk one vertex,
     asking at its new point, again at its last one, and at a point 1e-3 band away) give the plain
     queries' numbers bit for bit, with both their shortcuts (a point asked again, a far point that
     moved little) taken;
   - the same for free walks from anywhere in the surface's box widened by band, with short moves
     (the far skip's balls around the cells' centres, in cells with and without candidates and in
     empty coarse cells), and that those balls are used; the clearance they give
     (MSimMeshObstacleVertexClearance) lies between band and the distance, and a point within it is
     answered beyond band;
   - a mesh far from the origin (FarFromOrigin): the cached distance is the tree path's bit for bit
     where two sheets are nearly equally near;
   - thin triangles (Slivers): the same, where a sliver is nearer than a square by 1e-7 of the distance;
   - concave creases (Creases): the barrier summed over a point's contacts has no jump along paths
     across a faceted cup's panels and up a thin fin's side, each counting one contact per wall;
   - rim corners (RimCorners): no jump and no kink where an open box's walls end at its rim.
   Each rank walks its own points (the queries are local): the same checks at 1 and 2 ranks. */
#include "harness.h"
#include <msim/contact.h>
#include <cmath>
#include <random>
#include <vector>
#include <array>
#include <map>

typedef std::array<double, 3> V3;

static V3     Sub(const V3 &a, const V3 &b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
static double Dot(const V3 &a, const V3 &b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static V3     Cross(const V3 &a, const V3 &b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }

/* squared distance from x to the segment [a, b] */
static double SegmentDistance2(const V3 &x, const V3 &a, const V3 &b)
{
  const V3     ab = Sub(b, a), ax = Sub(x, a);
  const double t = std::min(1.0, std::max(0.0, Dot(ax, ab) / Dot(ab, ab)));
  const V3     q = {a[0] + t * ab[0] - x[0], a[1] + t * ab[1] - x[1], a[2] + t * ab[2] - x[2]};
  return Dot(q, q);
}

/* squared distance from x to the triangle: the plane's foot if it lies inside, else the edges */
static double TriangleDistance2(const V3 &x, const V3 &a, const V3 &b, const V3 &c)
{
  const V3     n = Cross(Sub(b, a), Sub(c, a));
  const double nn = Dot(n, n), h = Dot(Sub(x, a), n) / nn;
  const V3     f = {x[0] - h * n[0], x[1] - h * n[1], x[2] - h * n[2]};
  const double wa = Dot(Cross(Sub(b, f), Sub(c, f)), n), wb = Dot(Cross(Sub(c, f), Sub(a, f)), n), wc = Dot(Cross(Sub(a, f), Sub(b, f)), n);
  if (wa >= 0 && wb >= 0 && wc >= 0) return h * h * nn;
  return std::min({SegmentDistance2(x, a, b), SegmentDistance2(x, b, c), SegmentDistance2(x, c, a)});
}

struct Surface {
  std::vector<V3>                 v;
  std::vector<std::array<int, 3>> t;
  double                          lo[3], hi[3], diam;
};

/* OBJ ("v x y z", "f i j k") or OFF, as the two files here are written */
static PetscErrorCode ReadSurface(const char *path, Surface *s)
{
  FILE *f;
  char  line[512];

  PetscFunctionBeginUser;
  f = fopen(path, "r");
  PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot open %s", path);
  if (strstr(path, ".off")) {
    int nv, nt, ne;
    PetscCheck(fgets(line, sizeof(line), f) && fscanf(f, "%d %d %d", &nv, &nt, &ne) == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: bad header", path);
    s->v.resize(nv), s->t.resize(nt);
    for (auto &p : s->v) PetscCheck(fscanf(f, "%lf %lf %lf", &p[0], &p[1], &p[2]) == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: bad vertex", path);
    for (auto &q : s->t) {
      int k;
      PetscCheck(fscanf(f, "%d %d %d %d", &k, &q[0], &q[1], &q[2]) == 4 && k == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: bad face", path);
    }
  } else {
    while (fgets(line, sizeof(line), f)) {
      V3                 p;
      std::array<int, 3> q;
      if (sscanf(line, "v %lf %lf %lf", &p[0], &p[1], &p[2]) == 3) s->v.push_back(p);
      else if (sscanf(line, "f %d %d %d", &q[0], &q[1], &q[2]) == 3) s->t.push_back({q[0] - 1, q[1] - 1, q[2] - 1});
    }
  }
  fclose(f);
  for (int c = 0; c < 3; c++) s->lo[c] = 1e300, s->hi[c] = -1e300;
  for (const auto &p : s->v)
    for (int c = 0; c < 3; c++) s->lo[c] = std::min(s->lo[c], p[c]), s->hi[c] = std::max(s->hi[c], p[c]);
  s->diam = std::sqrt((s->hi[0] - s->lo[0]) * (s->hi[0] - s->lo[0]) + (s->hi[1] - s->lo[1]) * (s->hi[1] - s->lo[1]) + (s->hi[2] - s->lo[2]) * (s->hi[2] - s->lo[2]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* brute force: the distance to the nearest triangle; *side -1 inside (odd crossings of a ray over
   all triangles), 1 outside, 0 undecided (every ray tried passed within 1e-7 of an edge) */
static double BruteForce(const Surface &s, const V3 &x, bool closed, int *side)
{
  double best = 1e300;
  for (const auto &q : s.t) best = std::min(best, TriangleDistance2(x, s.v[q[0]], s.v[q[1]], s.v[q[2]]));
  *side = 1;
  if (!closed) return std::sqrt(best);
  const V3 dirs[3] = {{0.2672612419, 0.5345224838, 0.8017837257}, {-0.6666666667, 0.3333333333, 0.6666666667}, {0.4082482905, -0.8164965809, -0.4082482905}};
  *side = 0;
  for (const V3 &d : dirs) {
    int  count = 0;
    bool clear = true;
    for (const auto &q : s.t) { /* the ray x + t d, t > 0, against the triangle by barycentric volumes */
      const V3 &a = s.v[q[0]], &b = s.v[q[1]], &c = s.v[q[2]];
      const V3  n = Cross(Sub(b, a), Sub(c, a));
      const double dn = Dot(d, n);
      if (std::abs(dn) < 1e-9 * std::sqrt(Dot(n, n))) continue; /* parallel: no crossing */
      const double t = Dot(Sub(a, x), n) / dn;
      if (t <= 0) continue;
      const V3     p = {x[0] + t * d[0], x[1] + t * d[1], x[2] + t * d[2]};
      const double wa = Dot(Cross(Sub(b, p), Sub(c, p)), n) / Dot(n, n), wb = Dot(Cross(Sub(c, p), Sub(a, p)), n) / Dot(n, n), wc = 1 - wa - wb;
      if (std::min({wa, wb, wc}) > 1e-7) count++;
      else if (std::min({wa, wb, wc}) > -1e-7) clear = false;
    }
    if (clear) {
      *side = count % 2 ? -1 : 1;
      break;
    }
  }
  return std::sqrt(best);
}

static PetscErrorCode Walks(const char *path, double band_frac, double thick_frac, PetscMPIInt rank)
{
  Surface          s;
  MSimMeshObstacle mo;
  std::mt19937     gen(11 + 7 * rank);
  std::uniform_real_distribution<double> U(0, 1);
  std::normal_distribution<double>       N(0, 1);
  PetscInt         nq = 0, nbad_tree = 0, nbad_bf = 0, nbad_step = 0, nbf = 0, nsteps = 0, nside = 0, nlow = 0, nbad_vertex = 0;
  PetscInt64       vc[5];
  PetscInt         nfree = 0, nclear = 0, nbad_clear = 0;
  double           worst_tree = 0, worst_bf = 0;
  PetscLogEvent      ev;
  PetscEventPerfInfo before, after;

  PetscFunctionBeginUser;
  PetscCall(ReadSurface(path, &s));
  const double band = band_frac * s.diam, thick = thick_frac * band;
  PetscCall(MSimMeshObstacleCreate(PETSC_COMM_WORLD, path, thick, &mo));
  PetscBool closed;
  MSimMeshObstacleInfo(mo, NULL, NULL, &closed);
  MSimMeshObstacleSetBand(mo, band);
  PetscCall(PetscLogEventGetId("MSimMeshCells", &ev));
  PetscCall(PetscLogEventGetPerfInfo(0, ev, &before));
  for (int walk = 0; walk < 24; walk++) {
    /* start on a random triangle, offset along its normal by up to 1.5 bands either way */
    const auto  &q = s.t[(size_t)(U(gen) * s.t.size()) % s.t.size()];
    double       w0 = U(gen), w1 = U(gen);
    if (w0 + w1 > 1) w0 = 1 - w0, w1 = 1 - w1;
    const V3     n  = Cross(Sub(s.v[q[1]], s.v[q[0]]), Sub(s.v[q[2]], s.v[q[0]]));
    const double nl = std::sqrt(Dot(n, n)), off = (2 * U(gen) - 1) * 1.5 * band;
    V3           x;
    for (int c = 0; c < 3; c++) x[c] = s.v[q[0]][c] + w0 * (s.v[q[1]][c] - s.v[q[0]][c]) + w1 * (s.v[q[2]][c] - s.v[q[0]][c]) + off * n[c] / nl;
    for (int step = 0; step < 120; step++) {
      /* the next point: a random direction, log-uniform length in [1e-5, 2] bands */
      const V3     dir = {N(gen), N(gen), N(gen)};
      const double len = band * std::pow(10.0, -5 + 5.3 * U(gen)) / std::sqrt(Dot(dir, dir));
      V3           y;
      for (int c = 0; c < 3; c++) y[c] = x[c] + len * dir[c];
      double nc[3], nt[3], Hc[9], Ht[9];
      MSimMeshObstacleSetCache(mo, PETSC_TRUE);
      const double dc = MSimMeshObstacleDistance(mo, y.data(), nc, Hc);
      MSimMeshObstacleSetCache(mo, PETSC_FALSE);
      const double dt = MSimMeshObstacleDistance(mo, y.data(), nt, Ht);
      nq++;
      /* the tree path: the same answer to roundoff (the Hessian scales as 1/r) */
      double err = std::abs(dc - dt) / band;
      const double r = std::abs(dt + thick);
      for (int c = 0; c < 3; c++) err = std::max(err, std::abs(nc[c] - nt[c]));
      for (int k = 0; k < 9; k++) err = std::max(err, std::abs(Hc[k] - Ht[k]) * std::max(r, 1e-300));
      worst_tree = std::max(worst_tree, err);
      if (err > 1e-10) nbad_tree++;
      /* the vertex queries: bit for bit the plain ones, at y, at the walk's last point x (asked the
         step before: answered again) and near y (skipped where y was far, answered from y's near set
         where y was near) */
      MSimMeshObstacleSetCache(mo, PETSC_TRUE);
      {
        const V3 z = {y[0] + 1e-3 * band, y[1], y[2]};
        const V3 *pts[3] = {&y, &x, &z};
        for (const V3 *p : pts) {
          double nv[3], Hv[9], np[3], Hp[9];
          const double dv = MSimMeshObstacleDistanceVertex(mo, walk, p->data(), nv, Hv), dp = MSimMeshObstacleDistance(mo, p->data(), np, Hp);
          bool same = dv == dp;
          for (int c = 0; c < 3; c++) same = same && nv[c] == np[c];
          for (int k = 0; k < 9; k++) same = same && Hv[k] == Hp[k];
          nbad_vertex += !same;
        }
      }
      /* brute force */
      int          side;
      const double rb = BruteForce(s, y, closed, &side);
      if (rb < band * (1 - 1e-9) && rb > 1e-7 * s.diam && side != 0) {
        const double e = std::abs(dc - (side * rb - thick)) / band;
        worst_bf = std::max(worst_bf, e);
        if (e > 1e-10) nbad_bf++;
        nbf++;
        nside += side < 0;
      } else if (rb > band * (1 + 1e-9)) {
        /* beyond the band a lower bound: the distance to the surface's box where that exceeds the
           band, else the band (less the thickness, as every distance) */
        double db = 0;
        for (int c = 0; c < 3; c++) {
          const double e = y[c] < s.lo[c] ? s.lo[c] - y[c] : (y[c] > s.hi[c] ? y[c] - s.hi[c] : 0.0);
          db += e * e;
        }
        db = std::sqrt(db);
        if (std::abs(dc - ((db > band ? db : band) - thick)) > 1e-12 * band) nbad_bf++;
        nlow++;
      }
      /* the safe step of a random move from an outside point */
      if (dc > 0) {
        const V3     ud  = {N(gen), N(gen), N(gen)};
        const double ul  = band * std::pow(10.0, -3 + 3.5 * U(gen)) / std::sqrt(Dot(ud, ud));
        const double u[3] = {ul * ud[0], ul * ud[1], ul * ud[2]};
        MSimMeshObstacleSetCache(mo, PETSC_TRUE);
        const double sc = MSimMeshObstacleSafeStep(mo, y.data(), u, 1.0);
        MSimMeshObstacleSetCache(mo, PETSC_FALSE);
        const double st = MSimMeshObstacleSafeStep(mo, y.data(), u, 1.0);
        if (!(sc == st || (std::abs(sc - st) <= 1e-12 * std::abs(st)))) nbad_step++;
        MSimMeshObstacleSetCache(mo, PETSC_TRUE);
        if (!(MSimMeshObstacleSafeStepVertex(mo, walk, y.data(), u, 1.0) == sc)) nbad_vertex++;
        nsteps++;
      }
      /* keep near the surface: a point beyond 3 bands starts over from where it was */
      if (rb < 3 * band) x = y;
    }
  }
  /* free walks (vertices 100 on; the flat sheet's box has no room beyond band, so its walks only
     compare): from a uniform point of the box widened by band, moves of 1e-3
     to 2 bands, each point's vertex query against the plain one; a point leaving the widened box
     starts over */
  for (int walk = 0; walk < 8; walk++) {
    V3 x;
    for (int c = 0; c < 3; c++) x[c] = s.lo[c] - band + U(gen) * (s.hi[c] - s.lo[c] + 2 * band);
    for (int step = 0; step < 150; step++) {
      const V3     dir = {N(gen), N(gen), N(gen)};
      const double len = band * std::pow(10.0, -3 + 3.3 * U(gen)) / std::sqrt(Dot(dir, dir));
      bool         in  = true;
      for (int c = 0; c < 3; c++) {
        x[c] += len * dir[c];
        in = in && x[c] > s.lo[c] - band && x[c] < s.hi[c] + band;
      }
      if (!in)
        for (int c = 0; c < 3; c++) x[c] = s.lo[c] - band + U(gen) * (s.hi[c] - s.lo[c] + 2 * band);
      double       nv[3], Hv[9], np[3], Hp[9];
      const double dv = MSimMeshObstacleDistanceVertex(mo, 100 + walk, x.data(), nv, Hv), dp = MSimMeshObstacleDistance(mo, x.data(), np, Hp);
      bool         same = dv == dp;
      for (int c = 0; c < 3; c++) same = same && nv[c] == np[c];
      for (int k = 0; k < 9; k++) same = same && Hv[k] == Hp[k];
      nbad_vertex += !same;
      nfree++;
      /* the clearance where the answer is "beyond band": at most the distance (brute force, less the
         thickness), and a point of the neighbourhood it certifies is answered beyond band too */
      const double L = MSimMeshObstacleVertexClearance(mo, 100 + walk, x.data());
      if (dv == band - thick && L > -1e300) {
        int          side;
        const V3     u  = {N(gen), N(gen), N(gen)};
        const double rb = BruteForce(s, x, false, &side), rad = (L - (band - thick)) * U(gen) / std::sqrt(Dot(u, u));
        const V3     pz = {x[0] + rad * u[0], x[1] + rad * u[1], x[2] + rad * u[2]};
        double       nz[3];
        nbad_clear += !(L <= rb - thick && L >= band - thick) || !(MSimMeshObstacleDistance(mo, pz.data(), nz, NULL) >= band - thick);
        nclear++;
      }
    }
  }
  PetscCall(PetscLogEventGetPerfInfo(0, ev, &after));
  const PetscInt rebuilds = after.count - before.count;
  MSimMeshObstacleVertexCounts(mo, vc);
  NOTE("%s (band %.3g, thickness %.3g): %d queries, %d against brute force within the band (%d inside), %d beyond it, %d safe steps, %d cell rebuilds on rank 0; worst |cached - tree| %.2e, |cached - brute force| %.2e (in bands)\n", path, band, thick, (int)nq, (int)nbf, (int)nside, (int)nlow, (int)nsteps, (int)rebuilds, worst_tree, worst_bf);
  CHECK(nbad_tree == 0, "%s: %d of %d cached queries differ from the tree's (worst %.3e)", path, (int)nbad_tree, (int)nq, worst_tree);
  CHECK(nbad_bf == 0, "%s: %d cached queries differ from brute force (worst %.3e)", path, (int)nbad_bf, worst_bf);
  CHECK(nbf > nq / 4, "%s: only %d of %d queries within the band were checked against brute force", path, (int)nbf, (int)nq);
  CHECK(!closed || nside > nbf / 10, "%s: only %d of %d checked points were inside: the side is not exercised", path, (int)nside, (int)nbf);
  CHECK(nbad_step == 0, "%s: %d of %d cached safe steps differ from the tree's", path, (int)nbad_step, (int)nsteps);
  NOTE("%s: vertex queries in the box's band (%d of them on free walks, %d clearances checked): %lld answered again, %lld skipped as far (%lld by a cell centre's ball alone), %lld in full, %lld from the near set\n", path, (int)nfree, (int)nclear, (long long)vc[0], (long long)vc[1], (long long)vc[4], (long long)vc[2], (long long)vc[3]);
  CHECK(nbad_vertex == 0, "%s: %d vertex queries (distance, normal, Hessian or safe step) differ from the plain ones", path, (int)nbad_vertex);
  CHECK(nbad_clear == 0 && (nclear > nfree / 10 || !closed), "%s: the vertex clearance: %d of %d wrong (below band, above the distance, or a point it certifies answered within band)", path, (int)nbad_clear, (int)nclear);
  CHECK(vc[4] > nfree / 10 || !closed, "%s: the far skip's cell-centre balls not exercised (%lld skips by them in %d free-walk queries)", path, (long long)vc[4], (int)nfree);
  /* the far skip needs points in the box's band yet beyond band from the surface: the bunny's box
     has them, the flat sheet's hardly any */
  CHECK(vc[0] > nq / 10 && (vc[1] > nq / 10 || !closed) && vc[3] > nq / 10, "%s: the vertex queries' shortcuts not exercised (%lld answered again, %lld skipped, %lld from the near set)", path, (long long)vc[0], (long long)vc[1], (long long)vc[3]);
  CHECK(rebuilds > 0 && rebuilds < nq / 2, "%s: %d cell rebuilds for %d cached queries (and as many safe steps): the cache is not reused", path, (int)rebuilds, (int)nq);
  MSimMeshObstacleDestroy(&mo);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A mesh far from the origin: two parallel square sheets (side 1, 0.02 apart, tilted) moved by
   ~3e6, where a coordinate's roundoff (~5e-10) dwarfs 1e-12 of the mesh's size. Points halfway
   between them, nearer to one sheet by up to 1e-9: the cached query's loop passes over a candidate
   whose distance to the cell's centre, or whose plane, shows it farther than the nearest found so
   far, less a roundoff margin; a margin scaled by the mesh's size alone (and, for the first, taken
   on the wrong side) passed over the nearer sheet in 41 of these 2,000 points and answered with the
   other one's distance. The tree path compares the same computed distances of both sheets, so its
   distance is the least one bit for bit (the normals may differ: at these coordinates the two
   sheets' computed distances are often exactly equal, and the tie goes to the first in each
   path's own order). */
static PetscErrorCode FarFromOrigin(PetscMPIInt rank)
{
  const double     O[3] = {3.1e6, -2.3e6, 1.7e6}, gap = 0.02, band = 0.05;
  const V3         u = {0.8, 0.36, 0.48}, w = {-0.6, 0.48, 0.64}, nrm = Cross(u, w); /* orthonormal, the sheets' axes */
  char             path[PETSC_MAX_PATH_LEN];
  int              pid = (int)getpid();
  MSimMeshObstacle mo;
  std::mt19937     gen(5 + 3 * rank);
  std::uniform_real_distribution<double> U(0, 1);
  PetscInt         nq = 0, nbad = 0;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD));
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_mesh_far_%d.obj", pid));
  if (!rank) {
    FILE *f = fopen(path, "w");
    PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
    for (int sh = 0; sh < 2; sh++)
      for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) fprintf(f, "v %.17g %.17g %.17g\n", O[0] + i * u[0] + j * w[0] + sh * gap * nrm[0], O[1] + i * u[1] + j * w[1] + sh * gap * nrm[1], O[2] + i * u[2] + j * w[2] + sh * gap * nrm[2]);
    for (int sh = 0; sh < 2; sh++) fprintf(f, "f %d %d %d\nf %d %d %d\n", 4 * sh + 1, 4 * sh + 2, 4 * sh + 4, 4 * sh + 1, 4 * sh + 4, 4 * sh + 3);
    fclose(f);
  }
  PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD));
  PetscCall(MSimMeshObstacleCreate(PETSC_COMM_WORLD, path, 0.0, &mo));
  MSimMeshObstacleSetBand(mo, band);
  for (int k = 0; k < 2000; k++) {
    const double a = 0.1 + 0.8 * U(gen), b = 0.1 + 0.8 * U(gen), off = 0.5 * gap + (2 * U(gen) - 1) * 1e-9;
    V3           x;
    for (int c = 0; c < 3; c++) x[c] = O[c] + a * u[c] + b * w[c] + off * nrm[c];
    double nc[3], nt[3];
    MSimMeshObstacleSetCache(mo, PETSC_TRUE);
    const double dc = MSimMeshObstacleDistance(mo, x.data(), nc, NULL);
    MSimMeshObstacleSetCache(mo, PETSC_FALSE);
    const double dt = MSimMeshObstacleDistance(mo, x.data(), nt, NULL);
    nbad += dc != dt;
    nq++;
  }
  MSimMeshObstacleDestroy(&mo);
  PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD));
  if (!rank) remove(path);
  NOTE("two sheets 0.02 apart at ~3e6 from the origin: %d near ties between them\n", (int)nq);
  CHECK(nbad == 0, "far from the origin: %d of %d cached distances differ from the tree's (a nearer sheet passed over)", (int)nbad, (int)nq);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* thin triangles (Slivers): the cached path's bounds from a triangle's plane and edge lines come
   from a computed normal that is off by about eps lmax^2 / (2 area), so they are not bounds for a
   sliver. Each case is a sliver (height delta of its long edge, 1e-6 to 1e-11) and a small square
   facing x, x at D above the sliver's long edge (its nearest point there) and the square's centre
   D (1 + 1e-7) from x: the sliver is the nearer by 1e-7 D, less than its bound's error. The cached
   distance must be the tree path's bit for bit (before thin triangles were kept out of the bounds,
   the square was picked in 5 of these 300 cases at 1 rank). */
static PetscErrorCode Slivers(PetscMPIInt rank)
{
  char                                   path[PETSC_MAX_PATH_LEN];
  std::mt19937                           gen(11 + 7 * rank);
  std::uniform_real_distribution<double> U(0, 1);
  PetscInt                               nq = 0, nbad = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_mesh_sliver_%d_%d.obj", (int)getpid(), (int)rank));
  auto unit = [](V3 a) {
    const double l = std::sqrt(Dot(a, a));
    return V3{a[0] / l, a[1] / l, a[2] / l};
  };
  for (int k = 0; k < 300; k++) {
    const double delta = std::pow(10.0, -6 - 5 * U(gen)), D = 0.05 + 0.05 * U(gen), s = 0.2 + 0.6 * U(gen), h = 0.005;
    const V3     a = {U(gen), U(gen), U(gen)}, b = {U(gen), U(gen), U(gen)}, e = Sub(b, a), r = {U(gen) - 0.5, U(gen) - 0.5, U(gen) - 0.5};
    const V3     p = unit(Cross(e, r)), q = unit(Cross(e, p)), u = unit({U(gen) - 0.5, U(gen) - 0.5, U(gen) - 0.5});
    const double le = std::sqrt(Dot(e, e));
    V3           c, x, m, v = unit(Cross(u, r)), w = Cross(u, v);
    for (int i = 0; i < 3; i++) {
      c[i] = a[i] + 0.5 * e[i] + delta * le * p[i];
      x[i] = a[i] + s * e[i] + D * q[i];
      m[i] = x[i] + D * (1 + 1e-7) * u[i]; /* the square's centre */
    }
    FILE *f = fopen(path, "w");
    PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
    fprintf(f, "v %.17g %.17g %.17g\nv %.17g %.17g %.17g\nv %.17g %.17g %.17g\n", a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]);
    for (int j = 0; j < 4; j++) {
      const double sv = (j & 1) ? h : -h, sw = (j & 2) ? h : -h;
      fprintf(f, "v %.17g %.17g %.17g\n", m[0] + sv * v[0] + sw * w[0], m[1] + sv * v[1] + sw * w[1], m[2] + sv * v[2] + sw * w[2]);
    }
    fprintf(f, "f 1 2 3\nf 4 5 7\nf 4 7 6\n");
    fclose(f);
    MSimMeshObstacle mo;
    double           nc[3], nt[3];
    PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, 0.0, &mo));
    MSimMeshObstacleSetBand(mo, 0.2);
    MSimMeshObstacleSetCache(mo, PETSC_TRUE);
    const double dc = MSimMeshObstacleDistance(mo, x.data(), nc, NULL);
    MSimMeshObstacleSetCache(mo, PETSC_FALSE);
    const double dt = MSimMeshObstacleDistance(mo, x.data(), nt, NULL);
    MSimMeshObstacleDestroy(&mo);
    nbad += dc != dt;
    nq++;
  }
  remove(path);
  NOTE("slivers of height 1e-11 to 1e-6 of their long edge beside a square 1e-7 D farther: %d cases\n", (int)nq);
  CHECK(nbad == 0, "slivers: %d of %d cached distances differ from the tree's (the nearer sliver passed over)", (int)nbad, (int)nq);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the features' sum of mesh_obstacle.cpp's FeatureSum, computed here by brute force over every
   face, edge and vertex of s (edge weight m - 1 for m triangles, vertex weight 1 - triangles +
   edges' weights), each b(r - th) at its true distance r; and b(nearest - th) */
static double FeatureEnergy(const Surface &s, const V3 &x, double th, double dhat, double *nearest)
{
  std::map<std::pair<int, int>, int> m;
  std::map<int, double>              w;
  for (const auto &q : s.t)
    for (int k = 0; k < 3; k++) {
      m[{std::min(q[k], q[(k + 1) % 3]), std::max(q[k], q[(k + 1) % 3])}]++;
      w[q[k]] = 1;
    }
  for (const auto &q : s.t)
    for (int k = 0; k < 3; k++) w[q[k]] -= 1;
  for (const auto &e : m) w[e.first.first] += e.second - 1, w[e.first.second] += e.second - 1;
  auto b = [&](double r) {
    double e = 0, db, d2b;
    if (r - th < dhat) MSimBarrier(r - th, dhat, &e, &db, &d2b);
    return e;
  };
  double sum = 0, best = 1e300;
  for (const auto &q : s.t) {
    const double r = std::sqrt(TriangleDistance2(x, s.v[q[0]], s.v[q[1]], s.v[q[2]]));
    sum += b(r), best = std::min(best, r);
  }
  for (const auto &e : m) sum -= (e.second - 1) * b(std::sqrt(SegmentDistance2(x, s.v[e.first.first], s.v[e.first.second])));
  for (const auto &v : w) sum += v.second * b(std::sqrt(Dot(Sub(x, s.v[v.first]), Sub(x, s.v[v.first]))));
  *nearest = b(best);
  return sum;
}

/* the barrier summed over x's contacts (MSimObstacleContacts' rule: the nearest and its creases'),
   its gradient; dhat: b's */
static double ContactEnergy(MSimMeshObstacle mo, const V3 &x, double dhat, V3 *g, int *nc)
{
  double          nn[3], e = 0;
  MSimMeshCreases cr;
  const double    d = MSimMeshObstacleDistanceVertex(mo, -1, x.data(), nn, NULL, &cr);
  *nc               = 0;
  *g                = {0, 0, 0};
  auto add = [&](double dd, const double *nv) {
    double b, db, d2b;
    if (dd >= dhat) return;
    MSimBarrier(dd, dhat, &b, &db, &d2b);
    e += b;
    for (int c = 0; c < 3; c++) (*g)[c] += db * nv[c];
    (*nc)++;
  };
  add(d, nn);
  for (PetscInt k = 0; k < cr.k; k++) add(cr.d[k], cr.n[k]);
  return e;
}

/* writes s to path as OBJ */
static PetscErrorCode WriteSurface(const char *path, const Surface &s)
{
  PetscFunctionBeginUser;
  FILE *f = fopen(path, "w");
  PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
  for (const V3 &v : s.v) fprintf(f, "v %.17g %.17g %.17g\n", v[0], v[1], v[2]);
  for (const auto &t : s.t) fprintf(f, "f %d %d %d\n", t[0] + 1, t[1] + 1, t[2] + 1);
  fclose(f);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* an open tray: the floor [lo, hi]^2 at z = 0 as an n x n grid, four walls up to z = 0.4 at angle
   (degrees, inside) to it, open at the top (tests/contact_mesh.py's trays: n = 1); each wall a fan
   from its rim corner over the floor's side, and one triangle */
static Surface Tray(double angle, int n, double lo = 0.3, double hi = 0.7)
{
  const double o = 0.4 / std::tan((180 - angle) * 3.14159265358979323846 / 180), hw = hi - lo;
  Surface      s;
  auto         at = [&](int i, int j) { return i * (n + 1) + j; };
  for (int i = 0; i <= n; i++)
    for (int j = 0; j <= n; j++) s.v.push_back({lo + hw * i / n, lo + hw * j / n, 0});
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) s.t.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)}), s.t.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
  const int    top = (int)s.v.size();
  const double cx[4] = {lo - o, hi + o, hi + o, lo - o}, cy[4] = {lo - o, lo - o, hi + o, hi + o};
  for (int k = 0; k < 4; k++) s.v.push_back({cx[k], cy[k], 0.4});
  for (int k = 0; k < 4; k++) { /* wall k: the floor's side from corner k to corner k + 1 */
    std::vector<int> side;
    for (int i = 0; i <= n; i++) side.push_back(k == 0 ? at(i, 0) : k == 1 ? at(n, i) : k == 2 ? at(n - i, n) : at(0, n - i));
    const int ta = top + k, tb = top + (k + 1) % 4;
    for (int i = 0; i < n; i++) s.t.push_back({side[i], side[i + 1], tb});
    s.t.push_back({side[0], tb, ta});
  }
  for (int c = 0; c < 3; c++) { /* the box, as ReadSurface sets it */
    s.lo[c] = 1e300, s.hi[c] = -1e300;
    for (const V3 &v : s.v) s.lo[c] = std::min(s.lo[c], v[c]), s.hi[c] = std::max(s.hi[c], v[c]);
  }
  return s;
}

/* a faceted bowl: a floor of n triangles (an n-gon of radius r0 at z = 0 around (0.5, 0.5)) and n
   panels, each two triangles, up to z = 0.4 at angle (degrees, inside) to it, open at the top */
static Surface Bowl(int n, double angle, double r0)
{
  const double PI = 3.14159265358979323846, o = 0.4 / std::tan((180 - angle) * PI / 180);
  Surface      s;
  s.v.push_back({0.5, 0.5, 0});
  for (int ring = 0; ring < 2; ring++)
    for (int k = 0; k < n; k++) s.v.push_back({0.5 + (r0 + ring * o) * std::cos(2 * PI * (k + 0.5) / n), 0.5 + (r0 + ring * o) * std::sin(2 * PI * (k + 0.5) / n), 0.4 * ring});
  for (int k = 0; k < n; k++) {
    const int a = 1 + k, b = 1 + (k + 1) % n;
    s.t.push_back({0, a, b}), s.t.push_back({a, b + n, b}), s.t.push_back({a, a + n, b + n});
  }
  return s;
}

/* a UV sphere of radius 0.5 around (0.5, 0.5, 0), nu points a ring, nv bands pole to pole; open:
   its upper half alone (a dome, open at the equator) */
static Surface Ball(int nu, int nv, bool open)
{
  const double PI = 3.14159265358979323846;
  Surface      s;
  const int    rings = open ? nv / 2 : nv - 1;
  s.v.push_back({0.5, 0.5, 0.5});
  for (int i = 1; i <= rings; i++)
    for (int j = 0; j < nu; j++) s.v.push_back({0.5 + 0.5 * std::sin(PI * i / nv) * std::cos(2 * PI * j / nu), 0.5 + 0.5 * std::sin(PI * i / nv) * std::sin(2 * PI * j / nu), 0.5 * std::cos(PI * i / nv)});
  for (int j = 0; j < nu; j++) s.t.push_back({0, 1 + j, 1 + (j + 1) % nu});
  for (int i = 0; i + 1 < rings; i++)
    for (int j = 0; j < nu; j++) {
      const int a = 1 + i * nu + j, b = 1 + i * nu + (j + 1) % nu;
      s.t.push_back({a, a + nu, b + nu}), s.t.push_back({a, b + nu, b});
    }
  if (!open) {
    s.v.push_back({0.5, 0.5, -0.5});
    const int S = (int)s.v.size() - 1, base = 1 + (rings - 1) * nu;
    for (int j = 0; j < nu; j++) s.t.push_back({S, base + (j + 1) % nu, base + j});
  }
  return s;
}

/* The barrier summed over a point's contacts (ContactEnergy) along a straight path: each step's
   change is within twice the larger end's gradient times the step (no jump; the sum may have a
   kink), the path's most contacts at one point, (kink) the largest change of the gradient between
   neighbouring points, which halves with the step where the gradient is continuous and stays where
   it jumps, and (fd) the largest difference of the gradient along the path from the energy's
   central difference (h = 1e-7), relative to the gradient */
static PetscErrorCode CreaseSweep(MSimMeshObstacle mo, double dhat, const V3 &x0, const V3 &dir, int n, double *worst, int *most, double *kink = NULL, double *fd = NULL)
{
  PetscFunctionBeginUser;
  V3           g0, g1, gh;
  double       e0 = 0;
  int          nc, nh;
  const double len = std::sqrt(Dot(dir, dir)), hfd = 1e-7;
  *worst = 0, *most = 0;
  if (kink) *kink = 0;
  if (fd) *fd = 0;
  for (int i = 0; i <= n; i++) {
    const V3     x  = {x0[0] + dir[0] * i / n, x0[1] + dir[1] * i / n, x0[2] + dir[2] * i / n};
    const double e1 = ContactEnergy(mo, x, dhat, &g1, &nc);
    if (i) {
      const V3 dg = Sub(g1, g0);
      *worst      = std::max(*worst, std::abs(e1 - e0) / (2 * std::max(std::sqrt(Dot(g0, g0)), std::sqrt(Dot(g1, g1))) * len / n + 1e-300));
      if (kink) *kink = std::max(*kink, std::sqrt(Dot(dg, dg)));
    }
    if (fd && nc) {
      const V3     xp = {x[0] + hfd * dir[0] / len, x[1] + hfd * dir[1] / len, x[2] + hfd * dir[2] / len}, xm = {x[0] - hfd * dir[0] / len, x[1] - hfd * dir[1] / len, x[2] - hfd * dir[2] / len};
      const double cd = (ContactEnergy(mo, xp, dhat, &gh, &nh) - ContactEnergy(mo, xm, dhat, &gh, &nh)) / (2 * hfd);
      *fd             = std::max(*fd, std::abs(cd - Dot(g1, dir) / len) / std::sqrt(Dot(g1, g1)));
    }
    *most = std::max(*most, nc);
    e0 = e1, g0 = g1;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Concave creases (mesh_obstacle.cpp, CreaseContacts): a faceted cup (16 vertical panels on a
   floor) and a fin thinner than dhat standing on a plate. Along a path across a panel's edge 3 mm
   above the floor, the floor and one wall count (2 contacts: two panels counted each made the
   energy jump 20% where the point's foot entered the second); along a path up the fin's side the
   plate and the fin's near face (the far face through the fin counted only while the plate was
   nearest: a jump at the bisector); in an open box's corner the floor and both walls (3). */
static PetscErrorCode Creases(PetscMPIInt rank)
{
  char             path[PETSC_MAX_PATH_LEN];
  const double     dhat = 0.01, PI = 3.14159265358979323846;
  double           worst;
  int              most;
  MSimMeshObstacle mo;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_mesh_crease_%d_%d.obj", (int)getpid(), (int)rank));
  FILE *f = fopen(path, "w");
  PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
  fprintf(f, "v 0 0 0\n"); /* the cup: the floor's centre, 16 rim points at z 0 and 16 at z 0.3 */
  for (int k = 0; k < 16; k++) fprintf(f, "v %.17g %.17g 0\nv %.17g %.17g 0.3\n", 0.5 * std::cos(2 * PI * k / 16), 0.5 * std::sin(2 * PI * k / 16), 0.5 * std::cos(2 * PI * k / 16), 0.5 * std::sin(2 * PI * k / 16));
  for (int k = 0; k < 16; k++) {
    const int a = 2 + 2 * k, b = 2 + 2 * ((k + 1) % 16);
    fprintf(f, "f 1 %d %d\nf %d %d %d\nf %d %d %d\n", a, b, a, b, b + 1, a, b + 1, a + 1);
  }
  fclose(f);
  PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, 0.0, &mo));
  MSimMeshObstacleSetBand(mo, dhat);
  /* 4.4 mm inside the two panels that meet at angle 0, from 1 cm on one side of their edge to 1 cm on the other */
  PetscCall(CreaseSweep(mo, dhat, {0.4955, -0.01, 0.003}, {0, 0.02, 0}, 400, &worst, &most));
  MSimMeshObstacleDestroy(&mo);
  NOTE("cup: across a panel's edge 3 mm above the floor, most contacts %d, largest change %.3g of the gradient's bound\n", most, worst);
  CHECK(most == 2 && worst <= 1, "cup: %d contacts (floor and one wall expected) and an energy change %.3g x its gradient's bound (a jump)", most, worst);

  f = fopen(path, "w"); /* a plate z = 0 and a closed fin x in [0, 0.002] on it */
  PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
  fprintf(f, "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\n");
  fprintf(f, "v 0 -0.2 0\nv 0 0.2 0\nv 0 0.2 0.2\nv 0 -0.2 0.2\nv 0.002 -0.2 0\nv 0.002 0.2 0\nv 0.002 0.2 0.2\nv 0.002 -0.2 0.2\n");
  fprintf(f, "f 1 2 3\nf 1 3 4\nf 5 6 7\nf 5 7 8\nf 9 11 10\nf 9 12 11\nf 8 7 11\nf 8 11 12\nf 5 8 12\nf 5 12 9\nf 6 10 11\nf 6 11 7\n");
  fclose(f);
  PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, 0.0, &mo));
  MSimMeshObstacleSetBand(mo, dhat);
  PetscCall(CreaseSweep(mo, dhat, {-0.004, 0, 0.002}, {0, 0, 0.004}, 400, &worst, &most));
  MSimMeshObstacleDestroy(&mo);
  NOTE("fin: up its side across the bisector, most contacts %d, largest change %.3g of the gradient's bound\n", most, worst);
  CHECK(most == 2 && worst <= 1, "fin: %d contacts (plate and near face expected) and an energy change %.3g x its gradient's bound (a jump)", most, worst);
  remove(path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Rim corners (mesh_obstacle.cpp, RimCorner): the open box of tests/contact_mesh.py (floor z = -0.5,
   walls up to the rim z = -0.1 around x, y in [0.2, 0.8]) with a thickness of 1 cm and dhat 1 cm,
   near its rim corner V = (0.2, 0.2, -0.1), where the walls' rim edges meet. Along four paths, each
   point farther than the thickness from the box: above the rim across the bisector (where the
   nearest edge alone flipped between the walls' normals), across a wall's plane above the rim
   (where the other wall's contact starts), down the bisector through the rim's plane (where the
   feet enter the walls: the faces' two contacts, while above it the nearest edge's alone gave
   half that energy) and through the corner's vertical line (where a cloth dropped on the corner
   lands). On each the barrier's sum has no jump, and its gradient no kink: the gradient's largest
   change between neighbouring points at least a third smaller with 800 points than with 400 (half,
   where it is continuous; the same, where it jumps); above the rim's corner both walls count. */
static PetscErrorCode RimCorners(PetscMPIInt rank)
{
  char             path[PETSC_MAX_PATH_LEN];
  const double     dhat = 0.01, th = 0.01;
  MSimMeshObstacle mo;
  struct {
    const char *what;
    V3          x0, dir;
    int         contacts; /* the most at one point (0: not checked) */
  } paths[] = {
    {"above the rim across the bisector", {0.204, 0.212, -0.088}, {0.008, -0.008, 0}, 2},
    {"across a wall's plane above the rim", {0.194, 0.204, -0.088}, {0.012, 0, 0}, 0},
    {"down the bisector through the rim's plane", {0.213, 0.213, -0.094}, {0, 0, -0.012}, 2},
    {"through the corner's vertical line", {0.195, 0.195, -0.0885}, {0.01, 0.01, 0}, 0},
  };

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_mesh_rim_%d_%d.obj", (int)getpid(), (int)rank));
  FILE *f = fopen(path, "w");
  PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
  for (double x : {0.2, 0.8})
    for (double y : {0.2, 0.8})
      for (double z : {-0.5, -0.1}) fprintf(f, "v %.17g %.17g %.17g\n", x, y, z);
  fprintf(f, "f 1 3 4\nf 1 4 2\nf 5 6 8\nf 5 8 7\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 5 7\nf 1 7 3\n");
  fclose(f);
  PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, th, &mo));
  MSimMeshObstacleSetBand(mo, th + dhat);
  for (const auto &p : paths) {
    double worst, kink[2], w2;
    int    most, m2;
    PetscCall(CreaseSweep(mo, dhat, p.x0, p.dir, 400, &worst, &most, &kink[0]));
    PetscCall(CreaseSweep(mo, dhat, p.x0, p.dir, 800, &w2, &m2, &kink[1]));
    NOTE("rim corner, %s: most contacts %d, largest change %.3g of the gradient's bound, the gradient's largest step %.3g at 400 points, %.3g at 800\n", p.what, most, PetscMax(worst, w2), kink[0], kink[1]);
    CHECK(worst <= 1 && w2 <= 1, "rim corner, %s: an energy change %.3g x its gradient's bound (a jump)", p.what, PetscMax(worst, w2));
    CHECK(kink[1] <= 2.0 / 3.0 * kink[0], "rim corner, %s: the gradient's largest step %.3g at 800 points against %.3g at 400 (a kink)", p.what, kink[1], kink[0]);
    CHECK(!p.contacts || most == p.contacts, "rim corner, %s: %d contacts (both walls expected)", p.what, most);
  }
  MSimMeshObstacleDestroy(&mo);
  remove(path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Obtuse concave creases (mesh_obstacle.cpp, FeatureSum): open trays whose walls slope at 120 and
   135 degrees to the floor and a faceted bowl (16 panels at 135 degrees on a floor), where the
   nearest face alone (b4c5436's rule keeps it there) has a gradient that flips on the crease's
   bisector (a cloth dropped in made Newton diverge).
   - Sweeps across the bisectors (floor and wall, with and without a thickness; two walls; two
     panels): no jump, the gradient's largest step at least a third smaller with 800 points than
     with 400 (the nearest face alone: the same), the gradient within 1e-5 of the energy's central
     difference, and two contacts (the nearest and the rest of the sum);
   - at random points within the band of each, both sides of the open surface: the summed
     barrier is the features' sum computed here by brute force (FeatureEnergy), within 1e-9;
   - where the surface within dhat is convex or flat the sum is the nearest face's: brute force
     on a closed coarse ball (dhat 0.3, the triangles ~0.26 wide) at random points outside it,
     and both brute force and the contacts at random points over an open coarse dome and over a
     tray's floor gridded finely (dhat 0.06, 3.6 triangles) between 1.5 and 1.9 dhat from its
     walls (the walls then beyond dhat, the creases within 2 dhat: the sum is taken) */
static PetscErrorCode ObtuseCreases(PetscMPIInt rank)
{
  char             path[PETSC_MAX_PATH_LEN];
  const double     PI = 3.14159265358979323846;
  MSimMeshObstacle mo;
  std::mt19937_64  rng(7 + rank);
  std::uniform_real_distribution<double> U(0, 1);

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_mesh_obtuse_%d_%d.obj", (int)getpid(), (int)rank));
  struct Sweep {
    const char *what;
    Surface     s;
    double      th, dhat;
    V3          x0, dir;
  };
  /* the floor-wall crease of a tray along y = 0.5 (x = 0.3, z = 0): its bisector's direction at
     angle a (radians, inside) and a point at distance rho on it; the path crosses it, 8 mm long */
  auto crease = [&](double angle, double rho, V3 *x0, V3 *dir) {
    const double a = angle * PI / 180, bx = std::cos(a / 2), bz = std::sin(a / 2);
    *x0 = {0.3 + rho * bx - 0.004 * bz, 0.5, rho * bz + 0.004 * bx};
    *dir = {0.008 * bz, 0, -0.008 * bx};
  };
  std::vector<Sweep> sweeps;
  for (double angle : {120.0, 135.0}) {
    Sweep w{angle == 120 ? "tray 120, floor and wall" : "tray 135, floor and wall", Tray(angle, 1), 0, 0.01, {}, {}};
    crease(angle, 0.006, &w.x0, &w.dir);
    sweeps.push_back(w);
  }
  {
    Sweep w{"tray 120, floor and wall, thickness 5 mm", Tray(120, 1), 0.005, 0.01, {}, {}};
    crease(120, 0.012, &w.x0, &w.dir);
    sweeps.push_back(w);
    /* two walls of the 135 tray at their edge's middle (0.1, 0.1, 0.2), across the plane x = y */
    Sweep v{"tray 135, two walls", Tray(135, 1), 0, 0.01, {0.1 + 0.005 + 0.004, 0.1 + 0.005 - 0.004, 0.2 + 0.003}, {-0.008, 0.008, 0}};
    sweeps.push_back(v);
    /* two panels of the bowl at their edge's middle, across it towards the axis (tangentially) */
    const double ph = 2 * PI * 0.5 / 16, r = 0.2 + 0.2 - 0.006;
    Sweep b{"bowl of 16 panels, two panels", Bowl(16, 135, 0.2), 0, 0.01, {0.5 + r * std::cos(ph) + 0.004 * std::sin(ph), 0.5 + r * std::sin(ph) - 0.004 * std::cos(ph), 0.2}, {-0.008 * std::sin(ph), 0.008 * std::cos(ph), 0}};
    sweeps.push_back(b);
  }
  for (const Sweep &w : sweeps) {
    double worst, w2, kink[2], fd, fd2;
    int    most, m2;
    PetscCall(WriteSurface(path, w.s));
    PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, w.th, &mo));
    MSimMeshObstacleSetBand(mo, w.th + w.dhat);
    PetscCall(CreaseSweep(mo, w.dhat, w.x0, w.dir, 400, &worst, &most, &kink[0], &fd));
    PetscCall(CreaseSweep(mo, w.dhat, w.x0, w.dir, 800, &w2, &m2, &kink[1], &fd2));
    MSimMeshObstacleDestroy(&mo);
    NOTE("obtuse crease, %s: most contacts %d, largest change %.3g of the gradient's bound, the gradient's largest step %.3g at 400 points, %.3g at 800, against the central difference %.3g\n", w.what, most, PetscMax(worst, w2), kink[0], kink[1], PetscMax(fd, fd2));
    CHECK(worst <= 1 && w2 <= 1, "obtuse crease, %s: an energy change %.3g x its gradient's bound (a jump)", w.what, PetscMax(worst, w2));
    CHECK(kink[1] <= 2.0 / 3.0 * kink[0], "obtuse crease, %s: the gradient's largest step %.3g at 800 points against %.3g at 400 (a kink)", w.what, kink[1], kink[0]);
    CHECK(PetscMax(fd, fd2) <= 1e-5, "obtuse crease, %s: the gradient off the energy's central difference by %.3g of it", w.what, PetscMax(fd, fd2));
    CHECK(most == 2, "obtuse crease, %s: %d contacts (2 expected)", w.what, most);
  }

  /* random points within the band, on a random triangle's either side */
  auto near = [&](const Surface &s, double band, V3 *x) {
    const auto  &t = s.t[(size_t)(U(rng) * s.t.size()) % s.t.size()];
    double       a = U(rng), b = U(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const V3     n = Cross(Sub(s.v[t[1]], s.v[t[0]]), Sub(s.v[t[2]], s.v[t[0]]));
    const double h = (U(rng) < 0.5 ? -1 : 1) * (0.02 + 0.97 * U(rng)) * band / std::sqrt(Dot(n, n));
    for (int c = 0; c < 3; c++) (*x)[c] = s.v[t[0]][c] + a * (s.v[t[1]][c] - s.v[t[0]][c]) + b * (s.v[t[2]][c] - s.v[t[0]][c]) + h * n[c];
  };
  struct Case {
    const char *what;
    Surface     s;
    double      th, dhat;
  } cases[] = {{"tray 120", Tray(120, 1), 0, 0.05}, {"tray 135, thickness 0.02", Tray(135, 1), 0.02, 0.05}, {"bowl of 16 panels", Bowl(16, 135, 0.2), 0, 0.05}};
  for (const Case &c : cases) {
    double off = 0, nearest;
    int    n = 0;
    V3     g;
    PetscCall(WriteSurface(path, c.s));
    PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, c.th, &mo));
    MSimMeshObstacleSetBand(mo, c.th + c.dhat);
    for (int i = 0; i < 2000; i++) {
      V3 x;
      int nc;
      near(c.s, c.th + c.dhat, &x);
      const double ef = FeatureEnergy(c.s, x, c.th, c.dhat, &nearest);
      if (!(nearest > 0)) continue; /* within the thickness or beyond the band */
      const double ec = ContactEnergy(mo, x, c.dhat, &g, &nc);
      off = std::max(off, std::abs(ec - ef) / ef);
      n++;
    }
    MSimMeshObstacleDestroy(&mo);
    NOTE("features' sum, %s: %d points, the contacts' sum off brute force's by %.3g\n", c.what, n, off);
    CHECK(n > 1000 && off <= 1e-9, "features' sum, %s: the contacts' barrier off the features' sum by %.3g of it (%d points)", c.what, off, n);
  }

  /* convex and flat: the sum is the nearest's */
  {
    const Surface ball = Ball(12, 6, false);
    double        off = 0, nearest;
    int           n = 0;
    for (int i = 0; i < 2000; i++) {
      V3 x;
      near(ball, 0.3, &x);
      const V3 r = Sub(x, V3{0.5, 0.5, 0});
      if (Dot(r, r) < 0.25) continue; /* outside alone (the faces' planes cut the sphere: near enough) */
      const double ef = FeatureEnergy(ball, x, 0, 0.3, &nearest);
      if (!(nearest > 0)) continue;
      off = std::max(off, std::abs(ef - nearest) / nearest), n++;
    }
    NOTE("features' sum on a closed coarse ball: %d points, off the nearest's by %.3g\n", n, off);
    CHECK(n > 500 && off <= 1e-9, "features' sum on a closed coarse ball: off the nearest face's by %.3g of it (%d points)", off, n);
  }
  struct Flat {
    const char *what;
    Surface     s;
    double      dhat;
    bool        (*keep)(const V3 &x, double dhat);
  } flats[] = {
    {"an open coarse dome, above it", Ball(12, 6, true), 0.3, [](const V3 &x, double) { const V3 r = Sub(x, V3{0.5, 0.5, 0}); return Dot(r, r) > 0.25 && x[2] > 0; }},
    {"a tray's fine floor, 1.5 to 1.9 dhat from its walls", Tray(135, 24), 0.06,
     [](const V3 &x, double dh) {
       const double u = std::min({x[0] - 0.3, 0.7 - x[0], x[1] - 0.3, 0.7 - x[1]});
       return u >= 1.5 * dh && u <= 1.9 * dh && x[2] > 0 && x[2] < dh;
     }},
  };
  for (const Flat &c : flats) {
    double off = 0, offc = 0, nearest;
    int    n = 0;
    V3     g;
    PetscCall(WriteSurface(path, c.s));
    PetscCall(MSimMeshObstacleCreate(PETSC_COMM_SELF, path, 0.0, &mo));
    MSimMeshObstacleSetBand(mo, c.dhat);
    for (int i = 0; i < 40000 && n < 1000; i++) {
      V3  x;
      int nc;
      near(c.s, c.dhat, &x);
      if (!c.keep(x, c.dhat)) continue;
      const double ef = FeatureEnergy(c.s, x, 0, c.dhat, &nearest);
      if (!(nearest > 0)) continue;
      off  = std::max(off, std::abs(ef - nearest) / nearest);
      offc = std::max(offc, std::abs(ContactEnergy(mo, x, c.dhat, &g, &nc) - nearest) / nearest), n++;
    }
    MSimMeshObstacleDestroy(&mo);
    NOTE("features' sum on %s: %d points, off the nearest's by %.3g (brute force), %.3g (the contacts)\n", c.what, n, off, offc);
    CHECK(n >= 200 && off <= 1e-9 && offc <= 1e-9, "features' sum on %s: off the nearest face's by %.3g (brute force), %.3g (the contacts) (%d points)", c.what, off, offc, n);
  }
  remove(path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Body(void)
{
  PetscMPIInt rank;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCall(Walks(MSIM_SOURCE_DIR "/examples/meshes/bunny.off", 0.02, 0.0, rank));
  PetscCall(Walks(MSIM_SOURCE_DIR "/examples/meshes/bunny.off", 0.02, 0.3, rank));
  PetscCall(Walks(MSIM_SOURCE_DIR "/tests/data/meshes/sheet.obj", 0.05, 0.0, rank));
  PetscCall(FarFromOrigin(rank));
  PetscCall(Slivers(rank));
  PetscCall(Creases(rank));
  PetscCall(RimCorners(rank));
  PetscCall(ObtuseCreases(rank));
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(Body)
