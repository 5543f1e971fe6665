/* The surface a rank sees for self-contact (msim/self_contact.h): its own triangles (every one
   with a vertex in its block of input ids: all the elements around its vertices) and a halo of
   other ranks' triangles near them, with one scatter from the state Vec for their free
   vertices' positions (the fixed ones follow b(t)) and its reverse (ADD_VALUES) for the gradient;
   a plan reads positions from the natural-order Vec, where every vertex is. No rank ever holds the
   surface whole: a plan allgathers 6 numbers per rank (each rank's box around its own triangles,
   grown by the contact distance and a motion margin), and each rank sends (MSimExchange) only its
   own triangles that fall in a neighbour's box. A pair is computed by the rank whose block holds
   the pair's lowest input id: every element around that vertex is its own, and the other element,
   within dhat of it, was within dhat + margin at the plan, so in its halo. The plan is redone
   when a vertex (at an iterate or along a line search's motion) gets further than margin / 2
   from its planned position: two elements then moved together by at most the margin. */
#include <msim/private/selfcontactimpl.h>
#include <msim/errors.h>
#include <msim/private/systemimpl.h>
#include <msim/destroy.h>
#include <cmath>

PetscLogEvent MSIM_SelfBroad = 0, MSIM_SelfHalo = 0, MSIM_SelfNarrow = 0, MSIM_SelfCCD = 0;

