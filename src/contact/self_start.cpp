/* Self-contact's start check: a surface that already crosses itself, or whose vertex-disjoint
   elements start closer than -msim_self_contact_start_gap (by default the contact distance dhat,
   -msim_self_contact_distance; 0 for a start resting in contact, which then refuses only crossing
   or touching elements), is refused in one line naming the elements. The barrier keeps every pair on the side it starts on: crossing elements stay
   locked through each other, and a pair that starts at 1e-6 of dhat sees a barrier so steep that
   the CCD cuts every Newton step to nothing (examples/cloth_fold.opts at 41 x 41 with its 1 cm
   perturbation: 6 crossing triangle pairs and a vertex 2.3e-6 m from a triangle, dhat 1.8e-3 m;
   every step stalled after one iteration with the cloth frozen).
   The check is on the state the run starts from: the scene's start X0, or a restart's checkpoint,
   where one written without self-contact can hold a surface folded through itself (such a
   restart ran on, locked through itself). A checkpoint of a run with self-contact rests in
   contact within dhat wherever its surfaces touch, so at a restart the gap is 0 by default
   (crossing or touching elements only): a given -msim_self_contact_start_gap still applies.
   Each rank checks the pairs its surface plan holds (own triangles and halo; re-planned at the
   state first) under the term's rule (a pair with a free vertex, computed by the rank whose block holds its
   least input id, whose elements it always sees: src/contact/self_surface.cpp), and the worst
   offender over all ranks (a crossing first, then the smallest distance; ties by input ids) is
   named, so the line is the same at any rank count. Run once: a plain hash grid of its own. */
#include <msim/private/selfcontactimpl.h>
#include <msim/private/systemimpl.h>
#include <msim/errors.h>
#include <cmath>

namespace
{
/* an offender: kind 0 an edge crossing a triangle, 1 a pair closer than dhat (ee: 1 edge-edge,
   0 point-triangle); ids: input ids (edge or point first, then the other element; -1 unused) */
struct Offence {
  PetscReal kind = 2, d = PETSC_MAX_REAL, ee = 0;
  PetscReal ids[5] = {-1, -1, -1, -1, -1};
  bool      Worse(const Offence &o) const
  {
    if (kind != o.kind) return kind < o.kind;
    if (d != o.d) return d < o.d;
    for (int k = 0; k < 5; k++)
      if (ids[k] != o.ids[k]) return ids[k] < o.ids[k];
    return false;
  }
};

PetscReal Orient(const PetscReal *a, const PetscReal *b, const PetscReal *c, const PetscReal *d)
{
  PetscReal u[3], v[3], w[3];
  for (int k = 0; k < 3; k++) u[k] = b[k] - a[k], v[k] = c[k] - a[k], w[k] = d[k] - a[k];
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}

/* segment pq passes through the inside of triangle abc (strictly: touching cases are distances
   of 0, which the distance test catches) */
bool Crosses(const PetscReal *p, const PetscReal *q, const PetscReal *a, const PetscReal *b, const PetscReal *c)
{
  const PetscReal sp = Orient(a, b, c, p), sq = Orient(a, b, c, q);
  if (!((sp > 0 && sq < 0) || (sp < 0 && sq > 0))) return false;
  const PetscReal s1 = Orient(p, q, a, b), s2 = Orient(p, q, b, c), s3 = Orient(p, q, c, a);
  return (s1 > 0 && s2 > 0 && s3 > 0) || (s1 < 0 && s2 < 0 && s3 < 0);
}
} // namespace

