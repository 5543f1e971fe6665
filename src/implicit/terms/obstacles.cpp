/* Contact with static obstacles as a term of Phi: IPC's log barrier (Li et al. 2020) per free
   vertex and obstacle on their signed distance d,
     E = beta h^2 kappa sum_v m_v b(d_v),   b(d) = -(d - dhat)^2 log(d / dhat) on (0, dhat), 0 beyond,
   C2 at dhat and infinite at d = 0, so every iterate a line search accepts is outside every
   obstacle. Weighted by the vertex masses, so kappa is per unit mass (msim/contact.h's defaults).
   Gradient beta h^2 kappa m b'(d) n; Hessian block beta h^2 kappa m (b'' n n^T + b' D^2 d). b''
   >= 0 on (0, dhat); the curvature term b' D^2 d is negative semidefinite (b' <= 0, and the
   distance to a point, an edge or a convex surface has a PSD Hessian), so the PSD form keeps it
   only as far as the vertex's inertia m I covers it (Hessian_Obstacles; -msim_contact_psd_curvature).
   max_step: the largest alpha for which no owned vertex meets an obstacle (where it is at step.tx)
   along X - alpha Y (exact ray tests times 0.8, IPC's CCD filter; conservative advancement for
   meshes), reduced over ranks; a feasible start never gives 0. clamp: the same test per vertex
   without the reduction, so that the first iterate is cut vertex by vertex (a common alpha froze
   the whole cloth when one vertex reached the ball). PD (-msim_contact_pd_weight): each vertex
   within dhat gets w_v = beta h^2 kappa m b''(d) on the PD matrix's diagonal, computed at the
   first local step of each time step and taken when some vertex's diagonal is off the factored
   one by more than a factor (-msim_contact_pd_refactor, default 4; 0: when the set of such
   vertices changed; A is then refactored, and only then), and the right-hand side w_v x_v minus
   the barrier's gradient, so each global step is X - A^-1 g(X); the step is then shortened by max_step where it would cross
   an obstacle and halved until Phi does not rise (pd_steps.cpp). A constant factor (contact in
   the right-hand side only, -msim_contact_pd_weight 0, or as a projection in the local step) was
   measured against this in runs/contact/README.md: none both converges and keeps the cloth out.
   The contact force, -kappa m b'(d) n, is computed for the frames and -msim_monitor_csv at each
   step's result by src/contact/contact_force.cpp with the same loop and clamp. */
#include <msim/implicit.h>
#include <msim/contact.h>
#include <climits>
#include <cstdint>
#include <cstring>
#if defined(__AVX__)
  #include <immintrin.h>
#endif
#include <vector>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: max_step from the X whose distances the local step kept */

static PetscErrorCode Contact(MSimImplicitTerm term, MSimContact *ct)
{
  PetscFunctionBeginUser;
  PetscCall(MSimContactGetForStep(term->imp->sys, term->imp->step.h2, ct));
  PetscFunctionReturn(PETSC_SUCCESS);
}

typedef struct {
  std::vector<PetscReal> w;       /* per owned vertex: the weights in A */
  std::vector<PetscInt>  wset;    /* the vertices whose w is not zero (WeightedSet), in order */
  std::vector<PetscReal> next;    /* the last computed, taken into w when A is next assembled */
  PetscBool              pending; /* next holds weights not yet taken */
  PetscReal              t = PETSC_MIN_REAL; /* the time step (its start) they were computed in */
  Vec                    diag = NULL; /* A's diagonal, for -msim_contact_pd_refactor's test */
  PetscObjectId          diag_id    = 0; /* of A at the state it was read at: read again only where A changed */
  PetscObjectState       diag_state = 0; /* (MatGetDiagonal searched every row: 0.4 M instructions a PD-10 step of the 101 x 101 drape) */
  /* a restart: w holds the checkpoint's weights (those the run's factor held), A was assembled
     without them at set-up; `restored` makes the reweight that HistoryLoaded_Obstacles calls
     assemble them as they are, so that A is the run's before the first step */
  Vec                    hist     = NULL;
  PetscBool              restored = PETSC_FALSE;
  /* set by the Hessian (-msim_contact_pc_pd_weight) around its reweight: the weights of each
     Jacobian, where PD's own steps (also PD as another SNES's preconditioner) take them once a
     time step */
  PetscBool              at_jacobian = PETSC_FALSE;
  /* a global step was cut at a vertex whose factored weight is too low for its distance there
     (BlockerStale): the next local step takes the weights again, within the time step */
  PetscBool              stale = PETSC_FALSE;
  /* per owned vertex, where its distances were last computed (anchor, 3 coordinates) and its
     least distance to the obstacles there less dhat and a roundoff margin (ex; <= 0: none). The
     distance is 1-Lipschitz in x, so at any x with |x - anchor| <= ex every obstacle is beyond
     dhat: the barrier, its gradient, Hessian and PD weight are zero there and the queries are
     skipped (Far), the same sums as with them; max_step takes ex + dhat - |x - anchor| as the
     vertex's distance. Valid for one tx where obstacles move (anchors_tx). */
  std::vector<PetscReal> anchor, ex;
  PetscReal              anchors_tx = PETSC_MIN_REAL;
  /* each owned vertex's least distance to the obstacles at the last PD local step's X (its id and
     state), dhat for a vertex skipped there (Far: a lower bound): max_step from that X skips the
     vertices whose move cannot reach an obstacle without the anchors' square root */
  std::vector<PetscReal> dmin;
  std::vector<unsigned char> move; /* max_step's work: the vertices whose move may reach an obstacle */
  std::vector<PetscReal>     work; /* and the anchors' distances */
  std::vector<unsigned char> far;  /* NearLoop's work: FarFlags */
  /* FarFlags between its full passes, along one iterate X (PD's, whose global steps overwrite it
     in place and say by how much each vertex moved: MSimImplicitPDMoveBound): at a full pass at X
     the vertices that are not far or whose margin ex - |x - anchor| is at most `reach` are listed
     (nearlist, inlist), the least margin of the others kept (mout). While X's moves since (summed
     in `moved`) are known and twice their sum stays below mout, the others are still within their
     anchors' balls (the distance to the anchor is 1-Lipschitz) and only the listed vertices are
     tested: the same flags. A pass at another X (x_n's Phi, a line search's trial point) tests
     every vertex and lists those it queries (their anchors move), so that X's list stays whole.
     reach: 3 x the moves the last full pass's list served, so that a time step's PD iterations fit.
     Where X changes without saying by how much (L-BFGS's, Newton's iterates) a list that served no
     pass is not made again until a move is known (listed false: the plain test) */
  std::vector<PetscInt>      nearlist;
  std::vector<unsigned char> inlist;
  std::vector<PetscReal>     rwork;
  PetscReal                  mout = 0, moved = 0, reach = 0;
  PetscInt                   served = 0; /* passes the list served since it was made */
  PetscBool                  flags_valid = PETSC_FALSE, listed = PETSC_FALSE;
  PetscObjectId              flags_id    = 0; /* X, at the state of its last flags */
  PetscObjectState           flags_state = 0;
  PetscObjectId          dmin_id    = 0;
  PetscObjectState       dmin_state = 0;
  PetscReal              dmin_tx    = 0; /* where the obstacles were */
  /* each owned vertex's input id: max_step's blocker among ranks whose blockers cut the step
     alike, and its name in -info (InputIds) */
  std::vector<PetscInt>  input_id;
  PetscBool              have_input_id = PETSC_FALSE;
} PDWeights;

/* w's vertices with a weight, after w changed: PD's right-hand side adds w_v x_v for those alone
   (the loop over every vertex, most of them weightless, was 1.5 M instructions of a 123 M PD-10
   step of the 101 x 101 drape, runs/contact/README.md). w_v >= 0, and r + 0 x is r but for r =
   -0, so the sums are those of the loop over all vertices. */
static void WeightedSet(PDWeights *pw)
{
  pw->wset.clear();
  for (size_t v = 0; v < pw->w.size(); v++)
    if (pw->w[v] != 0) pw->wset.push_back((PetscInt)v);
}

/* the anchors, reset (every vertex queried) at a new size or, where obstacles move, a new tx */
static PDWeights *Anchors(MSimImplicitTerm term, MSimContact ct)
{
  PDWeights     *pw   = (PDWeights *)term->data;
  const PetscInt nown = term->imp->sys->nown;
  if ((PetscInt)pw->ex.size() != nown || (ct->moving && pw->anchors_tx != term->imp->step.tx)) {
    pw->anchor.assign(3 * nown, 0.0);
    pw->ex.assign(nown, -ct->dhat); /* none: below every skip test (e > 0, e > -dhat, lb = e + dhat - r > 0), and finite, so the passes that square it never overflow (-fp_trap) */
    pw->anchors_tx  = term->imp->step.tx;
    pw->flags_valid = PETSC_FALSE;
  }
  return pw;
}

/* r = sqrt(r), 4 at a time with AVX (the scalar sqrt's errno branch keeps the compiler's
   vectorizer out; each correctly rounded, so the same numbers); r: n + 4 entries */
static void AnchorRoots(PetscInt n, PetscReal *__restrict r)
{
  PetscInt v = 0;
#if defined(__AVX__)
  for (; v + 4 <= n; v += 4) _mm256_storeu_pd(r + v, _mm256_sqrt_pd(_mm256_loadu_pd(r + v)));
#endif
  for (; v < n; v++) r[v] = PetscSqrtReal(r[v]);
}

