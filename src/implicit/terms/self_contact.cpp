/* Self-contact as a term of Phi (-msim_self_contact; msim/self_contact.h): IPC's barrier (Li et al.
   2020) on the squared distance s = d^2 of every point-triangle and edge-edge pair of surface
   elements that share no vertex,
     E = C sum_pairs b(s, dhat^2),   b(s) = -(s - dhat^2)^2 log(s / dhat^2) on (0, dhat^2),
   infinite at contact, so every iterate a line search accepts keeps the surface apart. C gives a
   pair at d = dhat/2 the stiffness (d^2/dd^2 of C b(d^2)) of a mean vertex's mass term, the rule
   the obstacles' kappa follows, times -msim_self_contact_stiffness.
   Gradient: with the closest points' weights w (r = sum w_k x_k, s = |r|^2), by the envelope
   theorem ds/dx_k = 2 w_k r, so g_k = 2 C b'(s) w_k r, exact (also on the regions' borders).
   Hessian: with the closest points held fixed it is C (w w^T) kron (4 b'' r r^T + 2 b' I), whose
   PSD projection is exact in closed form, C max(0, 4 b'' s + 2 b') (w w^T) kron (r r^T / s): the
   12 x 12 block's eigen-decomposition is that of a Kronecker product, so no Eigen solve is needed.
   It omits the closest points' motion (a surface's curvature), the part IPC's projection keeps
   only where it is positive anyway; Newton then converges linearly near tangential sliding, and
   the line search keeps every iterate feasible whatever the Hessian. Given for -msim_psd 0 too.
   Duplicates: a contact whose closest features are an edge or a vertex is as close to every
   triangle and edge around them, so the pairs' barriers counted it several times (a vertex above
   a flat sheet's edge 1 + 1 + its own edges, above a vertex up to 19 times) and the barrier's
   strength depended on the mesh at the contact. With -msim_self_contact_once (off: Newton can
   stall at the weighted energy's kink where edges lie parallel, see the option) the point-edge and point-point pairs of those
   features join the sum with weights that make every contact count once (Collect, WeightPE,
   WeightPP: convergent IPC's inclusion-exclusion), tests/unit/test_self_features.cpp.
   Summation order: the terms are summed in the order of their vertices' input ids, and the CCD's
   answer depends on the step alone, so a checkpoint's restart repeats the run bit for bit.
   Simplification: no mollifier for nearly parallel edge-edge pairs (IPC's e_k): the distance is
   still exact there, only its Hessian jumps, which the line search tolerates.
   max_step: additive CCD over the pairs whose boxes swept along the step overlap, reduced over
   ranks, so no step (nor PD's global step, nor the first iterate: MSimImplicitGuess) can carry an
   element through another; with moving handles the step's start carries the free vertices with
   them as far as they must (FeasibleStart_Self). PD: the barrier's force in the right-hand side,
   as the obstacles'.
   The Hessian's blocks join vertices the springs do not: the system's matrix takes new entries
   when self-contact is on (MSimSystemCreateMatrix), and its assembly map follows the pattern. A
   pair's rows that other ranks own go to them over the halo scatter's neighbours and are added
   there in rank order (MSimSelfHessian, msim/self_contact.h): runs repeat bit for bit at 3 ranks.
   The surface: a cloth's grid triangles, a surface mesh's triangles, a tet mesh's boundary faces
   (src/contact/self_surface.cpp). */
#include <msim/implicit.h>
#include <msim/contact.h>
#include <msim/private/selfcontactimpl.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>
#include <msim/errors.h>
#include <msim/destroy.h>
#include <algorithm>
#include <string>
#include <cmath>

/* One term of the energy within dhat (Collect): a pair's kind (PT, EE, or the point-edge PE and
   point-point PP that duplicate their closest features), its 4 local vertices (PE: p, p, e0, e1;
   PP: p, p, q, q: the edge-edge distance with a degenerate edge), their input ids (the summation
   order), squared distance, closest points' weights and the term's weight c */
enum { KIND_PT = 0, KIND_EE = 1, KIND_PE = 2, KIND_PP = 3 };
struct SelfTerm {
  std::array<PetscInt, 4> gid;
  PetscInt                kind, v[4];
  PetscReal               s, w[4], c;
};

typedef struct {
  MSimSelfContactOptions opt;
  MSimSelfSurface        surf;
  PetscReal              C;             /* the barrier's weight */
  MSimBoxGrid            tgrid, egrid;  /* broad phase over triangles and over edges */
  std::vector<PetscReal> x, u, g, boxes;
  /* the candidate list (a Verlet list): the pairs within dhat + margin at xlist, valid for any x
     (and any motion) that keeps every vertex within margin / 2 of xlist */
  std::vector<PetscInt>  cand;         /* 5 per pair: ee flag, 4 local vertices */
  std::vector<PetscReal> xlist;
  PetscReal              margin;
  PetscInt               nbuild, nreuse;
  /* the wide list: pairs within dhat + wmargin at xwide, from a grid; the near list above is remade
     from it by one pass of distances (no grid) while the vertices stay within (wmargin - margin) / 2
     of xwide. wmargin is 4 dhat: the pairs within R of each other grow as R^2 on a surface, and
     past about an edge length (4 dhat by dhat's default) every element meets its neighbours in the
     sheet, none of them in contact: on the 101 x 101 fold R = 9 dhat (the former adaptive
     margin's cap) held 18 pairs per element against 2.2 at R = 5 dhat, and a longer-lived list
     did not pay for its size (35 steps: CPU 19.1 s with the margin let grow to 6 dhat, 11.6 s at
     4). The pairs are sorted by their distance at xwide (wd), so a query reads only the prefix
     that can matter (WidePrefix) */
  std::vector<PetscInt>  wide;
  std::vector<PetscReal> wd;           /* each wide pair's distance at xwide, ascending (the pairs sorted by it) */
  std::vector<PetscReal> xwide;
  PetscReal              wmargin;
  PetscInt               wplan, wuses, nwide;
  std::vector<PetscInt>  pt, ee;       /* the broad phase's output (kept: no allocation per query) */
  PetscInt               plan;         /* the halo plan the list's local numbers belong to */
  PetscInt               npairs;        /* pairs within dhat at the last gradient (this rank) */
  PetscReal              dmin;          /* the smallest distance among them */
  /* the last evaluation: the local energy and gradient (unsigned) at the local positions xeval of
     plan eplan, both from one pass over the pairs. PD asks for Phi and its gradient at the same
     iterate up to four times (the right-hand side, the global step's Phi check at x_k, the Phi
     check at x_k+1, the residual at x_k+1, the next right-hand side at it), Newton's line search
     for the energy and then the gradient at the accepted point: a query whose gathered positions
     equal xeval bit for bit returns these without a pass */
  std::vector<PetscReal> xeval, geval;
  PetscReal              eeval;
  PetscInt               eplan;
  PetscInt               nevals, nhits;
  PetscLogDouble         widesum, nearsum; /* pairs over all wide and near lists made */
  PetscInt               nswept;        /* CCDs that needed a swept broad phase */
  /* the local surface's connectivity, per halo plan: each local vertex's neighbours along edges
     and its triangles (CSR) */
  std::vector<PetscInt>  nbr_off, nbr, vtri_off, vtri;
  PetscInt               cplan;
  /* one evaluation's terms within dhat, sorted by their vertices' input ids, and the duplicate
     features' candidates (kind, 4 vertices) */
  std::vector<SelfTerm>                act;
  std::vector<std::array<PetscInt, 5>> sub;
  std::vector<std::array<PetscInt, 6>> keys;  /* the PSD Hessian's groups (Hessian_Self) */
  std::vector<PetscInt>                order;
  PetscBool                            once; /* -msim_self_contact_once */
  Vec                                  hz, hd; /* moving handles: the carried start and the motion from it (FeasibleStart_Self), made at the first step */
  MSimSelfHessian                      hess;   /* the Hessian's rows to their owners (msim/self_contact.h) */
} SelfData;