PetscErrorCode MSimSelfContactLogRegister(void)
{
  PetscClassId cls;

  PetscFunctionBeginUser;
  if (MSIM_SelfBroad) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscClassIdRegister("msim self-contact", &cls));
  PetscCall(PetscLogEventRegister("MSimSelfBroad", cls, &MSIM_SelfBroad));
  PetscCall(PetscLogEventRegister("MSimSelfHalo", cls, &MSIM_SelfHalo));
  PetscCall(PetscLogEventRegister("MSimSelfNarrow", cls, &MSIM_SelfNarrow));
  PetscCall(PetscLogEventRegister("MSimSelfCCD", cls, &MSIM_SelfCCD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static MSimSelfTri Sorted(PetscInt a, PetscInt b, PetscInt c)
{
  MSimSelfTri v = {a, b, c};
  std::sort(v.begin(), v.end());
  return v;
}

/* the cloth grid's triangles: cell (i, j) is split along its (i,j)-(i+1,j+1) diagonal, which is a
   shear spring (src/scene/cloth.cpp numbers vertex (i, j) j N + i) */
static MSimSelfTri ClothTri(PetscInt N, PetscInt t)
{
  const PetscInt cell = t / 2, i = cell % (N - 1), j = cell / (N - 1);
  const PetscInt a = j * N + i, b = a + 1, c = a + N + 1, d = a + N;
  return t % 2 ? Sorted(a, c, d) : Sorted(a, b, c);
}

PetscErrorCode MSimSelfSurfaceTriangles(MPI_Comm comm, const MSimSceneData &S, std::vector<PetscInt> &tris)
{
  std::vector<MSimSelfTri> faces, recv;
  std::vector<PetscMPIInt> dest;

  PetscFunctionBeginUser;
  tris.clear();
  PetscCheck(S.cell_size == 3 || S.cell_size == 4, comm, PETSC_ERR_PLIB, "self-contact's surface needs triangles or tets (cells of %d vertices)", S.cell_size);
  const size_t nc = S.cells.size() / S.cell_size;
  /* collective: the exchange below must not be left by one rank alone */
  PetscCall(MSimCollectiveCheck(comm, (PetscBool)(S.ncell == 0 || nc > 0 || S.cells_not_stored == 0), "the scene did not keep its cells for self-contact"));
  if (S.cell_size == 3) {
    for (size_t c = 0; c < nc; c++) faces.push_back(Sorted(S.cells[3 * c], S.cells[3 * c + 1], S.cells[3 * c + 2]));
  } else {
    /* every tet's four faces to the directory rank of their least vertex, where a face two tets
       share arrives twice and a boundary face once */
    static const int F[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    std::vector<MSimSelfTri> all;
    for (size_t c = 0; c < nc; c++)
      for (int f = 0; f < 4; f++) {
        const PetscInt *v = &S.cells[4 * c];
        all.push_back(Sorted(v[F[f][0]], v[F[f][1]], v[F[f][2]]));
        dest.push_back(S.dir.Owner(all.back()[0]));
      }
    PetscCall(MSimExchange(comm, dest, std::move(all), recv));
    std::sort(recv.begin(), recv.end());
    for (size_t k = 0; k < recv.size();) {
      size_t e = k;
      while (e < recv.size() && recv[e] == recv[k]) e++;
      if (e - k == 1) faces.push_back(recv[k]);
      k = e;
    }
    recv.clear();
  }
  /* each triangle to the directory ranks of its vertices */
  std::vector<MSimSelfTri> send;
  dest.clear();
  for (const MSimSelfTri &f : faces) {
    PetscMPIInt last = -1;
    for (int q = 0; q < 3; q++) {
      const PetscMPIInt r = S.dir.Owner(f[q]);
      if (r == last) continue; /* ascending ids: equal owners are adjacent */
      send.push_back(f);
      dest.push_back(r);
      last = r;
    }
  }
  PetscCall(MSimExchange(comm, dest, std::move(send), recv));
  std::sort(recv.begin(), recv.end());
  recv.erase(std::unique(recv.begin(), recv.end()), recv.end());
  for (const MSimSelfTri &f : recv) tris.insert(tris.end(), f.begin(), f.end());
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A plan from the given triangles: local vertices, triangles, edges, the scatter, positions */
static PetscErrorCode BuildLocal(MSimSelfSurface s, PetscReal t, std::vector<MSimSelfTri> &tris)
{
  MSimSystem            sys = s->sys;
  IS                    is;
  std::vector<long long> e;

  PetscFunctionBeginUser;
  std::sort(tris.begin(), tris.end());
  tris.erase(std::unique(tris.begin(), tris.end()), tris.end());
  s->vid.clear();
  for (const MSimSelfTri &v : tris) s->vid.insert(s->vid.end(), v.begin(), v.end());
  std::sort(s->vid.begin(), s->vid.end());
  s->vid.erase(std::unique(s->vid.begin(), s->vid.end()), s->vid.end());
  auto local = [&](PetscInt id) { return (PetscInt)(std::lower_bound(s->vid.begin(), s->vid.end(), id) - s->vid.begin()); };
  s->tri.resize(3 * tris.size());
  for (size_t k = 0; k < tris.size(); k++) {
    const MSimSelfTri &v = tris[k];
    for (int c = 0; c < 3; c++) s->tri[3 * k + c] = local(v[c]);
    for (int c = 0; c < 3; c++) {
      const PetscInt p = s->tri[3 * k + c], q = s->tri[3 * k + (c + 1) % 3];
      e.push_back((long long)PetscMin(p, q) * (long long)s->vid.size() + PetscMax(p, q));
    }
  }
  std::sort(e.begin(), e.end());
  e.erase(std::unique(e.begin(), e.end()), e.end());
  s->edge.resize(2 * e.size());
  for (size_t k = 0; k < e.size(); k++) {
    s->edge[2 * k]     = (PetscInt)(e[k] / (long long)s->vid.size());
    s->edge[2 * k + 1] = (PetscInt)(e[k] % (long long)s->vid.size());
  }
  PetscCall(MSimDestroy(&s->scatter, &s->xscatter, &s->xl, &s->gl));
  const PetscInt n = (PetscInt)s->vid.size();
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, 3 * n, &s->xl));
  PetscCall(VecDuplicate(s->xl, &s->gl));
  PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, n, s->vid.data(), PETSC_COPY_VALUES, &is));
  PetscCall(VecScatterCreate(sys->natural, is, s->xl, NULL, &s->scatter));
  PetscCall(ISDestroy(&is));
  {
    const PetscScalar *g;
    PetscCall(VecScatterBegin(s->scatter, s->gnumnat, s->xl, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(s->scatter, s->gnumnat, s->xl, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecGetArrayRead(s->xl, &g));
    s->gnum.resize(n);
    for (PetscInt k = 0; k < n; k++) s->gnum[k] = (PetscInt)std::lround(PetscRealPart(g[3 * k]));
    PetscCall(VecRestoreArrayRead(s->xl, &g));
  }
  /* queries scatter straight from the state Vec into the free vertices' slots; the fixed ones
     follow b(t), from b0 */
  {
    std::vector<PetscInt> from, to;
    IS                    isf, ist;
    for (PetscInt k = 0; k < n; k++)
      if (s->gnum[k] >= 0) {
        from.push_back(s->gnum[k]);
        to.push_back(k);
      }
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, (PetscInt)from.size(), from.data(), PETSC_COPY_VALUES, &isf));
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, (PetscInt)to.size(), to.data(), PETSC_COPY_VALUES, &ist));
    PetscCall(VecScatterCreate(sys->X0, isf, s->xl, ist, &s->xscatter));
    PetscCall(MSimDestroy(&isf, &ist));
  }
  /* positions: sys->natural holds them (the caller's MSimSystemNaturalPositions at time t) */
  {
    const PetscScalar *x;
    PetscCall(VecScatterBegin(s->scatter, sys->natural, s->xl, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(s->scatter, sys->natural, s->xl, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecGetArrayRead(s->xl, &x));
    s->xplan.assign(x, x + 3 * n);
    PetscCall(VecRestoreArrayRead(s->xl, &x));
  }
  s->fixed.clear();
  s->fixed_b0.clear();
  for (PetscInt k = 0; k < n; k++)
    if (s->gnum[k] < 0) {
      s->fixed.push_back(k);
      for (int c = 0; c < 3; c++) s->fixed_b0.push_back(s->xplan[3 * k + c] - t * sys->fix_velocity[c]);
    }
  s->nplans++;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Re-plan from the positions in sys->natural (the current plan holds the own triangles) */
static PetscErrorCode Replan(MSimSelfSurface s, PetscReal t)
{
  MSimSystem               sys = s->sys;
  std::vector<PetscReal>   boxes(6 * sys->size), x;
  PetscReal                box[6] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL};
  std::vector<MSimSelfTri> tris = s->own_tris, recv, send;
  std::vector<PetscMPIInt> dest;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_SelfHalo, 0, 0, 0, 0));
  {
    const PetscScalar *xa;
    PetscCall(VecScatterBegin(s->scatter, sys->natural, s->xl, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(s->scatter, sys->natural, s->xl, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecGetArrayRead(s->xl, &xa));
    x.assign(xa, xa + 3 * s->vid.size());
    PetscCall(VecRestoreArrayRead(s->xl, &xa));
  }
  auto pos = [&](PetscInt id) { return &x[3 * (std::lower_bound(s->vid.begin(), s->vid.end(), id) - s->vid.begin())]; };
  /* each own triangle's box, and the rank's */
  std::vector<PetscReal> tbox(6 * s->own_tris.size());
  for (size_t k = 0; k < s->own_tris.size(); k++) {
    const MSimSelfTri &v = s->own_tris[k];
    for (int c = 0; c < 3; c++) {
      tbox[6 * k + c]     = PetscMin(pos(v[0])[c], PetscMin(pos(v[1])[c], pos(v[2])[c]));
      tbox[6 * k + 3 + c] = PetscMax(pos(v[0])[c], PetscMax(pos(v[1])[c], pos(v[2])[c]));
      box[c]              = PetscMin(box[c], tbox[6 * k + c]);
      box[3 + c]          = PetscMax(box[3 + c], tbox[6 * k + 3 + c]);
    }
  }
  const PetscReal grow = s->dhat + s->margin;
  for (int c = 0; c < 3; c++) box[c] -= grow, box[3 + c] += grow;
  PetscCallMPI(MPI_Allgather(box, 6, MPIU_REAL, boxes.data(), 6, MPIU_REAL, sys->comm));
  for (PetscMPIInt r = 0; r < sys->size && s->halo; r++) {
    if (r == sys->rank) continue;
    const PetscReal *b = &boxes[6 * r];
    for (size_t k = 0; k < s->own_tris.size(); k++) {
      bool in = true;
      for (int c = 0; c < 3; c++) in = in && tbox[6 * k + c] <= b[3 + c] && tbox[6 * k + 3 + c] >= b[c];
      if (in) {
        dest.push_back(r);
        send.push_back(s->own_tris[k]);
      }
    }
  }
  PetscCall(MSimExchange(sys->comm, dest, send, recv));
  s->nhalo = 0;
  for (const MSimSelfTri &t : recv)
    if (!std::binary_search(s->own_tris.begin(), s->own_tris.end(), t)) s->nhalo++;
  tris.insert(tris.end(), recv.begin(), recv.end());
  PetscCall(BuildLocal(s, t, tris));
  PetscCall(PetscLogEventEnd(MSIM_SelfHalo, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfSurfaceCreate(MSimSystem sys, const MSimSelfContactOptions *o, MSimSelfSurface *out)
{
  MSimSelfSurface s = new _n_MSimSelfSurface();
  Vec             G;
  PetscScalar    *g;

  PetscFunctionBeginUser;
  PetscCall(MSimSelfContactLogRegister());
  s->sys = sys;
  s->halo   = o->halo;
  s->dstart = sys->dir.Start(sys->rank);
  s->dcount = sys->dir.Count(sys->rank);
  if (sys->scene_name == "cloth") { /* the grid's triangles around the block's vertices */
    const PetscInt N = (PetscInt)std::llround(std::sqrt((double)sys->nv));
    PetscCheck(N * N == sys->nv && N >= 2, sys->comm, PETSC_ERR_PLIB, "cloth of %" PetscInt_FMT " vertices is not a square grid", sys->nv);
    for (PetscInt v = s->dstart; v < s->dstart + s->dcount; v++) {
      const PetscInt i = v % N, j = v / N;
      for (PetscInt cj = j - 1; cj <= j; cj++)
        for (PetscInt ci = i - 1; ci <= i; ci++) {
          if (ci < 0 || cj < 0 || ci >= N - 1 || cj >= N - 1) continue;
          for (PetscInt h = 0; h < 2; h++) {
            const MSimSelfTri w = ClothTri(N, 2 * (cj * (N - 1) + ci) + h);
            if (w[0] == v || w[1] == v || w[2] == v) s->own_tris.push_back(w);
          }
        }
    }
  } else { /* a mesh's surface, which the system kept (MSimSelfSurfaceTriangles) */
    PetscCheck(sys->cell_size == 3 || sys->cell_size == 4, sys->comm, PETSC_ERR_SUP, "-msim_self_contact needs a surface: cloth, a triangle mesh or a tet mesh (scene '%s' has none)", sys->scene_name.c_str());
    for (size_t k = 0; k < sys->self_tris.size(); k += 3) s->own_tris.push_back({sys->self_tris[k], sys->self_tris[k + 1], sys->self_tris[k + 2]});
  }
  std::sort(s->own_tris.begin(), s->own_tris.end());
  s->own_tris.erase(std::unique(s->own_tris.begin(), s->own_tris.end()), s->own_tris.end());
  /* global free numbers in natural order (-1: fixed), for the Hessian's rows */
  PetscCall(MSimSystemNaturalSetUp(sys));
  PetscCall(VecDuplicate(sys->natural, &s->gnumnat));
  PetscCall(VecSet(s->gnumnat, -1.0));
  PetscCall(MSimSystemCreateVec(sys, &G));
  PetscCall(VecGetArray(G, &g));
  for (PetscInt k = 0; k < 3 * sys->nown; k++) g[k] = sys->rstart + k / 3;
  PetscCall(VecRestoreArray(G, &g));
  PetscCall(VecScatterBegin(sys->to_natural, G, s->gnumnat, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sys->to_natural, G, s->gnumnat, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecDestroy(&G));
  /* the first plan: the own triangles at the start state, whose shortest edge sets dhat's default */
  PetscCall(MSimSystemNaturalPositions(sys, 0, sys->X0));
  {
    std::vector<MSimSelfTri> tris = s->own_tris;
    PetscCall(BuildLocal(s, 0, tris));
  }
  s->dhat = o->dhat;
  if (s->dhat <= 0) {
    PetscReal shortest = PETSC_MAX_REAL;
    for (size_t k = 0; k < s->edge.size() / 2; k++) {
      const PetscReal *a = &s->xplan[3 * s->edge[2 * k]], *b = &s->xplan[3 * s->edge[2 * k + 1]];
      shortest           = PetscMin(shortest, std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])));
    }
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &shortest, 1, MPIU_REAL, MPIU_MIN, sys->comm));
    /* a flat grid's nearest vertex-disjoint elements are 1/sqrt 2 of an edge apart: a quarter
       leaves the rest state and moderate compression outside the barrier */
    s->dhat = 0.25 * shortest;
  }
  /* the halo's margin: a re-plan every 2 dhat of motion, a halo 4 dhat thick */
  s->margin0 = s->margin = 4 * s->dhat;
  if (sys->size > 1) PetscCall(Replan(s, 0));
  *out = s;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfSurfaceDestroy(MSimSelfSurface *s)
{
  PetscFunctionBeginUser;
  if (!*s) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimDestroy(&(*s)->scatter, &(*s)->xscatter, &(*s)->xl, &(*s)->gl, &(*s)->gnumnat));
  delete *s;
  *s = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* X's local vertices times sign into x; the fixed ones at b(t) (position) or 0 (a direction) */
static PetscErrorCode ScatterLocal(MSimSelfSurface s, Vec X, PetscBool position, PetscReal t, std::vector<PetscReal> &x, PetscReal sign)
{
  const PetscScalar *xa;

  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(s->xscatter, X, s->xl, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(s->xscatter, X, s->xl, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(s->xl, &xa));
  x.resize(3 * s->vid.size());
  for (size_t k = 0; k < x.size(); k++) x[k] = sign * PetscRealPart(xa[k]);
  PetscCall(VecRestoreArrayRead(s->xl, &xa));
  for (size_t f = 0; f < s->fixed.size(); f++)
    for (int c = 0; c < 3; c++) x[3 * s->fixed[f] + c] = position ? s->fixed_b0[3 * f + c] + t * s->sys->fix_velocity[c] : 0.0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfSurfaceGather(MSimSelfSurface s, PetscReal t, Vec X, Vec Y, PetscReal a, std::vector<PetscReal> &x, std::vector<PetscReal> *u)
{
  MSimSystem sys = s->sys;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_SelfHalo, 0, 0, 0, 0));
  PetscCall(ScatterLocal(s, X, PETSC_TRUE, t, x, 1.0));
  if (Y) PetscCall(ScatterLocal(s, Y, PETSC_FALSE, t, *u, -1.0));
  PetscCall(PetscLogEventEnd(MSIM_SelfHalo, 0, 0, 0, 0));
  if (sys->size == 1) PetscFunctionReturn(PETSC_SUCCESS);
  /* the furthest any vertex is (or goes, along the motion) from its planned position */
  PetscReal far[2] = {0, 0};
  for (size_t k = 0; k < s->vid.size(); k++) {
    PetscReal d0 = 0, d1 = 0, m = 0;
    for (int c = 0; c < 3; c++) {
      const PetscReal e = x[3 * k + c] - s->xplan[3 * k + c], f = Y ? a * (*u)[3 * k + c] : 0.0;
      d0 += e * e;
      d1 += (e + f) * (e + f);
      m += f * f;
    }
    far[0] = PetscMax(far[0], std::sqrt(PetscMax(d0, d1)));
    far[1] = PetscMax(far[1], std::sqrt(m));
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, far, 2, MPIU_REAL, MPIU_MAX, sys->comm));
  if (far[0] <= 0.5 * s->margin) PetscFunctionReturn(PETSC_SUCCESS);
  /* re-plan at X with a margin that covers the motion too */
  s->margin = PetscMax(s->margin0, 2.2 * far[1]);
  PetscCall(MSimSystemNaturalPositions(sys, t, X));
  PetscCall(Replan(s, t));
  PetscCall(PetscLogEventBegin(MSIM_SelfHalo, 0, 0, 0, 0));
  PetscCall(ScatterLocal(s, X, PETSC_TRUE, t, x, 1.0));
  if (Y) PetscCall(ScatterLocal(s, Y, PETSC_FALSE, t, *u, -1.0));
  PetscCall(PetscLogEventEnd(MSIM_SelfHalo, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfSurfaceAddGradient(MSimSelfSurface s, const std::vector<PetscReal> &g, Vec G)
{
  PetscScalar *ga;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_SelfHalo, 0, 0, 0, 0));
  PetscCall(VecGetArray(s->gl, &ga));
  for (size_t k = 0; k < g.size(); k++) ga[k] = g[k];
  PetscCall(VecRestoreArray(s->gl, &ga));
  PetscCall(VecScatterBegin(s->xscatter, s->gl, G, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(s->xscatter, s->gl, G, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(PetscLogEventEnd(MSIM_SelfHalo, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