static inline PetscReal AnchorDistance2(const PetscReal *__restrict an, const PetscScalar *__restrict x, PetscInt v)
{
  const PetscReal dx = x[3 * v] - an[3 * v], dy = x[3 * v + 1] - an[3 * v + 1], dz = x[3 * v + 2] - an[3 * v + 2];
  return dx * dx + dy * dy + dz * dz;
}

/* f(v, o, d, n, H) for every owned vertex v and obstacle o within dhat (d may be <= 0), as
   msim/private/contactimpl.h's MSimContactForEachNear (the output's contact force uses that one:
   the same queries, the same order), except that a vertex far from every obstacle (FarFlags) is
   skipped without a query; each queried vertex's anchor is set to x. With dmin: each vertex's least
   distance (dhat where skipped) */
/* the first vertex v' >= v below n whose flag (0 or 1) is want, n if none: the passes below visit
   few of the owned vertices, so eight flags are read at once where a block of eight starts and
   skipped together when all are the other way (the flag arrays are padded to n + 8 with it) */
static inline PetscInt NextFlagged(const unsigned char *flags, PetscInt v, PetscInt n, unsigned char want)
{
  const std::uint64_t other = want ? 0 : 0x0101010101010101ULL;
  for (; v < n; v++) {
    if (!(v & 7)) {
      std::uint64_t eight;
      std::memcpy(&eight, flags + v, sizeof eight);
      if (eight == other) {
        v += 7;
        continue;
      }
    }
    if (flags[v] == want) return v;
  }
  return n;
}

/* min(r): 4 at a time with AVX (the compiler does not vectorize a floating-point min); r not NaN */
static PetscReal LeastOf(PetscInt n, const PetscReal *r)
{
  PetscReal m = PETSC_MAX_REAL;
  PetscInt  v = 0;
#if defined(__AVX__)
  __m256d mm = _mm256_set1_pd(PETSC_MAX_REAL);
  for (; v + 4 <= n; v += 4) mm = _mm256_min_pd(mm, _mm256_loadu_pd(r + v));
  PetscReal lanes[4];
  _mm256_storeu_pd(lanes, mm);
  for (int l = 0; l < 4; l++) m = PetscMin(m, lanes[l]);
#endif
  for (; v < n; v++) m = PetscMin(m, r[v]);
  return m;
}

/* x's vertices within ex of their anchors, beyond dhat of every obstacle (far[v] = 1); the loop
   then visits the others alone, eight flags at a time. A test per vertex at each of the 11 local
   steps of a PD-10 step was 1.9 M instructions of the 101 x 101 drape on the ball (runs/contact/
   README.md): along PD's iterate only the listed vertices are tested (PDWeights' nearlist).
   moved: a bound on every vertex's move since X's last flags (FlagsMove); -1: X's list starts
   afresh (none known); -2: x is another iterate */
static void FarFlags(PDWeights *pw, PetscReal dhat, PetscReal moved, PetscInt nown, const PetscScalar *__restrict x, unsigned char *__restrict far)
{
  const PetscReal *__restrict an = pw->anchor.data(), *__restrict ex = pw->ex.data();
  if (pw->listed && moved >= 0 && 2 * (pw->moved + moved) < pw->mout) {
    pw->moved += moved;
    pw->served++;
    for (const PetscInt v : pw->nearlist) far[v] = (unsigned char)((ex[v] > 0) & (AnchorDistance2(an, x, v) <= ex[v] * ex[v]));
    return;
  }
  if (moved == -2 || (moved == -1 && pw->flags_valid && !pw->served)) {
    for (PetscInt v = 0; v < nown; v++) far[v] = (unsigned char)((ex[v] > 0) & (AnchorDistance2(an, x, v) <= ex[v] * ex[v]));
    if (moved == -1) pw->listed = PETSC_FALSE; /* X's flags, no list */
    if (!pw->listed) return;
    /* the vertices queried here (their anchors move) join X's list; past half of them it starts afresh */
    for (PetscInt v = NextFlagged(far, 0, nown, 0); v < nown; v = NextFlagged(far, v + 1, nown, 0))
      if (!pw->inlist[v]) {
        pw->inlist[v] = 1;
        pw->nearlist.push_back(v);
      }
    if (2 * (PetscInt)pw->nearlist.size() > nown) pw->flags_valid = PETSC_FALSE;
    return;
  }
  if (pw->listed && pw->moved + PetscMax(moved, 0) > 0) pw->reach = 3 * (pw->moved + PetscMax(moved, 0));
  pw->rwork.resize(nown + 4);
  pw->inlist.resize(nown + 8, 0); /* the padding: not listed (NextFlagged) */
  PetscReal *__restrict r = pw->rwork.data();
  unsigned char *__restrict in = pw->inlist.data();
  for (PetscInt v = 0; v < nown; v++) {
    r[v]   = AnchorDistance2(an, x, v);
    far[v] = (unsigned char)((ex[v] > 0) & (r[v] <= ex[v] * ex[v]));
  }
  AnchorRoots(nown, r);
  /* reach's floor: the margins are good to a few ulps of the coordinates, far below it. In
     passes the compiler vectorizes: the listed ones, the others' margins (PETSC_MAX_REAL for the
     listed), their least; then the list */
  const PetscReal reach = PetscMax(pw->reach, PETSC_SQRT_MACHINE_EPSILON * dhat);
  for (PetscInt v = 0; v < nown; v++) {
    const PetscReal m = ex[v] - r[v];
    in[v]             = (unsigned char)(!far[v] | !(m > reach));
    r[v]              = in[v] ? PETSC_MAX_REAL : m;
  }
  pw->nearlist.clear();
  for (PetscInt v = NextFlagged(in, 0, nown, 1); v < nown; v = NextFlagged(in, v + 1, nown, 1)) pw->nearlist.push_back(v);
  pw->mout        = LeastOf(nown, r);
  pw->moved       = 0;
  pw->served      = 0;
  pw->flags_valid = PETSC_TRUE;
  pw->listed      = PETSC_TRUE;
}