/* f(ee, v[4]) for each pair this rank computes whose boxes overlap: within dhat of each other at
   x (u NULL), or whose boxes swept from x to x + a u overlap (CCD) */
template <class F>
static PetscErrorCode BroadPhase(SelfData *sd, const std::vector<PetscReal> &x, const std::vector<PetscReal> *u, PetscReal a, PetscReal grow, F &&f)
{
  MSimSelfSurface s    = sd->surf;
  const PetscInt  nt = (PetscInt)s->tri.size() / 3, ne = (PetscInt)s->edge.size() / 2, nv = (PetscInt)s->vid.size();
  PetscReal       extent = 0;
  auto            vbox   = [&](PetscInt v, PetscReal *b) {
    for (int c = 0; c < 3; c++) {
      const PetscReal p = x[3 * v + c], q = u ? p + a * (*u)[3 * v + c] : p;
      b[c]     = PetscMin(b[c], PetscMin(p, q));
      b[3 + c] = PetscMax(b[3 + c], PetscMax(p, q));
    }
  };
  auto build = [&](const std::vector<PetscInt> &el, int per, PetscInt n, MSimBoxGrid &grid) {
    sd->boxes.assign(6 * n, 0);
    extent = 0;
    for (PetscInt k = 0; k < n; k++) {
      PetscReal *b = &sd->boxes[6 * k];
      for (int c = 0; c < 3; c++) b[c] = PETSC_MAX_REAL, b[3 + c] = -PETSC_MAX_REAL;
      for (int q = 0; q < per; q++) vbox(el[per * k + q], b);
      for (int c = 0; c < 3; c++) b[c] -= grow, b[3 + c] += grow;
      extent += PetscMax(b[3] - b[0], PetscMax(b[4] - b[1], b[5] - b[2]));
    }
    grid.Build(sd->boxes, PetscMax(n ? extent / n : 1.0, PETSC_SMALL));
  };
  /* the pairs with a free vertex that the rank computes: those whose least input id is its own
     (Collect); with -msim_self_contact_once every pair with a vertex in its block, as the rank also
     computes the point-edge and point-point terms of the pair's features whose least id is its
     own (their owner may not own the pair itself) */
  auto mine = [&](const PetscInt *v) {
    bool     touches = false, moving = false;
    PetscInt low     = PETSC_MAX_INT;
    for (int k = 0; k < 4; k++) {
      touches = touches || (s->vid[v[k]] >= s->dstart && s->vid[v[k]] < s->dstart + s->dcount);
      moving  = moving || s->gnum[v[k]] >= 0;
      low     = PetscMin(low, s->vid[v[k]]);
    }
    /* without -msim_self_contact_once no feature terms exist: a pair is listed (and CCD-tested)
       by the one rank that computes it, not by every rank it touches */
    return moving && (sd->once ? touches : (low >= s->dstart && low < s->dstart + s->dcount));
  };

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_SelfBroad, 0, 0, 0, 0));
  std::vector<PetscInt> &pt = sd->pt, &ee = sd->ee;
  pt.clear();
  ee.clear();
  build(s->tri, 3, nt, sd->tgrid);
  for (PetscInt v = 0; v < nv; v++) {
    PetscReal b[6] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL};
    vbox(v, b);
    sd->tgrid.Query(b, [&](PetscInt t) {
      const PetscInt *tv = &s->tri[3 * t];
      if (tv[0] == v || tv[1] == v || tv[2] == v) return; /* the grid reports only overlapping boxes */
      const PetscInt q[4] = {v, tv[0], tv[1], tv[2]};
      if (mine(q)) pt.insert(pt.end(), q, q + 4);
    });
  }
  build(s->edge, 2, ne, sd->egrid);
  for (PetscInt e = 0; e < ne; e++) {
    const PetscInt *ev = &s->edge[2 * e];
    PetscReal       b[6];
    /* the edge's own box against the others' grown ones (within grow of each other) */
    for (int c = 0; c < 3; c++) b[c] = sd->boxes[6 * e + c] + grow, b[3 + c] = sd->boxes[6 * e + 3 + c] - grow;
    sd->egrid.Query(b, [&](PetscInt o) {
      if (o <= e) return;
      const PetscInt *ov = &s->edge[2 * o];
      if (ov[0] == ev[0] || ov[0] == ev[1] || ov[1] == ev[0] || ov[1] == ev[1]) return;
      const PetscInt q[4] = {ev[0], ev[1], ov[0], ov[1]};
      if (mine(q)) ee.insert(ee.end(), q, q + 4);
    });
  }
  PetscCall(PetscLogEventEnd(MSIM_SelfBroad, 0, 0, 0, 0));
  for (size_t k = 0; k < pt.size(); k += 4) f(PETSC_FALSE, &pt[k]);
  for (size_t k = 0; k < ee.size(); k += 4) f(PETSC_TRUE, &ee[k]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* How far the vertices moved from xref (to x, and to x + a u when u is given), less the motion they
   share: with d_k a vertex's displacement and c the midrange of all d_k, returns max_k |d_k - c|.
   Two vertices came closer by at most |d_i - d_j| <= 2 max_k |d_k - c|, so a Verlet list stays
   valid while this is under half its margin, and a cloth's fall or a body's drift (the larger
   part of a step's motion) costs no rebuild. Along the motion the shared part c(t) interpolates
   the two ends' midranges, so |d_k(t) - c(t)| is convex in t and its two ends bound it. */
static PetscReal Reach(const std::vector<PetscReal> &xref, const std::vector<PetscReal> &x, const std::vector<PetscReal> *u, PetscReal a)
{
  PetscReal far = 0;
  for (int end = 0; end < (u ? 2 : 1); end++) {
    PetscReal lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL}, c[3];
    for (size_t k = 0; k < x.size(); k += 3)
      for (int q = 0; q < 3; q++) {
        const PetscReal d = x[k + q] - xref[k + q] + (end ? a * (*u)[k + q] : 0.0);
        lo[q]             = PetscMin(lo[q], d);
        hi[q]             = PetscMax(hi[q], d);
      }
    for (int q = 0; q < 3; q++) c[q] = 0.5 * (lo[q] + hi[q]);
    for (size_t k = 0; k < x.size(); k += 3) {
      PetscReal e = 0;
      for (int q = 0; q < 3; q++) {
        const PetscReal d = x[k + q] - xref[k + q] + (end ? a * (*u)[k + q] : 0.0) - c[q];
        e += d * d;
      }
      far = PetscMax(far, e);
    }
  }
  return std::sqrt(far);
}

static PetscReal PairDistance2(const std::vector<PetscReal> &x, PetscBool ee, const PetscInt *v, PetscReal w[4]);

/* A pair's two sides (point | triangle, edge | edge), boxed over x and, with u, over x + a u: true
   when the boxes are further apart than r along an axis (then the pair is further apart than r
   wherever its points go along the motion). A few comparisons against a closest-point solve or
   an additive CCD: it lets the wide list serve the CCD and remake the near list cheaply. */
static inline bool PairApart(const std::vector<PetscReal> &x, const std::vector<PetscReal> *u, PetscReal a, PetscBool ee, const PetscInt *v, PetscReal r)
{
  const int split = ee ? 2 : 1;
  for (int c = 0; c < 3; c++) {
    PetscReal lo[2] = {PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[2] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL};
    for (int k = 0; k < 4; k++) {
      const int       side = k >= split;
      const PetscReal p = x[3 * v[k] + c], q = u ? p + a * (*u)[3 * v[k] + c] : p;
      lo[side]          = PetscMin(lo[side], PetscMin(p, q));
      hi[side]          = PetscMax(hi[side], PetscMax(p, q));
    }
    if (lo[0] > hi[1] + r || lo[1] > hi[0] + r) return true;
  }
  return false;
}

/* The wide pairs whose distance at xwide is at most dmax, a prefix of the list (sorted by it):
   while no vertex strays more than rho from xwide (less the shared motion, Reach), a pair d0 apart
   there stays at least d0 - 2 rho apart, so a query that needs the pairs within r reads only
   those with d0 <= r + 2 rho, the rest not even once. */
static inline size_t WidePrefix(const SelfData *sd, PetscReal dmax)
{
  return 5 * (size_t)(std::upper_bound(sd->wd.begin(), sd->wd.end(), dmax) - sd->wd.begin());
}

/* The wide pairs a motion's CCD must see when no vertex strays more than rho from xwide: additive
   CCD stops a pair only once it comes within s (-msim_self_contact_ccd_fraction) times its
   distance at the motion's start, at most d0 + 2 rho, and the pair stays at least d0 - 2 rho
   apart; so with d0 (1 - s) > 2 rho (1 + s) its CCD would return 1 and skipping it changes
   nothing */
static inline size_t WideCCDPrefix(const SelfData *sd, PetscReal rho)
{
  const PetscReal s = sd->opt.ccd_s;
  return WidePrefix(sd, 2 * rho * (1 + s) / (1 - s));
}

/* f(ee, v[4]) for each pair this rank computes that may be within dhat at x (u NULL) or meet
   along x + t a u, t in [0, 1] (static queries get only the pairs whose boxes are within dhat:
   every caller skips the others). Two Verlet lists: the near one (margin dhat) while the vertices
   stay within margin / 2 of where it was made (Reach); else the wide one, which covers a motion
   within wmargin / 2 (CCD) or remakes the near one by one pass of distances; else a new wide list
   from the grid (static queries) or a swept broad phase (a motion that leaves the wide list's
   reach) */
template <class F>
static PetscErrorCode ForEachPair(SelfData *sd, const std::vector<PetscReal> &x, const std::vector<PetscReal> *u, PetscReal a, F &&f)
{
  const PetscReal dhat = sd->surf->dhat;

  PetscFunctionBeginUser;
  if (sd->plan == sd->surf->nplans && sd->xlist.size() == x.size() && Reach(sd->xlist, x, u, a) <= 0.5 * sd->margin) {
    sd->nreuse++;
    for (size_t k = 0; k < sd->cand.size(); k += 5)
      /* a motion's pairs filtered as the wide list's and the broad phase's are, so whichever list a
         rank's history reuses, the same pairs reach f (results do not depend on the partition) */
      if (u ? !PairApart(x, u, a, (PetscBool)sd->cand[k], &sd->cand[k + 1], 0.0) : !PairApart(x, NULL, 0, (PetscBool)sd->cand[k], &sd->cand[k + 1], dhat)) f((PetscBool)sd->cand[k], &sd->cand[k + 1]);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const bool      wide_ok = sd->wplan == sd->surf->nplans && sd->xwide.size() == x.size();
  const PetscReal wfar    = wide_ok ? Reach(sd->xwide, x, u, a) : PETSC_MAX_REAL;
  if (u) {
    if (wfar <= 0.5 * sd->wmargin) {
      const size_t n = WideCCDPrefix(sd, wfar);
      for (size_t k = 0; k < n; k += 5)
        if (!PairApart(x, u, a, (PetscBool)sd->wide[k], &sd->wide[k + 1], 0.0)) f((PetscBool)sd->wide[k], &sd->wide[k + 1]);
    } else { sd->nswept++; PetscCall(BroadPhase(sd, x, u, a, 0.0, f)); } /* a long motion: this query's swept boxes, not cached */
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscReal rho = wfar; /* how far the vertices strayed from xwide */
  if (wfar > 0.5 * (sd->wmargin - sd->margin)) {
    sd->wide.clear();
    PetscCall(BroadPhase(sd, x, NULL, 0, dhat + sd->wmargin, [&](PetscBool ee, const PetscInt *v) {
      sd->wide.push_back(ee);
      sd->wide.insert(sd->wide.end(), v, v + 4);
    }));
    {
      /* sorted by their distance at x */
      const size_t                               n = sd->wide.size() / 5;
      std::vector<std::pair<PetscReal, PetscInt>> d(n);
      std::vector<PetscInt>                      sorted(5 * n);
      for (size_t k = 0; k < n; k++) {
        PetscReal w[4];
        d[k] = {std::sqrt(PairDistance2(x, (PetscBool)sd->wide[5 * k], &sd->wide[5 * k + 1], w)), (PetscInt)k};
      }
      std::sort(d.begin(), d.end());
      sd->wd.resize(n);
      for (size_t k = 0; k < n; k++) {
        sd->wd[k] = d[k].first;
        for (int q = 0; q < 5; q++) sorted[5 * k + q] = sd->wide[5 * d[k].second + q];
      }
      sd->wide.swap(sorted);
    }
    sd->xwide = x;
    rho       = 0;
    sd->widesum += sd->wide.size() / 5;
    sd->wplan = sd->surf->nplans;
    sd->wuses = 0;
    sd->nwide++;
  }
  /* the near list from the wide one: the pairs within dhat + margin at x */
  const PetscReal r2 = (dhat + sd->margin) * (dhat + sd->margin);
  const size_t    nw = WidePrefix(sd, dhat + sd->margin + 2 * rho);
  sd->cand.clear();
  for (size_t k = 0; k < nw; k += 5) {
    PetscReal w[4];
    if (!PairApart(x, NULL, 0, (PetscBool)sd->wide[k], &sd->wide[k + 1], dhat + sd->margin) && PairDistance2(x, (PetscBool)sd->wide[k], &sd->wide[k + 1], w) < r2) sd->cand.insert(sd->cand.end(), &sd->wide[k], &sd->wide[k + 5]);
  }
  sd->xlist = x;
  sd->nearsum += sd->cand.size() / 5;
  sd->plan  = sd->surf->nplans;
  sd->wuses++;
  sd->nbuild++;
  for (size_t k = 0; k < sd->cand.size(); k += 5)
    if (!PairApart(x, NULL, 0, (PetscBool)sd->cand[k], &sd->cand[k + 1], dhat)) f((PetscBool)sd->cand[k], &sd->cand[k + 1]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscReal PairDistance2(const std::vector<PetscReal> &x, PetscBool ee, const PetscInt *v, PetscReal w[4])
{
  const PetscReal *p0 = &x[3 * v[0]], *p1 = &x[3 * v[1]], *p2 = &x[3 * v[2]], *p3 = &x[3 * v[3]];
  return ee ? MSimEdgeEdgeDistance2(p0, p1, p2, p3, w) : MSimPointTriangleDistance2(p0, p1, p2, p3, w);
}

/* The local surface's connectivity (once per halo plan): neighbours along edges and triangles of
   each local vertex. A vertex's star is complete wherever a term within dhat that the rank owns
   needs it: the elements around a term's vertices are within dhat of an own element, so in the
   halo (self_surface.cpp keeps every element within dhat + margin of the rank's own). */
static void Connect(SelfData *sd)
{
  MSimSelfSurface s  = sd->surf;
  const PetscInt  nv = (PetscInt)s->vid.size(), ne = (PetscInt)s->edge.size() / 2, nt = (PetscInt)s->tri.size() / 3;
  if (sd->cplan == s->nplans) return;
  auto csr = [&](const std::vector<PetscInt> &el, int per, PetscInt n, bool other, std::vector<PetscInt> &off, std::vector<PetscInt> &adj) {
    off.assign(nv + 1, 0);
    for (PetscInt k = 0; k < per * n; k++) off[el[k] + 1]++;
    for (PetscInt v = 0; v < nv; v++) off[v + 1] += off[v];
    adj.resize(off[nv]);
    std::vector<PetscInt> at(off.begin(), off.end() - 1);
    for (PetscInt k = 0; k < n; k++)
      for (int q = 0; q < per; q++) adj[at[el[per * k + q]]++] = other ? el[per * k + 1 - q] : k;
  };
  csr(s->edge, 2, ne, true, sd->nbr_off, sd->nbr);
  csr(s->tri, 3, nt, false, sd->vtri_off, sd->vtri);
  sd->cplan = s->nplans;
}

static inline bool TriHas(const SelfData *sd, PetscInt t, PetscInt v)
{
  const PetscInt *tv = &sd->surf->tri[3 * t];
  return tv[0] == v || tv[1] == v || tv[2] == v;
}

static inline bool Adjacent(const SelfData *sd, PetscInt p, PetscInt q)
{
  for (PetscInt k = sd->nbr_off[p]; k < sd->nbr_off[p + 1]; k++)
    if (sd->nbr[k] == q) return true;
  return false;
}

/* The weights that count each contact once (inclusion-exclusion over the features' stars, as the
   "improved max approximator" of convergent IPC, Li et al. 2023): a vertex p whose closest feature
   on the other part of the surface is an edge e is as close to each triangle on e and, when its
   own edges leave it away from the surface, each edge-edge pair (a at p, e) is as close too: the
   pairs' barriers would count that contact 1 + 1 + |edges at p| times, where a contact inside a
   face counts once. With every vertex-disjoint pair of features in the energy at weight c, and c
   chosen so that the weights of the pairs that contain a given closest pair of features (the
   pairs whose distance is that pair's) sum to 1, every contact counts once, whatever features
   are closest: c = 1 for point-triangle and edge-edge pairs (their contacts: a vertex against a
   face's inside, two edges crossing), and below, solving W = 1 from the top down, for a point p
   against an edge e and a point p against a point q. Each term is as smooth as the pairs' (a barrier
   of a squared distance between convex sets), and so is their weighted sum, at every weight; but
   an edge-edge pair whose edges lie parallel and overlap has two closest vertex-edge features at
   once (both ends of one edge against the other) while the weights count it in each: there the
   pair's barrier, already only continuous (the distance of parallel segments is a min), is no
   longer outweighed by the other pairs at those contacts, and the energy is the max of the two
   vertices' barriers instead of their sum. A fold of a regular grid settles on such parallel edges
   and Newton stalls there (runs/self_contact/README.md, "Each contact counted once"). */
static PetscReal WeightPE(const SelfData *sd, PetscInt p, PetscInt e0, PetscInt e1)
{
  PetscInt n = 0;
  for (PetscInt k = sd->vtri_off[e0]; k < sd->vtri_off[e0 + 1]; k++) /* triangles on e without p */
    if (TriHas(sd, sd->vtri[k], e1) && !TriHas(sd, sd->vtri[k], p)) n++;
  for (PetscInt k = sd->nbr_off[p]; k < sd->nbr_off[p + 1]; k++) /* edges at p that miss e */
    if (sd->nbr[k] != e0 && sd->nbr[k] != e1) n++;
  return (PetscReal)(1 - n);
}

static PetscReal WeightPP(const SelfData *sd, PetscInt p, PetscInt q)
{
  PetscReal n = 0;
  for (PetscInt k = sd->vtri_off[q]; k < sd->vtri_off[q + 1]; k++) n += !TriHas(sd, sd->vtri[k], p); /* (p, triangle at q) */
  for (PetscInt k = sd->vtri_off[p]; k < sd->vtri_off[p + 1]; k++) n += !TriHas(sd, sd->vtri[k], q); /* (q, triangle at p) */
  for (PetscInt k = sd->nbr_off[q]; k < sd->nbr_off[q + 1]; k++)                                    /* (p, edge at q) */
    if (sd->nbr[k] != p) n += WeightPE(sd, p, q, sd->nbr[k]);
  for (PetscInt k = sd->nbr_off[p]; k < sd->nbr_off[p + 1]; k++) /* (q, edge at p) */
    if (sd->nbr[k] != q) n += WeightPE(sd, q, p, sd->nbr[k]);
  for (PetscInt k = sd->nbr_off[p]; k < sd->nbr_off[p + 1]; k++) /* (edge at p, edge at q), disjoint */
    for (PetscInt l = sd->nbr_off[q]; l < sd->nbr_off[q + 1]; l++) n += sd->nbr[k] != q && sd->nbr[l] != p && sd->nbr[k] != sd->nbr[l];
  return 1 - n;
}

/* The terms within dhat at sd->x that this rank computes, into sd->act, sorted by their vertices'
   input ids (then kind): the sums over them do not depend on the order the candidate lists hold
   their pairs in, which depends on where the lists were made (a restart makes them elsewhere),
   so a restarted run repeats the uninterrupted one bit for bit. A term is the rank's when its
   least input id is in the rank's block. With dup, also the point-edge and point-point terms
   (weights above): every one within dhat is a feature pair of a point-triangle or edge-edge pair
   within dhat (the triangle or the edges containing its features are at most as far), so they
   are derived from those pairs, not kept in the lists (the CCD has no use for them: a point
   reaches an edge or a point only through the triangles and edges around it). A point-edge pair
   none of whose super-pairs exists (p's edges and e's triangles all touch e or p: a collapsed
   neighbourhood, no contact) is left out, as before; point-point pairs of neighbours too. */
static PetscErrorCode Collect(SelfData *sd, PetscBool dup, PetscBool bykey)
{
  MSimSelfSurface s   = sd->surf;
  const PetscReal dh2 = s->dhat * s->dhat;
  auto            own = [&](const PetscInt *v, const PetscReal *w) {
    PetscInt low    = PETSC_MAX_INT;
    bool     moving = false;
    for (int k = 0; k < 4; k++) {
      if (!bykey || w[k] != 0) low = PetscMin(low, s->vid[v[k]]);
      moving = moving || s->gnum[v[k]] >= 0;
    }
    return moving && low >= s->dstart && low < s->dstart + s->dcount;
  };
  auto add = [&](PetscInt kind, const PetscInt *v, PetscReal s2, const PetscReal *w, PetscReal c) {
    SelfTerm t;
    t.kind = kind;
    t.s    = s2;
    t.c    = c;
    for (int k = 0; k < 4; k++) t.v[k] = v[k], t.w[k] = w[k], t.gid[k] = s->vid[v[k]];
    sd->act.push_back(t);
  };

  PetscFunctionBeginUser;
  sd->act.clear();
  sd->sub.clear();
  dup = (PetscBool)(dup && sd->once);
  if (dup) Connect(sd);
  PetscCall(ForEachPair(sd, sd->x, NULL, 0, [&](PetscBool ee, const PetscInt *v) {
    PetscReal       w[4];
    const PetscReal s2 = PairDistance2(sd->x, ee, v, w);
    if (s2 >= dh2) return;
    if (own(v, w)) add(ee ? KIND_EE : KIND_PT, v, s2, w, 1.0);
    if (!dup) return;
    /* only the feature pairs within dhat (most pairs' closest points lie inside their elements,
       away from the features), so that the sort below sees few */
    auto keep = [&](const std::array<PetscInt, 5> &q) {
      PetscReal wq[4];
      if (PairDistance2(sd->x, PETSC_TRUE, &q[1], wq) < dh2) sd->sub.push_back(q);
    };
    auto pe = [&](PetscInt p, PetscInt a, PetscInt b) { keep({KIND_PE, p, p, PetscMin(a, b), PetscMax(a, b)}); };
    auto pp = [&](PetscInt p, PetscInt q) { keep({KIND_PP, PetscMin(p, q), PetscMin(p, q), PetscMax(p, q), PetscMax(p, q)}); };
    if (!ee) {
      pe(v[0], v[1], v[2]), pe(v[0], v[1], v[3]), pe(v[0], v[2], v[3]);
      pp(v[0], v[1]), pp(v[0], v[2]), pp(v[0], v[3]);
    } else {
      pe(v[0], v[2], v[3]), pe(v[1], v[2], v[3]), pe(v[2], v[0], v[1]), pe(v[3], v[0], v[1]);
      pp(v[0], v[2]), pp(v[0], v[3]), pp(v[1], v[2]), pp(v[1], v[3]);
    }
  }));
  if (dup) {
    std::sort(sd->sub.begin(), sd->sub.end());
    sd->sub.erase(std::unique(sd->sub.begin(), sd->sub.end()), sd->sub.end());
    for (const std::array<PetscInt, 5> &q : sd->sub) {
      const PetscInt *v = &q[1];
      PetscReal       w[4];
      if (q[0] == KIND_PP && Adjacent(sd, v[0], v[2])) continue;
      const PetscReal s2 = PairDistance2(sd->x, PETSC_TRUE, v, w);
      if (s2 >= dh2 || !own(v, w)) continue;
      const PetscReal c = q[0] == KIND_PE ? WeightPE(sd, v[0], v[2], v[3]) : WeightPP(sd, v[0], v[2]);
      if (c != 0) add(q[0], v, s2, w, c);
    }
  }
  std::sort(sd->act.begin(), sd->act.end(), [](const SelfTerm &a, const SelfTerm &b) { return a.gid != b.gid ? a.gid < b.gid : a.kind < b.kind; });
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The local energy and gradient at the gathered positions sd->x, into eeval and geval, unless the
   last evaluation was at the same positions (and halo plan) */
static PetscErrorCode Evaluate(SelfData *sd)
{
  const PetscReal dh2 = sd->surf->dhat * sd->surf->dhat;
  PetscReal       local = 0;

  PetscFunctionBeginUser;
  if (sd->eplan == sd->surf->nplans && sd->xeval.size() == sd->x.size() && std::equal(sd->x.begin(), sd->x.end(), sd->xeval.begin())) {
    sd->nhits++;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(PetscLogEventBegin(MSIM_SelfNarrow, 0, 0, 0, 0));
  sd->geval.assign(sd->x.size(), 0);
  sd->npairs = 0;
  sd->dmin   = PETSC_INFINITY;
  PetscCall(Collect(sd, PETSC_TRUE, PETSC_FALSE));
  for (const SelfTerm &t : sd->act) {
    PetscReal b, db, d2b, r[3] = {0, 0, 0};
    if (t.s <= 0) local = PETSC_INFINITY;
    else if (local < PETSC_INFINITY) {
      MSimBarrier(t.s, dh2, &b, &db, &d2b);
      local += sd->C * t.c * b;
    }
    /* the gradient as Newton's: at a distance clamped away from 0 */
    MSimBarrier(PetscMax(t.s, PETSC_SMALL * dh2), dh2, &b, &db, &d2b);
    for (int k = 0; k < 4; k++)
      for (int c = 0; c < 3; c++) r[c] += t.w[k] * sd->x[3 * t.v[k] + c];
    for (int k = 0; k < 4; k++)
      for (int c = 0; c < 3; c++) sd->geval[3 * t.v[k] + c] += 2 * sd->C * t.c * db * t.w[k] * r[c];
    if (t.kind <= KIND_EE) {
      sd->npairs++;
      sd->dmin = PetscMin(sd->dmin, std::sqrt(t.s));
    }
  }
  sd->eeval = local;
  sd->xeval = sd->x;
  sd->eplan = sd->surf->nplans;
  sd->nevals++;
  PetscCall(PetscLogEventEnd(MSIM_SelfNarrow, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode LocalEnergy(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  SelfData *sd = (SelfData *)term->data;

  PetscFunctionBeginUser;
  PetscCall(MSimSelfSurfaceGather(sd->surf, term->imp->step.tx, X, NULL, 0, sd->x, NULL));
  PetscCall(Evaluate(sd));
  *e += sd->eeval;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += sign times the gradient (sent to the vertices' owners) */
static PetscErrorCode AddGradient(MSimImplicitTerm term, Vec X, Vec G, PetscReal sign)
{
  SelfData *sd = (SelfData *)term->data;

  PetscFunctionBeginUser;
  PetscCall(MSimSelfSurfaceGather(sd->surf, term->imp->step.tx, X, NULL, 0, sd->x, NULL));
  PetscCall(Evaluate(sd));
  sd->g.resize(sd->geval.size());
  for (size_t k = 0; k < sd->g.size(); k++) sd->g[k] = sign * sd->geval[k];
  PetscCall(MSimSelfSurfaceAddGradient(sd->surf, sd->g, G));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Hessian_Self(MSimImplicitTerm term, Vec X, PetscBool psd, Mat J)
{
  SelfData        *sd  = (SelfData *)term->data;
  MSimSelfSurface  s   = sd->surf;
  const PetscReal  dh2 = s->dhat * s->dhat;
  PetscErrorCode   ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  PetscCall(MSimSelfSurfaceGather(s, term->imp->step.tx, X, NULL, 0, sd->x, NULL));
  PetscCall(PetscLogEventBegin(MSIM_SelfNarrow, 0, 0, 0, 0));
  PetscCall(Collect(sd, PETSC_TRUE, (PetscBool)(psd && sd->once)));
  PetscCall(MSimSelfHessianBegin(&sd->hess, J));
  /* A term's block, with its closest points held fixed and projected in closed form (the header):
     lambda (w w^T) kron (r r^T), lambda = C max(0, 4 b'' s + 2 b') / s, times the term's weight c.
     Without -msim_self_contact_once every weight is 1 and the sum of these blocks is PSD. With it,
     the point-edge and point-point terms carry weights c < 0 that cancel the duplicates, and
     projecting each term on its own would keep the duplicates' blocks and drop their corrections:
     a Hessian 5 x (above an edge) and 32 x (above a vertex) stiffer than the energy there, and
     Newton's steps too short. So with psd the terms are grouped
     by the features their closest points lie on (a point-triangle pair whose closest point is on
     an edge is the point-edge term of that edge; on a vertex, the point-point term; an edge-edge
     pair at an end likewise): the terms of one group are one distance function (the same r, the
     same weights on the same vertices), so their blocks are one block times the sum of their
     weighted lambdas, kappa, and the group's sum is projected once: max(0, kappa) times the block.
     Where the duplicates coincide (a point above an edge or a vertex) kappa is one barrier's and
     the Hessian is the energy's (tests/unit/test_self_features.cpp); a group is the rank's when
     the least input id of its features' vertices is in the rank's block, which holds every
     term of it (Collect's bykey). Without psd (a direct solver with inertia correction), the
     weighted sum of the blocks. */
  const bool group = psd && sd->once;
  auto       block = [&](const SelfTerm &t, PetscReal lambda) {
    PetscReal   r[3] = {0, 0, 0};
    PetscInt    gnum[4];
    PetscScalar H[144];
    if (lambda == 0 || ierr) return;
    for (int k = 0; k < 4; k++)
      for (int c = 0; c < 3; c++) r[c] += t.w[k] * sd->x[3 * t.v[k] + c];
    for (int k = 0; k < 4; k++) gnum[k] = s->gnum[t.v[k]];
    for (int i = 0; i < 12; i++)
      for (int j = 0; j < 12; j++) H[12 * i + j] = lambda * t.w[i / 3] * t.w[j / 3] * r[i % 3] * r[j % 3];
    ierr = MSimSelfHessianAdd(&sd->hess, gnum, H);
  };
  auto lam = [&](const SelfTerm &t) {
    PetscReal b, db, d2b;
    MSimBarrier(PetscMax(t.s, PETSC_SMALL * dh2), dh2, &b, &db, &d2b);
    return sd->C * PetscMax(0.0, 4 * d2b * t.s + 2 * db) / PetscMax(t.s, PETSC_SMALL * dh2);
  };
  if (!group) {
    for (const SelfTerm &t : sd->act)
      if (!psd || t.c > 0) block(t, t.c * lam(t));
  } else {
    /* each term's features: the input ids of its vertices of nonzero weight on each side, the
       sides ordered (the same features from a point-triangle and from an edge-edge pair) */
    const size_t n = sd->act.size();
    sd->keys.resize(n);
    sd->order.resize(n);
    for (size_t k = 0; k < n; k++) {
      const SelfTerm &t     = sd->act[k];
      const int       split = t.kind == KIND_PT ? 1 : 2;
      PetscInt        side[2][3] = {{-1, -1, -1}, {-1, -1, -1}};
      int             m[2]       = {0, 0};
      for (int q = 0; q < 4; q++) {
        const int h = q >= split;
        bool      seen = false;
        for (int z = 0; z < m[h]; z++) seen = seen || side[h][z] == t.gid[q];
        if (t.w[q] == 0 || seen) continue;
        side[h][m[h]++] = t.gid[q];
        for (int z = m[h] - 1; z > 0 && side[h][z] < side[h][z - 1]; z--) std::swap(side[h][z], side[h][z - 1]); /* ascending */
      }
      const int first = std::lexicographical_compare(side[1], side[1] + 3, side[0], side[0] + 3) ? 1 : 0;
      for (int q = 0; q < 3; q++) sd->keys[k][q] = side[first][q], sd->keys[k][3 + q] = side[1 - first][q];
      sd->order[k] = (PetscInt)k;
    }
    /* stable: within a group the input-id order of Collect, so the sums repeat on a restart */
    std::stable_sort(sd->order.begin(), sd->order.end(), [&](PetscInt a, PetscInt b) { return sd->keys[a] < sd->keys[b]; });
    for (size_t k = 0; k < n;) {
      size_t    l     = k;
      PetscReal kappa = 0;
      for (; l < n && sd->keys[sd->order[l]] == sd->keys[sd->order[k]]; l++) kappa += sd->act[sd->order[l]].c * lam(sd->act[sd->order[l]]);
      block(sd->act[sd->order[k]], PetscMax(kappa, 0.0));
      k = l;
    }
  }
  PetscCall(PetscLogEventEnd(MSIM_SelfNarrow, 0, 0, 0, 0));
  PetscCall(ierr);
  PetscCall(MSimSelfHessianEnd(&sd->hess, s->xscatter)); /* the pairs' free vertices are its leaves */
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MaxStep_Self(MSimImplicitTerm term, Vec X, Vec Y, PetscReal *alpha)
{
  SelfData *sd = (SelfData *)term->data;
  PetscReal a  = *alpha, t = 1;

  PetscFunctionBeginUser;
  PetscCall(MSimSelfSurfaceGather(sd->surf, term->imp->step.tx, X, Y, a, sd->x, &sd->u));
  PetscCall(PetscLogEventBegin(MSIM_SelfCCD, 0, 0, 0, 0));
  auto ccd = [&](PetscReal am, PetscReal &tm) {
    return [&, am](PetscBool ee, const PetscInt *v) {
      PetscReal xp[12], up[12];
      for (int k = 0; k < 4; k++)
        for (int c = 0; c < 3; c++) {
          xp[3 * k + c] = sd->x[3 * v[k] + c];
          up[3 * k + c] = am * sd->u[3 * v[k] + c];
        }
      tm = PetscMin(tm, MSimAdditiveCCD(xp, up, ee, sd->opt.ccd_s));
    };
  };
  /* A long step (PD's global step ignores the barrier; Newton's first trial) leaves the lists'
     reach, and a swept broad phase over the whole motion is then the costliest query. First the
     part am of the motion in which no vertex moves more than dhat / 4 (less the shared motion,
     Reach): two elements then come closer by at most dhat / 2, so only the pairs within dhat at x
     can touch before am, and when one of them stops the motion within am that is a safe step
     (conservative like any ACCD answer; PD's lagged barrier proposes huge steps that a close pair
     cuts to almost nothing). Otherwise the whole motion. am and the pairs within dhat depend on x,
     u and a only, not on where the lists were made, so neither does the answer (a restart repeats
     the run bit for bit); either list holds every pair within dhat at x while it is valid. */
  const PetscReal dhat = sd->surf->dhat, rc = 0.25 * dhat, ru = Reach(sd->x, sd->x, &sd->u, a);
  PetscReal       am   = ru > rc ? a * (rc / ru) : a;
  bool            done = false;
  for (int it = 0; it < 8 && Reach(sd->x, sd->x, &sd->u, am) > rc; it++) am *= 0.5; /* roundoff */
  if (am > 0 && Reach(sd->x, sd->x, &sd->u, am) <= rc) {
    const std::vector<PetscInt> *list = NULL;
    size_t                       n    = 0;
    if (sd->plan == sd->surf->nplans && sd->xlist.size() == sd->x.size() && Reach(sd->xlist, sd->x, NULL, 0) <= 0.5 * sd->margin) list = &sd->cand, n = sd->cand.size();
    else if (sd->wplan == sd->surf->nplans && sd->xwide.size() == sd->x.size()) {
      const PetscReal rw = Reach(sd->xwide, sd->x, NULL, 0);
      if (rw <= 0.5 * sd->wmargin) list = &sd->wide, n = WidePrefix(sd, dhat + 2 * rw);
    }
    if (list) {
      PetscReal t0 = 1, w[4];
      auto      f  = ccd(am, t0);
      for (size_t k = 0; k < n; k += 5)
        if (!PairApart(sd->x, NULL, 0, (PetscBool)(*list)[k], &(*list)[k + 1], dhat) && PairDistance2(sd->x, (PetscBool)(*list)[k], &(*list)[k + 1], w) < dhat * dhat) f((PetscBool)(*list)[k], &(*list)[k + 1]);
      if (t0 < 1 || am == a) t = am * t0 / a, done = true;
    }
  }
  if (!done) PetscCall(ForEachPair(sd, sd->x, &sd->u, a, ccd(a, t)));
  PetscCall(PetscLogEventEnd(MSIM_SelfCCD, 0, 0, 0, 0));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &t, 1, MPIU_REAL, MPIU_MIN, term->imp->sys->comm));
  *alpha = a * t;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Moving handles (-msim_fix_velocity w, the same for every fixed vertex): a step moves the fixed
   vertices by w h at once, the free ones not at all (A holds x_n, or what the obstacles' feasible
   start made of it), and MSimImplicitGuess pulls the first iterate back towards A with the
   handles already at b(tx). A handle that came w h towards a free element passed it unseen when w
   h exceeded their gap: a sheet raised 8 cm a step through a patch 6 cm above it left the patch
   under it, with no contact force ever. In the handles' frame that start is the free vertices'
   motion from x_n + w h to A, the handles still, whose beginning is the configuration of (x_n,
   b(t)) moved rigidly, so apart; CCD along it gives the fraction t that is safe, and A becomes
   the point there: the free vertices are carried (1 - t) w h with the handles, none of them when
   nothing comes near (t = 1, A unchanged). A vertex so carried into an obstacle has no feasible
   start: that is refused. */
static PetscErrorCode FeasibleStart_Self(MSimImplicitTerm term, Vec A)
{
  SelfData       *sd  = (SelfData *)term->data;
  MSimImplicit    imp = term->imp;
  MSimSystem      sys = imp->sys;
  const PetscReal h = imp->step.tx - imp->step.t, *w = sys->fix_velocity;
  PetscReal       t = 1;
  PetscScalar    *z;

  PetscFunctionBeginUser;
  if (!sd->hz) {
    PetscCall(VecDuplicate(A, &sd->hz));
    PetscCall(VecDuplicate(A, &sd->hd));
  }
  Vec Z = sd->hz, D = sd->hd;
  PetscCall(VecCopy(imp->Xn, Z));
  PetscCall(VecGetArray(Z, &z));
  for (PetscInt k = 0; k < 3 * sys->nown; k++) z[k] += w[k % 3] * h;
  PetscCall(VecRestoreArray(Z, &z));
  PetscCall(VecWAXPY(D, -1.0, A, Z)); /* the motion Z - a D, A at a = 1 */
  PetscCall(MaxStep_Self(term, Z, D, &t));
  if (t < 1) {
    MSimContact        ct;
    const PetscScalar *a;
    PetscInt           inside = 0;
    PetscCall(VecWAXPY(A, -t, D, Z));
    PetscCall(MSimContactGet(sys, &ct));
    PetscCall(VecGetArrayRead(A, &a));
    for (PetscInt v = 0; ct && v < sys->nown && !inside; v++)
      for (const MSimObstacle &o : ct->obs) {
        PetscReal n[3];
        if (MSimObstacleDistanceAt(&o, imp->step.tx, a + 3 * v, n, NULL) <= 0) inside = 1;
      }
    PetscCall(VecRestoreArrayRead(A, &a));
    PetscCall(MSimCollectiveCheck(sys->comm, (PetscBool)!inside, "the moving handles (-msim_fix_velocity) carry the surface into an obstacle at t = " + std::to_string((double)imp->step.tx) + ": no position outside it (a smaller -msim_dt)"));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_Self(MSimImplicitTerm term, PetscViewer viewer)
{
  SelfData *sd = (SelfData *)term->data;
  PetscInt  tris = (PetscInt)sd->surf->own_tris.size(), halo = sd->surf->nhalo, plans = sd->surf->nplans;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &halo, 1, MPIU_INT, MPI_SUM, term->imp->sys->comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &tris, 1, MPIU_INT, MPI_SUM, term->imp->sys->comm));
  PetscCall(PetscViewerASCIIPrintf(viewer, "self-contact: IPC barrier on point-triangle and edge-edge pairs, dhat %g m, weight C %g, additive CCD (gap fraction %g); own triangles %" PetscInt_FMT " (summed over ranks), halo triangles %" PetscInt_FMT ", plans on rank 0 %" PetscInt_FMT ", near candidate lists made %" PetscInt_FMT " and reused %" PetscInt_FMT " times, wide lists (grid) %" PetscInt_FMT " (margin now %g m) on rank 0\n", (double)sd->surf->dhat, (double)sd->C, (double)sd->opt.ccd_s, tris, halo, plans, sd->nbuild, sd->nreuse, sd->nwide, (double)sd->wmargin));
  PetscCall(PetscViewerASCIIPrintf(viewer, "self-contact on rank 0: energy/gradient passes %" PetscInt_FMT ", repeated queries answered from the last pass %" PetscInt_FMT ", mean pairs per wide list %g, per near list %g; CCDs over a swept broad phase %" PetscInt_FMT "\n", sd->nevals, sd->nhits, sd->nwide ? sd->widesum / sd->nwide : 0.0, sd->nbuild ? sd->nearsum / sd->nbuild : 0.0, sd->nswept));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Self(MSimImplicitTerm term)
{
  SelfData *sd = (SelfData *)term->data;

  PetscFunctionBeginUser;
  PetscCall(MSimSelfSurfaceDestroy(&sd->surf));
  PetscCall(MSimDestroy(&sd->hz, &sd->hd));
  PetscCall(MSimSelfHessianDestroy(&sd->hess));
  delete sd;
  term->data = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode CheckStart_Self(MSimImplicitTerm term, PetscReal t, Vec X, const char *restart)
{
  SelfData *sd = (SelfData *)term->data;

  PetscFunctionBeginUser;
  if (sd->opt.start_check) PetscCall(MSimSelfSurfaceCheckStart(sd->surf, &sd->opt, t, X, restart));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimImplicitTermOps SelfOps = {.energy = MSimTermSummedEnergy<LocalEnergy>, .gradient = MSimTermGradient<AddGradient>, .hessian = Hessian_Self, .pd_rhs = MSimTermPDRHS<LocalEnergy, AddGradient>, .max_step = MaxStep_Self, .check_start = CheckStart_Self, .view = View_Self, .destroy = Destroy_Self};

PetscErrorCode MSimImplicitTermCreate_SelfContact(MSimImplicitTerm term)
{
  MSimSystem                   sys = term->imp->sys;
  const MSimSelfContactOptions o   = sys->self_contact; /* the scene read them */

  PetscFunctionBeginUser;
  if (!o.on) PetscFunctionReturn(PETSC_SUCCESS); /* off: no op, nothing per iteration */
  PetscCheck(!term->imp->scheme->no_barrier, sys->comm, PETSC_ERR_SUP, "-msim_integrator %s with -msim_self_contact is not supported (%s): use implicit_euler or bdf2", term->imp->scheme->type, term->imp->scheme->no_barrier);
  SelfData *sd = new SelfData();
  sd->opt      = o;
  term->data   = sd;
  term->ops.destroy = Destroy_Self;
  PetscCall(MSimSelfHessianCreate(sys->comm, &sd->hess));
  PetscCall(MSimSelfSurfaceCreate(sys, &o, &sd->surf));
  {
    const PetscReal s0 = 0.25 * sd->surf->dhat * sd->surf->dhat, dh2 = sd->surf->dhat * sd->surf->dhat, mbar = sys->total_mass / sys->nv;
    PetscReal       b, db, d2b;
    MSimBarrier(s0, dh2, &b, &db, &d2b);
    sd->C = o.stiffness * mbar / (4 * s0 * d2b + 2 * db);
  }
  /* the candidate list's margin: pairs within 2 dhat, reused while no vertex moved dhat / 2 */
  sd->once = o.once; /* -msim_self_contact_once (self_options.cpp: why it is off) */
  sd->margin  = sd->surf->dhat;
  sd->wmargin = 4 * sd->margin;
  sd->eplan   = -1;
  sd->cplan   = -1;
  term->ops   = SelfOps;
  {
    /* moving handles on the surface (on any rank): their step needs a feasible start */
    PetscInt        nfixed = (PetscInt)sd->surf->fixed.size();
    const PetscReal *w     = sys->fix_velocity;
    PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &nfixed, 1, MPIU_INT, MPI_SUM, sys->comm));
    if (nfixed && (w[0] != 0 || w[1] != 0 || w[2] != 0)) term->ops.feasible_start = FeasibleStart_Self;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfContactGetPairs(MSimImplicitTerm term, PetscReal t, Vec X, std::vector<MSimSelfContactPair> &pairs)
{
  SelfData       *sd  = (SelfData *)term->data;
  const PetscReal dh2 = sd->surf->dhat * sd->surf->dhat;

  PetscFunctionBeginUser;
  pairs.clear();
  PetscCall(MSimSelfSurfaceGather(sd->surf, t, X, NULL, 0, sd->x, NULL));
  /* the point-triangle and edge-edge pairs only, each at its own barrier's force: the friction
     term's Hessian is exact and PSD only with positive forces (not done: the duplicates' weights
     there, so friction still counts a contact at a shared edge or vertex once per pair) */
  PetscCall(Collect(sd, PETSC_FALSE, PETSC_FALSE));
  for (const SelfTerm &t : sd->act) {
    MSimSelfContactPair p;
    PetscReal           b, db, d2b, r[3] = {0, 0, 0};
    if (t.s <= 0) continue;
    MSimBarrier(t.s, dh2, &b, &db, &d2b);
    const PetscReal d = std::sqrt(t.s);
    for (int k = 0; k < 4; k++) {
      p.w[k]    = t.w[k];
      p.gnum[k] = sd->surf->gnum[t.v[k]];
      for (int c = 0; c < 3; c++) r[c] += t.w[k] * sd->x[3 * t.v[k] + c];
    }
    for (int c = 0; c < 3; c++) p.n[c] = r[c] / d;
    p.force = 2 * sd->C * PetscAbsReal(db) * d;
    pairs.push_back(p);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfHessianCreate(MPI_Comm comm, MSimSelfHessian *h)
{
  PetscFunctionBeginUser;
  PetscCall(PetscCommDuplicate(comm, &h->comm, &h->tag[0]));
  PetscCall(PetscCommGetNewTag(h->comm, &h->tag[1]));
  PetscCallMPI(MPI_Comm_rank(comm, &h->rank));
  PetscCallMPI(MPI_Comm_size(comm, &h->size));
  PetscCallMPI(MPI_Type_contiguous((int)sizeof(MSimSelfRows), MPI_BYTE, &h->type));
  PetscCallMPI(MPI_Type_commit(&h->type));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfHessianDestroy(MSimSelfHessian *h)
{
  PetscFunctionBeginUser;
  if (h->type != MPI_DATATYPE_NULL) PetscCallMPI(MPI_Type_free(&h->type));
  if (h->comm != MPI_COMM_NULL) PetscCall(PetscCommDestroy(&h->comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfHessianBegin(MSimSelfHessian *h, Mat J)
{
  PetscFunctionBeginUser;
  h->J = J;
  h->send.clear();
  h->dest.clear();
  PetscCall(MatGetOwnershipRanges(J, &h->ranges));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfHessianAdd(MSimSelfHessian *h, const PetscInt gnum[4], const PetscScalar H[144])
{
  const PetscInt lo = h->ranges[h->rank], hi = h->ranges[h->rank + 1];
  PetscInt       row[12], col[12];

  PetscFunctionBeginUser;
  for (int q = 0; q < 4; q++) {
    const bool mine = gnum[q] < 0 || (3 * gnum[q] >= lo && 3 * gnum[q] < hi);
    for (int c = 0; c < 3; c++) {
      col[3 * q + c] = gnum[q] >= 0 ? 3 * gnum[q] + c : -1;
      row[3 * q + c] = mine ? col[3 * q + c] : -1; /* negative: left out */
    }
    if (mine) continue;
    MSimSelfRows r;
    r.row = gnum[q];
    for (int k = 0; k < 4; k++) r.col[k] = gnum[k];
    for (int k = 0; k < 36; k++) r.v[k] = H[12 * (3 * q + k / 12) + k % 12];
    h->send.push_back(r);
    h->dest.push_back((PetscMPIInt)(std::upper_bound(h->ranges, h->ranges + h->size + 1, 3 * gnum[q]) - h->ranges - 1));
  }
  PetscCall(MatSetValues(h->J, 12, row, 12, col, H, ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfHessianEnd(MSimSelfHessian *h, VecScatter neighbours)
{
  PetscFunctionBeginUser;
  if (h->size > 1) {
    PetscInt                 nto, nfrom;
    const PetscMPIInt       *to, *from;
    std::vector<PetscMPIInt> scount, rcount, order;
    std::vector<PetscInt>    soff, roff;
    std::vector<MSimSelfRows> sorted;
    std::vector<MPI_Request> req;

    PetscCall(PetscSFSetUp(neighbours));
    PetscCall(PetscSFGetRootRanks(neighbours, &nto, &to, NULL, NULL, NULL));
    PetscCall(PetscSFGetLeafRanks(neighbours, &nfrom, &from, NULL, NULL));
    /* the rows grouped by owner (in to's order), each group in the order of Add */
    scount.assign(nto, 0);
    soff.assign(nto + 1, 0);
    std::vector<PetscInt> at(h->dest.size());
    PetscMPIInt           unreached = -1;
    for (size_t k = 0; k < h->dest.size(); k++) {
      at[k] = (PetscInt)(std::find(to, to + nto, h->dest[k]) - to);
      if (at[k] < nto) scount[at[k]]++;
      else unreached = h->dest[k];
    }
    /* an invariant (the pairs' free vertices are the scatter's leaves, so their owners are its
       roots), checked on every rank before the exchange: a rank stopping alone would leave its
       neighbours waiting for its counts */
    PetscCall(MSimCollectiveCheck(h->comm, (PetscBool)(unreached < 0), "a pair's vertex is owned by rank " + std::to_string(unreached) + ", which the pairs' scatter does not reach"));
    for (PetscInt i = 0; i < nto; i++) soff[i + 1] = soff[i] + scount[i];
    sorted.resize(h->send.size());
    {
      std::vector<PetscInt> next(soff.begin(), soff.end() - 1);
      for (size_t k = 0; k < h->send.size(); k++) sorted[next[at[k]]++] = h->send[k];
    }
    /* the counts, then the rows (a zero count: no message) */
    rcount.assign(nfrom, 0);
    for (PetscInt i = 0; i < nfrom; i++)
      if (from[i] != h->rank) {
        req.emplace_back();
        PetscCallMPI(MPI_Irecv(&rcount[i], 1, MPI_INT, from[i], h->tag[0], h->comm, &req.back()));
      }
    for (PetscInt i = 0; i < nto; i++)
      if (to[i] != h->rank) {
        req.emplace_back();
        PetscCallMPI(MPI_Isend(&scount[i], 1, MPI_INT, to[i], h->tag[0], h->comm, &req.back()));
      }
    PetscCallMPI(MPI_Waitall((int)req.size(), req.data(), MPI_STATUSES_IGNORE));
    req.clear();
    roff.assign(nfrom + 1, 0);
    for (PetscInt i = 0; i < nfrom; i++) roff[i + 1] = roff[i] + rcount[i];
    h->recv.resize(roff[nfrom]);
    for (PetscInt i = 0; i < nfrom; i++)
      if (rcount[i]) {
        req.emplace_back();
        PetscCallMPI(MPI_Irecv(h->recv.data() + roff[i], rcount[i], h->type, from[i], h->tag[1], h->comm, &req.back()));
      }
    for (PetscInt i = 0; i < nto; i++)
      if (scount[i]) {
        req.emplace_back();
        PetscCallMPI(MPI_Isend(sorted.data() + soff[i], scount[i], h->type, to[i], h->tag[1], h->comm, &req.back()));
      }
    PetscCallMPI(MPI_Waitall((int)req.size(), req.data(), MPI_STATUSES_IGNORE));
    /* added after this rank's own blocks, by sender in rank order */
    order.resize(nfrom);
    for (PetscInt i = 0; i < nfrom; i++) order[i] = (PetscMPIInt)i;
    std::sort(order.begin(), order.end(), [&](PetscMPIInt a, PetscMPIInt b) { return from[a] < from[b]; });
    for (PetscMPIInt i : order)
      for (PetscInt k = roff[i]; k < roff[i + 1]; k++) {
        const MSimSelfRows &r = h->recv[k];
        PetscInt            row[3], col[12];
        for (int c = 0; c < 3; c++) row[c] = 3 * r.row + c;
        for (int q = 0; q < 12; q++) col[q] = r.col[q / 3] >= 0 ? 3 * r.col[q / 3] + q % 3 : -1;
        PetscCall(MatSetValues(h->J, 3, row, 12, col, r.v, ADD_VALUES));
      }
  }
  PetscCall(MatAssemblyBegin(h->J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(h->J, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}