PetscErrorCode MSimSelfSurfaceCheckStart(MSimSelfSurface s, const MSimSelfContactOptions *o, PetscReal t, Vec X, const char *restart)
{
  MSimSystem             sys = s->sys;
  const PetscReal        gap = o->start_gap >= 0 ? o->start_gap : restart ? 0.0 : s->dhat, dh2 = gap * gap;
  std::vector<PetscReal> x;
  Offence                worst;

  PetscFunctionBeginUser;
  /* beyond dhat the barrier does not act, and the halo holds other ranks' elements only that far
     (plus a margin): a larger gap would be checked at one rank and not at several */
  PetscCheck(gap <= s->dhat, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_self_contact_start_gap %g m is above the contact distance %g m (-msim_self_contact_distance): the barrier acts only within it", (double)gap, (double)s->dhat);
  /* the local vertices at X, re-planned where X is far from the plan (X0's), so that the halo
     holds the elements near X */
  PetscCall(MSimSelfSurfaceGather(s, t, X, NULL, 0, x, NULL));
  const PetscInt nt = (PetscInt)s->tri.size() / 3, ne = (PetscInt)s->edge.size() / 2;
  /* the term's rule: some vertex free, the least input id in this rank's block */
  auto mine = [&](const PetscInt *v, int n) {
    PetscInt low = PETSC_MAX_INT;
    bool     moving = false;
    for (int k = 0; k < n; k++) {
      low    = PetscMin(low, s->vid[v[k]]);
      moving = moving || s->gnum[v[k]] >= 0;
    }
    return moving && low >= s->dstart && low < s->dstart + s->dcount;
  };
  auto note = [&](PetscReal kind, PetscReal ee, PetscReal d, const PetscInt *v, int n) {
    Offence o;
    o.kind = kind;
    o.ee   = ee;
    o.d    = d;
    for (int k = 0; k < n; k++) o.ids[k] = (PetscReal)s->vid[v[k]];
    if (o.Worse(worst)) worst = o;
  };
  /* the triangles' boxes grown by the gap, in the term's grid (each box binned once, by its centre,
     at the level of its size: one large triangle costs no more than a small one) */
  std::vector<PetscReal> box(6 * nt);
  PetscReal              cell = 0;
  for (PetscInt t = 0; t < nt; t++) {
    PetscReal *b = &box[6 * t];
    for (int c = 0; c < 3; c++) {
      b[c]     = PetscMin(x[3 * s->tri[3 * t] + c], PetscMin(x[3 * s->tri[3 * t + 1] + c], x[3 * s->tri[3 * t + 2] + c])) - gap;
      b[3 + c] = PetscMax(x[3 * s->tri[3 * t] + c], PetscMax(x[3 * s->tri[3 * t + 1] + c], x[3 * s->tri[3 * t + 2] + c])) + gap;
      cell += (b[3 + c] - b[c]) / (3.0 * nt);
    }
  }
  MSimBoxGrid grid;
  grid.Build(box, PetscMax(cell, PETSC_SMALL));
  /* f(t) once for every triangle whose grown box overlaps the box [lo, hi] */
  auto query = [&](const PetscReal *lo, const PetscReal *hi, auto &&f) {
    const PetscReal q[6] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
    grid.Query(q, f);
  };
  /* point-triangle pairs */
  for (PetscInt v = 0; v < (PetscInt)s->vid.size(); v++)
    query(&x[3 * v], &x[3 * v], [&](PetscInt t) {
      const PetscInt *tv = &s->tri[3 * t];
      if (tv[0] == v || tv[1] == v || tv[2] == v) return;
      const PetscInt q[4] = {v, tv[0], tv[1], tv[2]};
      if (!mine(q, 4)) return;
      PetscReal       w[4];
      const PetscReal d2 = MSimPointTriangleDistance2(&x[3 * v], &x[3 * tv[0]], &x[3 * tv[1]], &x[3 * tv[2]], w);
      if (d2 < dh2 || d2 == 0) note(1, 0, std::sqrt(d2), q, 4);
    });
  /* an edge through a triangle, and edge-edge pairs (every edge is some triangle's) */
  for (PetscInt e = 0; e < ne; e++) {
    const PetscInt  *ev = &s->edge[2 * e];
    const PetscReal *p = &x[3 * ev[0]], *q = &x[3 * ev[1]];
    PetscReal        lo[3], hi[3];
    for (int c = 0; c < 3; c++) lo[c] = PetscMin(p[c], q[c]), hi[c] = PetscMax(p[c], q[c]);
    query(lo, hi, [&](PetscInt t) {
      const PetscInt *tv = &s->tri[3 * t];
      for (int k = 0; k < 3; k++)
        if (tv[k] == ev[0] || tv[k] == ev[1]) return;
      const PetscInt c5[5] = {ev[0], ev[1], tv[0], tv[1], tv[2]};
      if (mine(c5, 5) && Crosses(p, q, &x[3 * tv[0]], &x[3 * tv[1]], &x[3 * tv[2]])) note(0, 0, 0, c5, 5);
      for (int k = 0; k < 3; k++) {
        const PetscInt o0 = PetscMin(tv[k], tv[(k + 1) % 3]), o1 = PetscMax(tv[k], tv[(k + 1) % 3]);
        const PetscInt c4[4] = {ev[0], ev[1], o0, o1};
        if (!mine(c4, 4)) continue;
        PetscReal       w[4];
        const PetscReal d2 = MSimEdgeEdgeDistance2(p, q, &x[3 * o0], &x[3 * o1], w);
        if (d2 < dh2 || d2 == 0) note(1, 1, std::sqrt(d2), c4, 4);
      }
    });
  }
  /* the worst over all ranks (every rank picks the same), named by file ids where the input
     had its own */
  std::vector<Offence> all(sys->size);
  PetscCallMPI(MPI_Allgather(&worst, (int)(sizeof(Offence) / sizeof(PetscReal)), MPIU_REAL, all.data(), (int)(sizeof(Offence) / sizeof(PetscReal)), MPIU_REAL, sys->comm));
  for (const Offence &o : all)
    if (o.Worse(worst)) worst = o;
  if (worst.kind > 1) PetscFunctionReturn(PETSC_SUCCESS);
  PetscInt name[5];
  for (int k = 0; k < 5; k++) {
    const PetscInt id = (PetscInt)worst.ids[k];
    name[k]           = id >= s->dstart && id < s->dstart + s->dcount ? (sys->nat_file_id.empty() || sys->nat_file_id[id - s->dstart] < 0 ? id : sys->nat_file_id[id - s->dstart]) : -1;
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, name, 5, MPIU_INT, MPI_MAX, sys->comm));
  char what[256];
  if (worst.kind == 0) PetscCall(PetscSNPrintf(what, sizeof(what), "edge (%" PetscInt_FMT ", %" PetscInt_FMT ") passes through triangle (%" PetscInt_FMT ", %" PetscInt_FMT ", %" PetscInt_FMT ")", name[0], name[1], name[2], name[3], name[4]));
  else if (!worst.ee) PetscCall(PetscSNPrintf(what, sizeof(what), "vertex %" PetscInt_FMT " is %g m from triangle (%" PetscInt_FMT ", %" PetscInt_FMT ", %" PetscInt_FMT ")", name[0], (double)worst.d, name[1], name[2], name[3]));
  else PetscCall(PetscSNPrintf(what, sizeof(what), "edge (%" PetscInt_FMT ", %" PetscInt_FMT ") is %g m from edge (%" PetscInt_FMT ", %" PetscInt_FMT ")", name[0], name[1], (double)worst.d, name[2], name[3]));
  /* where, and what separates them: the scene's start, or a checkpoint's state (one written
     without self-contact, or at a larger distance than this run's start gap) */
  char where[PETSC_MAX_PATH_LEN + 128], line[PETSC_MAX_PATH_LEN + 768];
  if (restart) PetscCall(PetscSNPrintf(where, sizeof(where), "in %s", restart));
  else PetscCall(PetscStrncpy(where, "at the start", sizeof(where)));
  const char *apart = restart ? "restart from a state where they are apart" : "separate them (e.g. a smaller -msim_perturb)";
  if (worst.kind == 0) PetscCall(PetscSNPrintf(line, sizeof(line), "-msim_self_contact: the surface passes through itself %s: %s (vertex ids of the input); the barrier would keep them locked through each other: %s", where, what, apart));
  /* a gap of 0 (a restart's default, or given) notes only elements at distance 0, where no
     smaller gap exists: the barrier is infinite there */
  else if (gap == 0) PetscCall(PetscSNPrintf(line, sizeof(line), "-msim_self_contact: the surface touches itself (distance 0) %s: %s (vertex ids of the input), where the barrier is infinite: %s", where, what, apart));
  else if (!restart) PetscCall(PetscSNPrintf(line, sizeof(line), "-msim_self_contact: the surface touches itself %s: %s (vertex ids of the input), closer than -msim_self_contact_start_gap %g m (by default the contact distance, -msim_self_contact_distance): %s, or for a start resting in contact give a smaller gap", where, what, (double)gap, apart));
  else PetscCall(PetscSNPrintf(line, sizeof(line), "-msim_self_contact: the surface touches itself %s: %s (vertex ids of the input), closer than -msim_self_contact_start_gap %g m (0 by default at a restart): %s, or give a smaller gap", where, what, (double)gap, apart));
  PetscCall(MSimCollectiveCheck(sys->comm, PETSC_FALSE, line));
  PetscFunctionReturn(PETSC_SUCCESS);
}