/* FarFlags' moved for X (0: X unchanged since its last flags) */
static PetscErrorCode FlagsMove(PDWeights *pw, Vec X, PetscReal *moved)
{
  PetscObjectId    id;
  PetscObjectState state, from;
  PetscReal        b;
  PetscBool        has;

  PetscFunctionBeginUser;
  *moved = -1;
  PetscCall(PetscObjectGetId((PetscObject)X, &id));
  PetscCall(PetscObjectStateGet((PetscObject)X, &state));
  if (!pw->flags_valid) PetscFunctionReturn(PETSC_SUCCESS);
  if (id != pw->flags_id) *moved = -2;
  else if (state == pw->flags_state) *moved = 0;
  else {
    PetscCall(MSimImplicitPDMoveBound(X, &from, &b, &has));
    if (has && from == pw->flags_state && b >= 0) *moved = b; /* b >= 0: not NaN */
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* after NearLoop at X with FarFlags' moved: X's flags, where they were X's list's */
static PetscErrorCode FlagsAt(PDWeights *pw, Vec X, PetscReal moved)
{
  PetscFunctionBeginUser;
  if (moved == -2) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscObjectGetId((PetscObject)X, &pw->flags_id));
  PetscCall(PetscObjectStateGet((PetscObject)X, &pw->flags_state));
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <class F>
static void NearLoop(PDWeights *pw, MSimContact ct, PetscReal moved, PetscInt nown, const PetscScalar *x, PetscReal t, PetscBool hessian, PetscReal *dmins, F &&f)
{
  pw->far.resize(nown + 8, 1); /* the padding: far */
  unsigned char *far = pw->far.data();
  FarFlags(pw, ct->dhat, moved, nown, x, far);
  if (dmins)
    for (PetscInt v = 0; v < nown; v++) dmins[v] = ct->dhat; /* the queried ones' below */
  /* each queried vertex's anchor and margin (MSimContactAnchorVertex; its mesh bound beyond the
     band, on the 101 x 101 drape on the 20,480-triangle ball: the mesh's calls 67,000 -> 22,000 a
     step, the step -6.6% in instructions, the same sums: runs/contact/README.md, h2's
     eighth-session section) */
  for (PetscInt v = NextFlagged(far, 0, nown, 0); v < nown; v = NextFlagged(far, v + 1, nown, 0))
    pw->ex[v] = MSimContactAnchorVertex(ct, v, x + 3 * v, t, hessian, pw->anchor.data() + 3 * v, dmins ? dmins + v : NULL, [&](const MSimObstacle &o, PetscReal d, const PetscReal *n, const PetscReal *H) { f(v, o, d, n, H); });
}

/* f(v, d, n, H, m) for every owned vertex v and obstacle within dhat (d may be <= 0), the
   obstacles where they are when the scheme's unknown is (step.tx: moving obstacles) */
template <class F>
static PetscErrorCode ForEachNear(MSimImplicitTerm term, MSimContact ct, Vec X, PetscBool hessian, F &&f)
{
  MSimSystem         sys = term->imp->sys;
  PDWeights         *pw  = Anchors(term, ct);
  const PetscScalar *x, *m;
  PetscReal          moved;

  PetscFunctionBeginUser;
  PetscCall(FlagsMove(pw, X, &moved));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  NearLoop(pw, ct, moved, sys->nown, x, term->imp->step.tx, hessian, NULL, [&](PetscInt v, const MSimObstacle &, PetscReal d, const PetscReal *n, const PetscReal *H) { f(v, d, n, H, PetscRealPart(m[3 * v])); });
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(FlagsAt(pw, X, moved));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode LocalEnergy(MSimImplicitTerm term, MSimContact ct, Vec X, PetscReal *e)
{
  const PetscReal w = term->imp->step.h2 * ct->kappa;

  PetscFunctionBeginUser;
  PetscCall(ForEachNear(term, ct, X, PETSC_FALSE, [&](PetscInt, PetscReal d, const PetscReal *, const PetscReal *, PetscReal m) {
    PetscReal b, db, d2b;
    if (d <= 0) {
      *e = PETSC_INFINITY; /* outside the barrier's domain: no line search accepts it */
      return;
    }
    MSimBarrier(d, ct->dhat, &b, &db, &d2b);
    *e += w * m * b;
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Energy_Obstacles(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  MSimContact ct;
  PetscReal   local = 0;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(LocalEnergy(term, ct, X, &local));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, term->imp->sys->comm));
  *e += local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G (or a PD right-hand side, with sign -1) += sign h2 kappa m b'(d) n (the output's contact
   force, src/contact/contact_force.cpp, is this over h2, at the step's result) */
static PetscErrorCode AddGradient(MSimImplicitTerm term, MSimContact ct, Vec X, Vec G, PetscReal sign)
{
  const PetscReal w = term->imp->step.h2 * ct->kappa;

  return MSimContactAddToVec(G, [&](PetscScalar *g) {
    return ForEachNear(term, ct, X, PETSC_FALSE, [&](PetscInt v, PetscReal d, const PetscReal *n, const PetscReal *, PetscReal m) {
      PetscReal b, db, d2b;
      MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &b, &db, &d2b);
      for (int c = 0; c < 3; c++) g[3 * v + c] += sign * w * m * db * n[c];
    });
  });
}

static PetscErrorCode Gradient_Obstacles(MSimImplicitTerm term, Vec X, Vec G)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (ct) PetscCall(AddGradient(term, ct, X, G, 1.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* one 3 x 3 block per owned vertex near an obstacle, added into the assembled J */
static PetscErrorCode Hessian_Obstacles(MSimImplicitTerm term, Vec X, PetscBool psd, Mat J)
{
  MSimSystem     sys = term->imp->sys;
  MSimContact    ct;
  PetscErrorCode ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  /* Newton-CG on the PD factor: without the barrier's stiffness the factor is a poor preconditioner
     of the contact vertices' stiff blocks (20 unconverged iterations a step on the ball); with it,
     refactored by PD's rule (runs/contact/README.md) */
  if (ct->pc_pd_weight && ct->pd_weight && term->imp->pd_pc) {
    PDWeights *pw    = (PDWeights *)term->data;
    pw->at_jacobian = PETSC_TRUE; /* past the once-per-step rule: this Jacobian's weights */
    PetscCall(MSimImplicitPDReweight(term->imp, X));
    pw->at_jacobian = PETSC_FALSE;
  }
  const PetscReal w = term->imp->step.h2 * ct->kappa;
  PetscCall(ForEachNear(term, ct, X, PETSC_TRUE, [&](PetscInt v, PetscReal d, const PetscReal *n, const PetscReal *H, PetscReal m) {
    PetscReal   b, db, d2b;
    PetscScalar blk[9];
    PetscInt    idx[3];
    MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &b, &db, &d2b);
    /* the curvature term w m b' D^2 d is negative semidefinite (b' <= 0, D^2 d PSD: the distance
       to a point, an edge or a convex surface curves away); with the inertia m I that every
       vertex's row of Phi's Hessian holds, m I + w m b' D^2 d stays PD while w |b'| lambda_max(D^2 d)
       < 1. The PSD form keeps it scaled so that this sum stays >= m/2 I (lambda_max bounded by the
       trace), the vertex's block then PD with the springs' PSD blocks added: the tangential
       softening that the exact Hessian has, where a projection of the barrier's block alone
       drops it. */
    PetscReal curv = db;
    if (psd) {
      const PetscReal tr = H[0] + H[4] + H[8];
      curv               = ct->psd_curvature && tr > 0 ? -PetscMin(-db, 0.5 / (w * tr)) : 0.0;
    }
    for (int a = 0; a < 3; a++) {
      idx[a] = 3 * (sys->rstart + v) + a;
      for (int c = 0; c < 3; c++) blk[3 * a + c] = w * m * (d2b * n[a] * n[c] + curv * H[3 * a + c]);
    }
    if (!ierr) ierr = MatSetValues(J, 3, idx, 3, idx, blk, ADD_VALUES);
  }));
  PetscCall(ierr);
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD's weights: w_v = beta h^2 kappa m_v sum_o b''(d_vo) on the diagonal of A for each vertex
   within dhat of an obstacle at the first local step of a time step, taken when
   -msim_contact_pd_refactor's test says the factored ones are too far off (and only then, so the
   factor is kept while they are close); zero elsewhere. Whether the set changed is decided over
   all ranks (pd_steps.cpp reduces the flag), so every rank takes its new weights when A is
   reassembled, not only the ranks whose own vertices changed: a rank that kept its old weights
   while another's set changed gave A, and so a fixed-iteration PD step, that depended on the
   partition (examples/bunny_drop.opts: 1 and 2 ranks 1.2 mm apart one step after landing). */

static PetscErrorCode PDReweight_Obstacles(MSimImplicitTerm term, Vec X, PetscBool *changed)
{
  PDWeights  *pw = (PDWeights *)term->data;
  MSimSystem  sys = term->imp->sys;
  MSimContact ct;

  PetscFunctionBeginUser;
  if (pw->restored) { /* the checkpoint's weights into A (pending is false: PDMatrix_Obstacles takes w), X unused */
    pw->restored = PETSC_FALSE;
    *changed     = PETSC_TRUE;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(Contact(term, &ct));
  if (!ct || !ct->pd_weight) PetscFunctionReturn(PETSC_SUCCESS);
  /* once per time step, at its first local step (the same on every rank): the weights only speed
     the iteration up (the right-hand side makes each global step X - A^-1 g(X) whatever they
     are), and a refactorization costs about 5 PD iterations of the 101 x 101 cloth in CPU time
     (runs/contact/README.md). Newton's preconditioner (-msim_contact_pc_pd_weight) takes them at
     every Jacobian instead: taken once per step, at the first iterate, they left CG's directions
     so poor that the 101 x 101 drape diverged at step 20 */
  if (pw->t == term->imp->step.t && !pw->at_jacobian && !pw->stale) PetscFunctionReturn(PETSC_SUCCESS);
  pw->t     = term->imp->step.t;
  pw->stale = PETSC_FALSE;
  std::vector<PetscReal> &w = pw->next; /* its storage kept from step to step (a vector made and zeroed per step was 0.1 M instructions) */
  w.assign(sys->nown, 0.0);
  const PetscReal        h2k = term->imp->step.h2 * ct->kappa;
  PetscCall(ForEachNear(term, ct, X, PETSC_FALSE, [&](PetscInt v, PetscReal d, const PetscReal *, const PetscReal *, PetscReal m) {
    PetscReal b, db, d2b;
    MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &b, &db, &d2b);
    w[v] += h2k * m * d2b;
  }));
  PetscBool same = (PetscBool)(pw->w.size() == w.size());
  if (ct->pd_refactor > 0 && same && term->imp->A) {
    /* lazy (-msim_contact_pd_refactor r): the factor's weights only speed the iteration up, and a
       vertex whose factored diagonal A_vv is within a factor r of the wanted one converges nearly
       as fast (too low a weight overshoots by up to the ratio, too high a one slows the vertex by
       it): refactor when some vertex within dhat (wanted or factored) is further off. A fraction
       of such vertices allowed off instead never refactored: the few vertices nearest the ball,
       whose b'' dwarfs the springs' diagonal, are the ones that need it (runs/contact/README.md).
       The two sides differ for PD's own steps: a factored weight too low lets the vertex's global
       step overshoot into the barrier, which max_step's common alpha then cuts for the whole
       cloth; one too high only slows that vertex as it lifts off, so it is kept up to r^2. A
       draped cloth's load moves from vertex to vertex as it slides (on a mesh obstacle it rests on
       the facets' edges: each pressed vertex, d 10-100 x smaller for a few steps, b'' ~ 1/d^2,
       refactored once as it was pressed and again as it lifted): 101 x 101 drape, 24 steps, mesh
       ball 17 -> 10 factorizations, analytic ball 7 -> 4 (runs/contact/README.md, the mesh
       obstacle, seventh session). Newton's preconditioner keeps the symmetric rule: its CG
       directions on the ball need the weights current (a 150-step ntr drape on the ball ended
       still sliding with the r^2 side), and also refactors where the set of vertices within dhat
       changed: on a cloth the springs' h^2 sum k dwarfs the barrier's weight in A's diagonal (on
       the 21 x 21 drape on the ball, 30 steps, no vertex's wanted diagonal came within a factor
       1.33 of the 4 that refactors), so the diagonals' test alone never let a weight into the
       factor and -msim_contact_pc_pd_weight changed nothing, bit for bit, while CG gains from the
       weights (60,402 -> 50,953 iterations there, 37 factorizations; testing each weight against
       its factored one instead refactored 51 times for 52,640; 41 x 41: 157,006 -> 151,860, 96
       factorizations of 1,681 rows). */
    const PetscReal    r = ct->pd_refactor, rhigh = pw->at_jacobian ? r : r * r;
    const PetscScalar *a;
    PetscBool          off = PETSC_FALSE;
    PetscObjectId    aid;
    PetscObjectState astate;
    PetscCall(PetscObjectGetId((PetscObject)term->imp->A, &aid));
    PetscCall(PetscObjectStateGet((PetscObject)term->imp->A, &astate));
    if (!pw->diag) PetscCall(MatCreateVecs(term->imp->A, &pw->diag, NULL));
    if (aid != pw->diag_id || astate != pw->diag_state) { /* A changed since its diagonal was read */
      PetscCall(MatGetDiagonal(term->imp->A, pw->diag));
      pw->diag_id    = aid;
      pw->diag_state = astate;
    }
    /* PD's own steps refactor selectively: at a refactorization a vertex within sqrt(r) of its
       wanted weight (either side) keeps its factored one, so few diagonal entries change (msimllt
       then corrects its factor by a low-rank update instead of refactoring). Keeping every vertex
       within the trigger's band instead (r, r^2) left weights up to 16 x too high on vertices that
       had lifted off: PD-10's steps on the 101 x 101 drape ended 4 x less converged (mean |g| 4.3e-3
       against 1.1e-3) and the 21 x 21 table's rest was off (runs/contact/README.md, eighth
       session). The decision per vertex reads only that vertex's numbers, so the weights do not
       depend on the partition; a rank none of whose vertices is off keeps its weights when
       another refactors. */
    const PetscBool   selective = (PetscBool)(!pw->at_jacobian && ct->pd_refactor_selective > 0);
    const PetscReal   rkeep     = PetscSqrtReal(r);
    std::vector<char> keep;
    PetscInt          nrefresh = 0; /* vertices off by more than sqrt(r) whose weight changes */
    if (selective) keep.assign(w.size(), 0);
    PetscCall(VecGetArrayRead(pw->diag, &a));
    for (size_t v = 0; (selective || !off) && v < w.size(); v++) {
      const PetscReal have = PetscRealPart(a[v]), want = have - pw->w[v] + w[v];
      if (want > r * have || have > rhigh * want || (pw->at_jacobian && (w[v] > 0) != (pw->w[v] > 0))) off = PETSC_TRUE;
      if (!selective) continue;
      keep[v] = !(want > rkeep * have || have > rkeep * want);
      if (!keep[v] && w[v] != pw->w[v]) nrefresh++;
    }
    PetscCall(VecRestoreArrayRead(pw->diag, &a));
    if (selective) {
      /* selective only while few vertices change (counted over all ranks, so the weights do not
         depend on the partition): past msimllt's update rank it refactors, and a refactorization
         of many rows costs what one of all does (the root supernodes are always reached), so
         every vertex may as well take its weight. (On the mesh ball the landing converges worse
         with the stale weights even so: 4-96 vertices refresh an event there; K = 0 refreshes
         all, runs/contact/README.md) */
      PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &nrefresh, 1, MPIU_INT, MPI_SUM, sys->comm));
      if (nrefresh <= ct->pd_refactor_selective)
        for (size_t v = 0; v < w.size(); v++)
          if (keep[v]) w[v] = pw->w[v];
    }
    if (off) *changed = PETSC_TRUE; /* reduced over the ranks by the caller */
  } else {
    for (size_t v = 0; same && v < w.size(); v++) same = (PetscBool)((w[v] > 0) == (pw->w[v] > 0));
    if (!same) *changed = PETSC_TRUE;
  }
  pw->pending = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode PDMatrix_Obstacles(MSimImplicitTerm term, Mat A)
{
  PDWeights *pw  = (PDWeights *)term->data;
  MSimSystem sys = term->imp->sys;

  PetscFunctionBeginUser;
  if (pw->pending) { /* on every rank at once: A is assembled collectively */
    pw->w.swap(pw->next);
    pw->pending = PETSC_FALSE;
    WeightedSet(pw);
  }
  pw->restored = PETSC_FALSE; /* A holds w from here on, restored or not */
  for (size_t v = 0; v < pw->w.size(); v++)
    if (pw->w[v] > 0) PetscCall(MatSetValue(A, sys->rstart + (PetscInt)v, sys->rstart + (PetscInt)v, pw->w[v], ADD_VALUES));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* G += sign (the barrier's gradient at X) and, with e, *e += its energy, in one pass over the
   vertices (each distance once): the same terms in the same order as AddGradient's and
   LocalEnergy's; the far vertices skipped (their anchors then serve max_step from this X too).
   Plus: PD + L-BFGS's fused gradient (sign +1), else PD's right-hand side (-1). */
template <bool Plus>
static PetscErrorCode LocalPass(MSimImplicitTerm term, MSimContact ct, Vec X, Vec G, PetscReal *e)
{
  const PetscReal    w = term->imp->step.h2 * ct->kappa;
  const PetscScalar *x, *ms;

  PDWeights         *pw = Anchors(term, ct);
  PetscReal          moved;

  PetscFunctionBeginUser;
  pw->dmin.resize(term->imp->sys->nown);
  PetscCall(FlagsMove(pw, X, &moved));
  PetscCall(MSimContactAddToVec(G, [&](PetscScalar *g) {
    PetscFunctionBeginUser;
    PetscCall(VecGetArrayRead(X, &x));
    PetscCall(VecGetArrayRead(term->imp->sys->mass, &ms));
    NearLoop(pw, ct, moved, term->imp->sys->nown, x, term->imp->step.tx, PETSC_FALSE, pw->dmin.data(), [&](PetscInt v, const MSimObstacle &, PetscReal d, const PetscReal *n, const PetscReal *) {
      PetscReal       b, db, d2b;
      const PetscReal m  = PetscRealPart(ms[3 * v]);
      const PetscReal dc = PetscMax(d, PETSC_SMALL * ct->dhat);
      MSimBarrier(dc, ct->dhat, &b, &db, &d2b);
      if (Plus)
        for (int c = 0; c < 3; c++) g[3 * v + c] += w * m * db * n[c];
      else
        for (int c = 0; c < 3; c++) g[3 * v + c] -= w * m * db * n[c];
      if (!e) return;
      if (d <= 0) *e = PETSC_INFINITY;
      else {
        if (dc != d) MSimBarrier(d, ct->dhat, &b, &db, &d2b);
        *e += w * m * b;
      }
    });
    PetscCall(VecRestoreArrayRead(term->imp->sys->mass, &ms));
    PetscCall(VecRestoreArrayRead(X, &x));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCall(FlagsAt(pw, X, moved));
  PetscCall(PetscObjectGetId((PetscObject)X, &pw->dmin_id));
  PetscCall(PetscObjectStateGet((PetscObject)X, &pw->dmin_state));
  pw->dmin_tx = term->imp->step.tx;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD: A x = rhs with A holding w_v: rhs += w_v x_v - the barrier's gradient at X, so that A X -
   rhs is Phi's gradient at X and the global step is X - A^-1 g(X) (with w = 0: the force alone,
   lagged) */
static PetscErrorCode PDRHS_Obstacles(MSimImplicitTerm term, Vec X, Vec rhs, PetscReal *e)
{
  PDWeights  *pw = (PDWeights *)term->data;
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(LocalPass<false>(term, ct, X, rhs, e));
  if (!pw->wset.empty()) {
    const PetscScalar *x;
    PetscScalar       *r;
    PetscCall(VecGetArrayRead(X, &x));
    PetscCall(VecGetArray(rhs, &r));
    for (const PetscInt v : pw->wset)
      for (int c = 0; c < 3; c++) r[3 * v + c] += pw->w[v] * x[3 * v + c];
    PetscCall(VecRestoreArray(rhs, &r));
    PetscCall(VecRestoreArrayRead(X, &x));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD + L-BFGS's fused gradient (pd_gradient.cpp): the term's part of A X - rhs(X) is its weights'
   w_v x_v less rhs's w_v x_v - grad B(X), that is grad B(X) alone: no product with A */
static PetscErrorCode PDGradient_Obstacles(MSimImplicitTerm term, Vec X, Vec G, PetscReal *e)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (ct) PetscCall(LocalPass<true>(term, ct, X, G, e));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD's bound on Phi along the global step (pd_steps.cpp, PDBound): the right-hand side holds
   the barrier's model at X0, its gradient and the factored weights w_v, so the step minimizes the
   springs' projections plus B(X0) + g.(X - X0) + sum_v w_v/2 |x_v - x0_v|^2; gap[j] is B's excess
   over that model at X0 - alpha[j] D. One distance per vertex and obstacle at X0; a vertex whose
   segment cannot come within dhat (the distance is 1-Lipschitz: d0 - alpha |D_v| >= dhat) adds
   only the weights' term, so only the vertices within reach are evaluated at each alpha. */
static PetscErrorCode PDGap_Obstacles(MSimImplicitTerm term, Vec X0, Vec D, PetscInt n, const PetscReal alpha[], PetscReal gap[])
{
  PDWeights         *pw  = (PDWeights *)term->data;
  MSimSystem         sys = term->imp->sys;
  const PetscReal    tx  = term->imp->step.tx;
  MSimContact        ct;
  const PetscScalar *x0, *dv, *m;
  PetscReal          amax = 0, q = 0;
  std::vector<PetscReal> g(n, 0.0);

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscReal w = term->imp->step.h2 * ct->kappa;
  for (PetscInt j = 0; j < n; j++) amax = PetscMax(amax, alpha[j]);
  PetscCall(VecGetArrayRead(X0, &x0));
  PetscCall(VecGetArrayRead(D, &dv));
  PetscCall(VecGetArrayRead(term->imp->sys->mass, &m));
  for (PetscInt v = 0; v < sys->nown; v++) {
    const PetscReal *p = x0 + 3 * v, *u = dv + 3 * v, len = PetscSqrtReal(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (v < (PetscInt)pw->w.size()) q += pw->w[v] * len * len;
    if (len == 0) continue;
    for (const MSimObstacle &o : ct->obs) {
      /* B's part at X0 and its slope grad B(X0).D_v, as the right-hand side has them, summed over the
         vertex's contacts (a mesh's creases': MSimObstacleContacts); v's answers are not kept here
         (vertex -1: the plain query) */
      const PetscReal wm = w * PetscRealPart(m[3 * v]);
      PetscReal       b0 = 0, slope = 0;
      const PetscReal d0 = MSimObstacleContacts(o, -1, p, tx, ct->dhat, PETSC_FALSE, [&](PetscReal d, const PetscReal *n0, const PetscReal *) {
        PetscReal b, db, d2b;
        if (d <= 0) { /* not feasible: no bound (PD halves on Phi instead) */
          b0 = PETSC_INFINITY;
          return;
        }
        MSimBarrier(d, ct->dhat, &b, &db, &d2b);
        b0 += b;
        MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &b, &db, &d2b); /* AddGradient's */
        slope += wm * db * (n0[0] * u[0] + n0[1] * u[1] + n0[2] * u[2]);
      });
      if (d0 - amax * len >= ct->dhat) continue;
      for (PetscInt j = 0; j < n; j++) {
        const PetscReal xa[3] = {p[0] - alpha[j] * u[0], p[1] - alpha[j] * u[1], p[2] - alpha[j] * u[2]};
        PetscReal       b     = 0;
        bool            bad   = b0 == PETSC_INFINITY;
        if (d0 - alpha[j] * len < ct->dhat)
          MSimObstacleContacts(o, -1, xa, tx, ct->dhat, PETSC_FALSE, [&](PetscReal d, const PetscReal *, const PetscReal *) {
            PetscReal bd, db, d2b;
            if (d <= 0) bad = true;
            else {
              MSimBarrier(d, ct->dhat, &bd, &db, &d2b);
              b += bd;
            }
          });
        if (bad) g[j] = PETSC_INFINITY;
        if (g[j] < PETSC_INFINITY) g[j] += wm * (b - b0) + alpha[j] * slope;
      }
    }
  }
  PetscCall(VecRestoreArrayRead(term->imp->sys->mass, &m));
  PetscCall(VecRestoreArrayRead(D, &dv));
  PetscCall(VecRestoreArrayRead(X0, &x0));
  for (PetscInt j = 0; j < n; j++) g[j] -= 0.5 * alpha[j] * alpha[j] * q;
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, g.data(), (PetscMPIInt)n, MPIU_REAL, MPIU_SUM, sys->comm));
  for (PetscInt j = 0; j < n; j++) gap[j] += g[j];
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The weights PD's factor holds are state: a fixed-iteration PD step depends on them, and the lazy
   rule keeps them over many steps, so a restart that recomputed them at its first step did not
   repeat the run bit for bit. A checkpoint carries them (each vertex's in its x slot). Serially,
   msimllt's solves also depend on the matrix it last factored (the base: it corrects the solves by a
   low-rank update while only a few diagonal entries differ from it, PCMSimLLTGetBaseDiagonal), so
   the checkpoint carries the base's diagonal too, in each vertex's y slot, with 1 in its z slot
   where it does (a checkpoint without it, all zeros, restarts as before: the factor from scratch). */

/* PD's global-step PC when it is msimllt, else NULL */
static PetscErrorCode PDLLT(MSimImplicitTerm term, PC *pc)
{
  PetscBool llt = PETSC_FALSE;

  PetscFunctionBeginUser;
  *pc = NULL;
  if (!term->imp->pdksp || !term->imp->A) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(KSPGetPC(term->imp->pdksp, pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)*pc, PCMSIMLLT, &llt));
  if (!llt) *pc = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode GetHistory_Obstacles(MSimImplicitTerm term, Vec *h)
{
  PDWeights   *pw = (PDWeights *)term->data;
  PetscScalar *x;
  PC           pc;
  Vec          d   = NULL;
  PetscBool    has = PETSC_FALSE;

  PetscFunctionBeginUser;
  if (!pw->hist) PetscCall(VecDuplicate(term->imp->sys->X0, &pw->hist));
  PetscCall(PDLLT(term, &pc));
  if (pc) { /* has: the same on every rank (false on several) */
    PetscCall(MatCreateVecs(term->imp->A, &d, NULL));
    PetscCall(PCMSimLLTGetBaseDiagonal(pc, d, &has));
  }
  PetscCall(VecZeroEntries(pw->hist));
  PetscCall(VecGetArray(pw->hist, &x));
  for (size_t v = 0; v < pw->w.size(); v++) x[3 * v] = pw->w[v];
  if (has) {
    const PetscScalar *b;
    PetscInt           n;
    PetscCall(VecGetLocalSize(d, &n));
    PetscCheck(n == term->imp->sys->nown, PETSC_COMM_SELF, PETSC_ERR_PLIB, "PD's matrix has %" PetscInt_FMT " rows, the system %" PetscInt_FMT " vertices", n, term->imp->sys->nown);
    PetscCall(VecGetArrayRead(d, &b));
    for (PetscInt v = 0; v < n; v++) {
      x[3 * v + 1] = b[v];
      x[3 * v + 2] = 1;
    }
    PetscCall(VecRestoreArrayRead(d, &b));
  }
  PetscCall(VecRestoreArray(pw->hist, &x));
  PetscCall(VecDestroy(&d));
  *h = pw->hist;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode HistoryLoaded_Obstacles(MSimImplicitTerm term)
{
  PDWeights         *pw = (PDWeights *)term->data;
  const PetscScalar *x;
  PC                 pc;
  PetscBool          has;

  PetscFunctionBeginUser;
  pw->w.assign(term->imp->sys->nown, 0.0);
  PetscCall(VecGetArrayRead(pw->hist, &x));
  for (size_t v = 0; v < pw->w.size(); v++) pw->w[v] = PetscRealPart(x[3 * v]);
  WeightedSet(pw);
  has = (PetscBool)(!pw->w.empty() && PetscRealPart(x[2]) == 1);
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &has, 1, MPIU_BOOL, MPI_LAND, term->imp->sys->comm));
  PetscCall(PDLLT(term, &pc));
  if (has && pc) { /* the run's base first: its factor then takes the same update as the run's */
    Vec          d;
    PetscScalar *b;
    PetscInt     n;
    PetscCall(MatCreateVecs(term->imp->A, &d, NULL));
    PetscCall(VecGetLocalSize(d, &n));
    PetscCall(VecGetArrayWrite(d, &b));
    for (PetscInt v = 0; v < n && v < (PetscInt)pw->w.size(); v++) b[v] = x[3 * v + 1];
    PetscCall(VecRestoreArrayWrite(d, &b));
    PetscCall(PCMSimLLTSetBaseDiagonal(pc, d));
    PetscCall(VecDestroy(&d));
  }
  PetscCall(VecRestoreArrayRead(pw->hist, &x));
  pw->pending  = PETSC_FALSE;
  pw->restored = PETSC_TRUE;
  /* A takes the weights now (where it exists; else its set-up does), so that the first step sees
     the run's A, factor and decisions: assembled at that step's first reweight instead, A changed
     there, where the run's did not, and PD + L-BFGS's fused gradient, which takes such a change
     for a new A, computed that step's gradients by the product and dropped its pairs
     (MSimImplicitPDGradient): 1.9e-4 m off the uninterrupted run after 17 more steps */
  PetscCall(MSimImplicitPDReweight(term->imp, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Obstacles(MSimImplicitTerm term)
{
  PetscFunctionBeginUser;
  if (term->data) PetscCall(VecDestroy(&((PDWeights *)term->data)->hist));
  if (term->data) PetscCall(VecDestroy(&((PDWeights *)term->data)->diag));
  delete (PDWeights *)term->data;
  term->data = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* o's safe step for the rank's vertex v: a mesh takes v's distance at x from its last answers
   (MSimMeshObstacleSafeStepVertex; the same numbers) */
static PetscReal SafeStep(const MSimObstacle &o, PetscReal t, PetscInt v, const PetscScalar *x, const PetscReal u[3], PetscReal tmax)
{
  if (o.kind != MSIM_OBSTACLE_MESH) return MSimObstacleSafeStep(&o, t, x, u, tmax);
  const PetscReal y[3] = {x[0] - o.v[0] * t, x[1] - o.v[1] * t, x[2] - o.v[2] * t}; /* as MSimObstacleSafeStep */
  return MSimMeshObstacleSafeStepVertex(o.mesh, v, y, u, tmax);
}

/* The anchors' tests of MaxStep_Obstacles and Clamp_Obstacles as flags, in passes without branches
   that the compiler vectorizes: |x - anchor|^2, its square roots (4 at a time with AVX: the scalar
   sqrt's errno branch keeps the compiler's vectorizer out; each correctly rounded, so the same
   numbers), then the test. mv[v] = 1: v's move may reach an obstacle (not skipped): the scalar
   tests' own flags. r: nown + 4 entries of work. */
static void AnchorDistances(PetscInt nown, const PetscReal *__restrict an, const PetscScalar *__restrict p, PetscReal *__restrict r)
{
  for (PetscInt v = 0; v < nown; v++) r[v] = AnchorDistance2(an, p, v);
  AnchorRoots(nown, r);
}

/* max(q), infinite where some q is NaN (no bound); q >= 0. 4 at a time with AVX (the compiler
   does not vectorize a floating-point max) */
static PetscReal LargestOf(PetscInt n, const PetscReal *q)
{
  PetscReal m = 0;
  PetscInt  v = 0;
  PetscBool nan = PETSC_FALSE;
#if defined(__AVX__)
  __m256d mm = _mm256_setzero_pd(), un = _mm256_setzero_pd();
  for (; v + 4 <= n; v += 4) {
    const __m256d qv = _mm256_loadu_pd(q + v);
    mm               = _mm256_max_pd(mm, qv);
    un               = _mm256_or_pd(un, _mm256_cmp_pd(qv, qv, _CMP_UNORD_Q));
  }
  PetscReal lanes[4], bad[4];
  _mm256_storeu_pd(lanes, mm);
  _mm256_storeu_pd(bad, un);
  for (int l = 0; l < 4; l++) {
    m   = PetscMax(m, lanes[l]);
    nan = (PetscBool)(nan || bad[l] != 0);
  }
#endif
  for (; v < n; v++) {
    m   = PetscMax(m, q[v]);
    nan = (PetscBool)(nan || q[v] != q[v]);
  }
  return nan ? PETSC_INFINITY : m;
}

/* max_step from an X without kept distances: X - alpha Y, at alpha^2 = a2 */
static void AnchorMoveMask(PetscInt nown, const PetscReal *__restrict an, const PetscReal *__restrict ex, PetscReal dhat, const PetscScalar *__restrict xr, const PetscScalar *__restrict yr, PetscReal a2, PetscReal *__restrict r, unsigned char *__restrict mv)
{
  AnchorDistances(nown, an, xr, r);
  for (PetscInt v = 0; v < nown; v++) {
    const PetscReal e = ex[v], q = yr[3 * v] * yr[3 * v] + yr[3 * v + 1] * yr[3 * v + 1] + yr[3 * v + 2] * yr[3 * v + 2];
    const PetscReal lb = e + dhat - r[v];
    mv[v]              = (unsigned char)!((e > -dhat) & (lb > 0) & (0.5625 * lb * lb > a2 * q));
  }
}

/* the clamp: A's vertices moving to X's, at alpha = 1 */
static void ClampMoveMask(PetscInt nown, const PetscReal *__restrict an, const PetscReal *__restrict ex, PetscReal dhat, const PetscScalar *__restrict ar, const PetscScalar *__restrict xr, PetscReal *__restrict r, unsigned char *__restrict mv)
{
  AnchorDistances(nown, an, ar, r);
  for (PetscInt v = 0; v < nown; v++) {
    const PetscReal u[3] = {PetscRealPart(xr[3 * v] - ar[3 * v]), PetscRealPart(xr[3 * v + 1] - ar[3 * v + 1]), PetscRealPart(xr[3 * v + 2] - ar[3 * v + 2])};
    const PetscReal e = ex[v], lb = e + dhat - r[v];
    mv[v]                = (unsigned char)!(((u[0] == 0) & (u[1] == 0) & (u[2] == 0)) | ((e > -dhat) & (lb > 0) & (0.5625 * lb * lb > u[0] * u[0] + u[1] * u[1] + u[2] * u[2])));
  }
}

/* Whether vertex v, which cut a PD global step from x (its safe step along the step set alpha),
   has a factored weight too low for its distance there, by -msim_contact_pd_refactor's rule (its
   wanted diagonal above r x A's; r = 0: a weight where it has none), at a distance that roundoff
   threatens: below sqrt(eps) |x_v|_1, where the coordinates' roundoff is over 1e-8 of it. The
   weights are taken once a time step, at its first local step, so a vertex that comes within dhat
   later in the step, or nearer than it was there, has a weight in A far below its barrier's
   curvature b'' ~ dhat^2/d^2; its global step then overshoots into the obstacle, max_step stops
   the whole cloth at 0.8 of the vertex's hit time and leaves it at a fifth of its distance, where
   its weight is 25 x further off. At -msim_contact_distance 1e-5 (PD-10 on a ball, h = 0.02) a
   vertex fell from 6.6e-9 to 5e-12 m in the iterations of two steps, the cloth's steps cut to
   alpha ~1e-6 meanwhile, and at 1e-12 m the coordinates' roundoff is 1e-5 of the distance: 1 and 2
   ranks drifted 8 mm apart in 20 steps once msimllt refactored there (3e-2 m before), and 3e-7 m
   with the weights taken again at the next local step, which stops the fall where it starts. Above sqrt(eps) |x| the rule per time step stands:
   there the same fall (to 7e-4 dhat at the default dhat) is harmless, and every PD contact run
   keeps its bits. PD's own steps alone (Newton's preconditioner takes them at every Jacobian). */
static PetscErrorCode BlockerStale(MSimImplicitTerm term, MSimContact ct, PDWeights *pw, PetscInt v, const PetscScalar *x, PetscBool *stale)
{
  const PetscScalar *m;
  PetscReal          wv = 0, want;
  PetscScalar        have;
  const PetscInt     row = term->imp->sys->rstart + v;
  PetscReal          dmin = PETSC_MAX_REAL;
  const PetscReal    size = PetscAbsScalar(x[3 * v]) + PetscAbsScalar(x[3 * v + 1]) + PetscAbsScalar(x[3 * v + 2]);

  PetscFunctionBeginUser;
  *stale = PETSC_FALSE;
  if (!term->imp->A || !ct->pd_weight || pw->at_jacobian || term->imp->pd_pc || (PetscInt)pw->w.size() != term->imp->sys->nown) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(term->imp->sys->mass, &m));
  const PetscReal h2km = term->imp->step.h2 * ct->kappa * PetscRealPart(m[3 * v]);
  PetscCall(VecRestoreArrayRead(term->imp->sys->mass, &m));
  for (const MSimObstacle &o : ct->obs)
    MSimObstacleContacts(o, v, x + 3 * v, term->imp->step.tx, ct->dhat, PETSC_FALSE, [&](PetscReal d, const PetscReal *, const PetscReal *) {
      PetscReal b, db, d2b;
      MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &b, &db, &d2b);
      wv += h2km * d2b;
      dmin = PetscMin(dmin, d);
    });
  if (!(dmin < PETSC_SQRT_MACHINE_EPSILON * size)) PetscFunctionReturn(PETSC_SUCCESS);
  if (ct->pd_refactor > 0) {
    PetscCall(MatGetValues(term->imp->A, 1, &row, 1, &row, &have));
    want   = PetscRealPart(have) - pw->w[v] + wv;
    *stale = (PetscBool)(want > ct->pd_refactor * PetscRealPart(have));
  } else *stale = (PetscBool)(wv > 0 && pw->w[v] == 0);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* pw->input_id: each owned vertex's input id, by the natural layout's scatter run backwards (once
   a run). Collective. */
static PetscErrorCode InputIds(MSimSystem sys, PDWeights *pw)
{
  Vec                g;
  PetscInt           lo, hi;
  PetscScalar       *n;
  const PetscScalar *x;

  PetscFunctionBeginUser;
  if (pw->have_input_id) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(sys->nv <= INT_MAX / 2, sys->comm, PETSC_ERR_SUP, "max_step's reduction keys 2 x the input id in an int: at most %d vertices", INT_MAX / 2);
  PetscCall(MSimSystemNaturalSetUp(sys));
  PetscCall(VecGetOwnershipRange(sys->natural, &lo, &hi));
  PetscCall(VecGetArray(sys->natural, &n));
  for (PetscInt i = lo; i < hi; i++) n[i - lo] = (PetscScalar)(i / 3);
  PetscCall(VecRestoreArray(sys->natural, &n));
  PetscCall(MSimSystemCreateVec(sys, &g));
  PetscCall(VecScatterBegin(sys->to_natural, sys->natural, g, INSERT_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(sys->to_natural, sys->natural, g, INSERT_VALUES, SCATTER_REVERSE));
  PetscCall(VecGetArrayRead(g, &x));
  pw->input_id.resize(sys->nown);
  for (PetscInt v = 0; v < sys->nown; v++) pw->input_id[v] = (PetscInt)(PetscRealPart(x[3 * v]) + 0.5);
  PetscCall(VecRestoreArrayRead(g, &x));
  PetscCall(VecDestroy(&g));
  pw->have_input_id = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MaxStep_Obstacles(MSimImplicitTerm term, Vec X, Vec Y, PetscReal *alpha)
{
  MSimSystem         sys = term->imp->sys;
  MSimContact        ct;
  const PetscScalar *x, *y;
  PetscReal          a = *alpha;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  /* a vertex whose move a |u| is shorter than 0.75 of a lower bound on its distance (its anchor's:
     ex + dhat - |x - anchor|) cannot lower alpha (the distance is 1-Lipschitz, so a hit comes after
     d / |u|, and the safe step is 0.8 of it; with a mesh's thickness, conservative advancement
     covers 0.9 d / |u| at once), so its ray tests are skipped (the global step's max_step: 4% of
     a contact step before); the others give the same alpha as without the skip */
  PDWeights       *pw = Anchors(term, ct);
  const PetscReal *dmin = NULL;
  PetscCall(InputIds(sys, pw));
  {
    /* from the X of PD's last local step, whose distances (or dhat) that pass kept */
    PetscObjectId    id;
    PetscObjectState state;
    PetscCall(PetscObjectGetId((PetscObject)X, &id));
    PetscCall(PetscObjectStateGet((PetscObject)X, &state));
    if (id == pw->dmin_id && state == pw->dmin_state && pw->dmin_tx == term->imp->step.tx && (PetscInt)pw->dmin.size() == sys->nown) dmin = pw->dmin.data();
  }
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(Y, &y));
  /* first the vertices that may lower alpha, by the test below at the incoming alpha (move[v]: not
     skipped there, so at no smaller alpha either), in a branch-free pass the compiler vectorizes;
     the loop below visits those alone, eight flags at a time, and repeats the exact test at its
     running alpha: the same ray tests in the same order (the test alone was 41 instructions a
     vertex, 4.2 M of a 123 M PD-10 step of the 101 x 101 drape, runs/contact/README.md) */
  {
    const PetscReal a2 = a * a, dhat = ct->dhat;
    pw->move.resize(sys->nown + 8, 0);
    unsigned char *__restrict mv = pw->move.data();
    const PetscReal *__restrict yr = y;
    const PetscInt nown = sys->nown; /* a char store could alias sys->nown */
    if (dmin) {
      const PetscReal *__restrict dr = dmin;
      pw->work.resize(nown + 4);
      PetscReal *__restrict qs = pw->work.data();
      for (PetscInt v = 0; v < nown; v++) {
        const PetscReal dm = dr[v], q = yr[3 * v] * yr[3 * v] + yr[3 * v + 1] * yr[3 * v + 1] + yr[3 * v + 2] * yr[3 * v + 2];
        mv[v]              = (unsigned char)((dm <= 0) | !(0.5625 * dm * dm > a2 * q)); /* | and !: no branch */
        qs[v]              = q;
      }
      /* the largest |y_v|, for the next local step's flags (FarFlags: PD's iterate moves by alpha y
         from X), with a margin for the roundoff of q and its root */
      const PetscReal qmax = LargestOf(nown, qs);
      if (qmax < PETSC_INFINITY) PetscCall(MSimImplicitPDSetVertexBound(Y, PetscSqrtReal(qmax) * (1 + 8 * PETSC_MACHINE_EPSILON)));
    } else { /* the first iterate's max_step from x_n's copy */
      pw->work.resize(nown + 4);
      AnchorMoveMask(nown, pw->anchor.data(), pw->ex.data(), dhat, x, y, a2, pw->work.data(), mv);
    }
  }
  const unsigned char *move    = pw->move.data();
  PetscInt             blocker = -1; /* the vertex that set this rank's alpha */
  for (PetscInt v = NextFlagged(move, 0, sys->nown, 1); v < sys->nown; v = NextFlagged(move, v + 1, sys->nown, 1)) {
    const PetscReal u[3] = {-y[3 * v], -y[3 * v + 1], -y[3 * v + 2]};
    if (u[0] == 0 && u[1] == 0 && u[2] == 0) continue;
    if (dmin) {
      if (dmin[v] > 0 && 0.5625 * dmin[v] * dmin[v] > a * a * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2])) continue; /* as below */
    } else if (pw->ex[v] > -ct->dhat) {
      const PetscReal *an = pw->anchor.data() + 3 * v, dx[3] = {x[3 * v] - an[0], x[3 * v + 1] - an[1], x[3 * v + 2] - an[2]};
      const PetscReal  lb = pw->ex[v] + ct->dhat - PetscSqrtReal(dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]);
      if (lb > 0 && 0.5625 * lb * lb > a * a * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2])) continue; /* 0.75 d > a |u|: the safe step, 0.8 of a hit at >= d / |u|, is then > a */
    }
    for (const MSimObstacle &o : ct->obs) {
      const PetscReal t = SafeStep(o, term->imp->step.tx, v, x + 3 * v, u, a);
      if (t < a || (t == a && blocker >= 0 && pw->input_id[v] < pw->input_id[blocker])) { /* ties: the least input id, as across ranks */
        a       = t;
        blocker = v;
      }
    }
  }
  /* with the step's alpha, whether the weights are to be taken again: the vertex that cut the
     global step decides, tested on its rank. One reduction as before (MINLOC of alpha with the
     key 2 id + (stale ? 0 : 1), where it was the MIN of alpha and a flag: no other collective)
     keeps the least alpha and, where several ranks' blockers cut it alike, the least input id
     (within a rank too, by the loop's tie rule: owned vertices are not in input order under
     -msim_vertex_order morton), so 1 and P ranks test the same vertex. The MIN of every rank's flag let each
     rank's own blocker, also one that cut no step, take the weights again: on the cloth over two
     balls (tests/contact_pd_small_dhat.py) 2 ranks did so where 1 did not and were 1.1e-5 m from
     it after 11 steps (1.1e-9 m now). A rank with no blocker sends an odd key: not stale. */
  static_assert(sizeof(PetscReal) == sizeof(double), "max_step's reduction is MPI_DOUBLE_INT");
  struct {
    double a;
    int    key;
  } red = {a, INT_MAX};
  if (blocker >= 0) {
    PetscBool stale;
    PetscCall(BlockerStale(term, ct, pw, blocker, x, &stale));
    red.key = 2 * (int)pw->input_id[blocker] + (stale ? 0 : 1);
  }
  PetscCall(VecRestoreArrayRead(Y, &y));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &red, 1, MPI_DOUBLE_INT, MPI_MINLOC, sys->comm));
  *alpha = red.a;
  if (!(red.key & 1)) {
    pw->stale = PETSC_TRUE;
    PetscCall(PetscInfo(X, "contact: vertex %d (input id) cut PD's global step to alpha %g with a factored weight too low for its distance: the weights are taken again at the next local step\n", red.key / 2, (double)red.a));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Each vertex of X whose segment from the feasible A meets an obstacle stops at its own safe step
   (0.8 of the hit time, IPC's filter; conservative advancement on meshes); the others keep their
   move. No reduction: max_step's common alpha, the smallest over all vertices, would instead stop
   the whole cloth when one vertex nears the ball (at the first iterate it froze the 101 x 101
   cloth in the air for PD and Newton-CG alike: runs/contact/README.md). */
static PetscErrorCode Clamp_Obstacles(MSimImplicitTerm term, Vec A, Vec X)
{
  MSimSystem         sys = term->imp->sys;
  MSimContact        ct;
  const PetscScalar *a;
  PetscScalar       *x;

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PDWeights *pw = Anchors(term, ct);
  PetscCall(VecGetArrayRead(A, &a));
  PetscCall(VecGetArray(X, &x));
  {
    /* the test below in a branch-free pass the compiler vectorizes (move[v]: not skipped), as
       max_step's; the loop visits the flagged vertices alone (the clamp was 0.7 M instructions of
       a 123 M PD-10 step of the 101 x 101 drape, most of it this test) */
    pw->move.resize(sys->nown + 8, 0);
    pw->work.resize(sys->nown + 4);
    ClampMoveMask(sys->nown, pw->anchor.data(), pw->ex.data(), ct->dhat, a, x, pw->work.data(), pw->move.data());
  }
  const unsigned char *move = pw->move.data();
  for (PetscInt v = NextFlagged(move, 0, sys->nown, 1); v < sys->nown; v = NextFlagged(move, v + 1, sys->nown, 1)) {
    const PetscReal u[3] = {PetscRealPart(x[3 * v] - a[3 * v]), PetscRealPart(x[3 * v + 1] - a[3 * v + 1]), PetscRealPart(x[3 * v + 2] - a[3 * v + 2])};
    PetscReal       s    = 1;
    if (u[0] == 0 && u[1] == 0 && u[2] == 0) continue;
    if (pw->ex[v] > -ct->dhat) {
      /* max_step's skip with alpha = 1, from the anchor's lower bound on the distance at A: the
         safe step then exceeds 1 and s stays 1 */
      const PetscReal *an = pw->anchor.data() + 3 * v, dx[3] = {a[3 * v] - an[0], a[3 * v + 1] - an[1], a[3 * v + 2] - an[2]};
      const PetscReal  lb = pw->ex[v] + ct->dhat - PetscSqrtReal(dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]);
      if (lb > 0 && 0.5625 * lb * lb > u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) continue;
    }
    for (const MSimObstacle &o : ct->obs) s = PetscMin(s, SafeStep(o, term->imp->step.tx, v, a + 3 * v, u, s));
    if (s < 1)
      for (int c = 0; c < 3; c++) x[3 * v + c] = a[3 * v + c] + s * u[c];
  }
  PetscCall(VecRestoreArray(X, &x));
  PetscCall(VecRestoreArrayRead(A, &a));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Whether a vertex's move from x0 at t to x1 at tx crosses o: o's exact hit time along the move
   relative to it (the analytic shapes; a mesh's ray query at thickness 0). A mesh's shell is judged
   at x1 alone: its conservative advancement cannot tell a crossing from a close pass. */
static PetscBool MoveCrosses(const MSimObstacle &o, PetscReal thickness, PetscReal t, PetscReal tx, const PetscReal x0[3], const PetscReal x1[3])
{
  PetscReal y[3], u[3];
  for (int c = 0; c < 3; c++) y[c] = x0[c] - o.v[c] * t, u[c] = x1[c] - o.v[c] * tx - y[c];
  if (u[0] == 0 && u[1] == 0 && u[2] == 0) return PETSC_FALSE;
  if (o.kind == MSIM_OBSTACLE_MESH) return (PetscBool)(thickness == 0 && MSimMeshObstacleSafeStep(o.mesh, y, u, 1.0) < 0.8);
  return (PetscBool)(MSimObstacleHitTime(&o, y, u) < 1);
}

/* Moving obstacles: x_n is outside them at t, but one may have moved onto it, or past it, by tx.
   In obstacle o's frame at tx, vertex v's motion over the step is the segment from a + v_o h to a
   (a: x_n, or where another obstacle carried it), whose start is at v's distance d(a, t) > 0 from
   o. A vertex o approached to within dhat, or whose segment o's own CCD sees cross o (o came
   farther in the step than their gap: a box rising 6 cm a step passed through the cloth, left
   under it with no force), is carried with o, all of v_o h: the segment's start, a rigid
   translation that keeps its distance, on the side it was on, so that the first iterate can be
   pulled back towards a feasible point and the barrier pushes it. The CCD's safe step (0.8 of the
   hit time for the analytic shapes and a mesh at thickness 0: below 0.8 is a hit within the
   segment, or for a box a pass by its edge nearer than a quarter of the start's distance;
   conservative advancement to a tenth of the start's distance for a mesh's shell: below 1 is
   one within the segment) is not taken as
   the start, as self-contact's moving handles take theirs (FeasibleStart_Self): there a vertex
   resting within dhat starts at a fifth of its gap, and PD's fixed iterations (-snes_pd_fixed,
   10) ended with a contact force of 1e5 N on the 9 x 9 cloth (6e8 N under a ball) where the
   whole carry gives 600 N (1.3e3 N); converged Newton ends the same from either. A segment whose
   end is farther from o than its length cannot cross it (most vertices: no query beyond the one
   at tx), and a vertex o does not cross is carried as before, so scenes where no obstacle passes a
   vertex start as before. Fixed vertices are no unknowns and are not carried: as a cloth pinned
   inside a static box runs, so does a handle a moving one passes (its free vertices kept out). A
   vertex carried into or through another obstacle (MoveCrosses) is squeezed between two: no
   feasible start exists. Per vertex: no communication but the one check. */
static PetscErrorCode FeasibleStart_Obstacles(MSimImplicitTerm term, Vec A)
{
  MSimImplicit   imp = term->imp;
  MSimSystem     sys = imp->sys;
  MSimContact    ct;
  PetscScalar   *a;
  const PetscReal dt = imp->step.tx - imp->step.t;
  std::vector<MSimSqueezed> squeezed; /* every one: the error names the first in input order, which the local order need not follow */

  PetscFunctionBeginUser;
  PetscCall(Contact(term, &ct));
  if (!ct || !ct->moving) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArray(A, &a));
  for (PetscInt v = 0; v < sys->nown; v++) {
    const PetscReal x0[3]   = {PetscRealPart(a[3 * v]), PetscRealPart(a[3 * v + 1]), PetscRealPart(a[3 * v + 2])};
    PetscInt        carrier = -1;
    for (const MSimObstacle &o : ct->obs) {
      if (o.v[0] == 0 && o.v[1] == 0 && o.v[2] == 0) continue;
      PetscReal       n[3];
      const PetscReal u[3] = {-o.v[0] * dt, -o.v[1] * dt, -o.v[2] * dt}, len = PetscSqrtReal(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
      const PetscReal dnew = MSimObstacleDistanceAt(&o, imp->step.tx, a + 3 * v, n, NULL);
      if (dnew >= ct->dhat && dnew > len) continue; /* the distance is 1-Lipschitz: the segment ending here cannot reach o */
      const PetscReal dold  = MSimObstacleDistanceAt(&o, imp->step.t, a + 3 * v, n, NULL);
      PetscBool       carry = (PetscBool)(dnew < ct->dhat && dnew < dold);
      if (!carry && dold > 0) { /* (dold <= 0: carried into o's place at t by another, no segment from outside; the check below judges it) */
        const PetscReal z[3] = {PetscRealPart(a[3 * v]) - u[0], PetscRealPart(a[3 * v + 1]) - u[1], PetscRealPart(a[3 * v + 2]) - u[2]};
        /* the plain query (the meshes' per-vertex answers stay the barrier's), over the whole
           segment: a mesh searches only up to tmax, so 0.8 missed one passing a vertex in the last
           fifth of its step (an open square rising 32 cm a step, 28 cm under the cloth). Its
           shell's answer is the advancement's own t, below 1 within the segment */
        const PetscReal s = MSimObstacleSafeStep(&o, imp->step.tx, z, u, 1.0);
        carry             = (PetscBool)(s < (o.kind == MSIM_OBSTACLE_MESH && ct->thickness > 0 ? 1.0 : 0.8));
      }
      if (carry) {
        for (int c = 0; c < 3; c++) a[3 * v + c] += o.v[c] * dt;
        carrier = (PetscInt)(&o - ct->obs.data());
      }
    }
    /* squeezed: inside an obstacle at tx, or carried through one (a box rising 6 cm a step carried
       the cloth through a 5 mm ceiling, which the check at tx alone let pass, exit 0) */
    for (size_t k = 0; k < ct->obs.size(); k++) {
      PetscReal       n[3];
      const PetscReal x1[3] = {PetscRealPart(a[3 * v]), PetscRealPart(a[3 * v + 1]), PetscRealPart(a[3 * v + 2])};
      if (MSimObstacleDistanceAt(&ct->obs[k], imp->step.tx, x1, n, NULL) <= 0 || (carrier >= 0 && MoveCrosses(ct->obs[k], ct->thickness, imp->step.t, imp->step.tx, x0, x1))) {
        squeezed.push_back({v, (PetscInt)k, carrier});
        break;
      }
    }
  }
  PetscCall(VecRestoreArray(A, &a));
  /* with one obstacle nothing squeezes: a vertex it carries keeps its distance, so it is inside
     only where that distance was within roundoff of 0 */
  PetscCall(MSimContactRefuseSqueezed(ct, imp->step.tx, squeezed));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_Obstacles(MSimImplicitTerm term, PetscViewer viewer)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  if (ct) PetscCall(PetscViewerASCIIPrintf(viewer, "obstacles: IPC barrier, dhat %g, kappa %g 1/s^2 (per unit mass)\n", (double)ct->dhat, (double)ct->kappa));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimImplicitTermOps ObstaclesOps = {.energy = Energy_Obstacles, .gradient = Gradient_Obstacles, .hessian = Hessian_Obstacles, .pd_matrix = PDMatrix_Obstacles, .pd_rhs = PDRHS_Obstacles, .pd_gradient = PDGradient_Obstacles,
                                                 .pd_reweight = PDReweight_Obstacles, .max_step = MaxStep_Obstacles, .clamp = Clamp_Obstacles, .feasible_start = FeasibleStart_Obstacles, .view = View_Obstacles, .destroy = Destroy_Obstacles};

PetscErrorCode MSimImplicitTermCreate_Obstacles(MSimImplicitTerm term)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  /* the options are read and the start state checked now, before the first step */
  PetscCall(MSimContactGet(term->imp->sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS); /* no obstacle: no op, nothing per iteration */
  /* the scheme says where a barrier on its unknown cannot guarantee x_{n+1} (midpoint, Newmark) */
  PetscCheck(!term->imp->scheme->no_barrier, term->imp->sys->comm, PETSC_ERR_SUP, "-msim_integrator %s with obstacles (-msim_contact_*) is not supported (%s): use implicit_euler or bdf2 (or an explicit integrator)", term->imp->scheme->type, term->imp->scheme->no_barrier);
  term->data = new PDWeights();
  term->ops  = ObstaclesOps;
  if (!ct->pd_weight) { /* the barrier in PD's right-hand side only */
    term->ops.pd_reweight = NULL;
    term->ops.pd_matrix   = NULL;
  } else {
    term->ops.get_history    = GetHistory_Obstacles;
    term->ops.history_loaded = HistoryLoaded_Obstacles;
  }
  if (!ct->moving) term->ops.feasible_start = NULL;
  if (ct->pd_bound) term->ops.pd_gap = PDGap_Obstacles;
  PetscFunctionReturn(PETSC_SUCCESS);
}
