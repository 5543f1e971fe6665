/* The contact object: obstacles from options (-msim_contact_plane / _sphere / _box, several per
   option, 4 or 6 values each; -msim_contact_mesh, several files, src/contact/mesh_obstacle.cpp),
   their velocities (-msim_contact_velocity, one triple per obstacle in the order -msim_scene_view
   lists them: planes, spheres, boxes, meshes, each in the order given), the contact distance,
   friction and stiffnesses, and the checks of the start state. Kept on the system's X0 (a PetscContainer composed there) so that it lives and
   dies with the system and no header of the system changes. Defaults:
   - dhat = 1e-2 of the scene's diameter (the barrier acts within 1% of the scene's size);
   - kappa (implicit barrier, per unit mass) = 1 / (beta h^2 b''(dhat/2)): the barrier's stiffness
     in Phi equals the mass's at half the contact distance, IPC's rule of balancing the barrier
     against the mass/h^2 scale (Li et al. 2020, sec. 4.3), set at the implicit integrator's set-up
     (so that step 0's monitor row and frame report a start's force);
   - kc (explicit penalty, N/m) = the largest rest row sum of spring stiffnesses over free
     vertices: a vertex in contact with one obstacle is at most half again as stiff as the
     stiffest vertex in the Gershgorin bound, so the stability guard's limit drops by at most
     sqrt(3/2) with one obstacle (it counts kc per obstacle: a vertex may press into several).
   Explicit integrators get a penalty, kc max(0, -d) n per vertex and obstacle, rather than a
   projection with a velocity response: it is one more force in MSimSystemComputeForce, so every
   explicit method and PETSc's TS take it without a change to their updates, and its stiffness is
   a diagonal term the Gershgorin guard bounds (max_i (2 sum_j k_ij + n_obstacles kc) / m_i). The
   penalty lets a vertex sink m g / kc at rest (and a landing vertex about v sqrt(m / kc) more),
   on a mesh as on the analytic shapes: a closed mesh answers its inside at any depth, and a shell
   pushes a vertex back to the side it came from (MSimMeshObstacleSetPenalty), so a mesh holds a
   vertex until it passes the solid's middle, as a box does, and a shell holds it at any depth
   while it stays over the surface; it has no friction: -msim_friction acts in the
   implicit integrators only (the others refuse it, contact_force.cpp). PETSc's implicit TS types
   take the penalty's stiffness in their Jacobian (MSimContactAddPenaltyJacobian). The SLEPc guard (-msim_spectrum_guard slepc) takes the largest
   eigenvalue of (K + kc sum_o n_o n_o^T per vertex, M) (MSimContactAddPenaltyStiffness): every
   vertex as if pressed into every obstacle, exact for a cloth lying on a plane. */
#include <msim/contact.h>
#include <msim/implicit.h>
#include <msim/options.h>
#include <msim/errors.h>
#include <msim/private/systemimpl.h>
#include <msim/private/contactimpl.h>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

static PetscErrorCode ContactDestroy(void *ctx)
{
  MSimContact ct = (MSimContact)ctx;
  for (MSimObstacle &o : ct->obs)
    if (o.mesh) MSimMeshObstacleDestroy(&o.mesh);
  delete ct;
  return PETSC_SUCCESS;
}

void MSimBarrier(PetscReal d, PetscReal dhat, PetscReal *b, PetscReal *db, PetscReal *d2b)
{
  if (d >= dhat) {
    *b = *db = *d2b = 0;
    return;
  }
  const PetscReal r = d - dhat, l = std::log(d / dhat);
  *b   = -r * r * l;
  *db  = -2 * r * l - r * r / d;
  *d2b = -2 * l - 4 * r / d + r * r / (d * d);
}

PetscReal MSimObstacleDistance(const MSimObstacle *o, const PetscReal x[3], PetscReal n[3], PetscReal H[9])
{
  const PetscReal *p = o->p;
  PetscReal        d = 0;

  if (H)
    for (int k = 0; k < 9; k++) H[k] = 0;
  switch (o->kind) {
  case MSIM_OBSTACLE_MESH: return MSimMeshObstacleDistance(o->mesh, x, n, H);
  case MSIM_OBSTACLE_PLANE:
    for (int c = 0; c < 3; c++) n[c] = p[c];
    return p[0] * x[0] + p[1] * x[1] + p[2] * x[2] - p[3];
  case MSIM_OBSTACLE_SPHERE: {
    PetscReal q[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]}, r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    if (r == 0) { /* the centre: any direction */
      n[0] = 0, n[1] = 0, n[2] = 1;
      return -p[3];
    }
    for (int c = 0; c < 3; c++) n[c] = q[c] / r;
    if (H) /* (I - n n^T) / r */
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) H[3 * a + b] = ((a == b) - n[a] * n[b]) / r;
    return r - p[3];
  }
  case MSIM_OBSTACLE_BOX: {
    PetscReal q[3], s = 0;
    for (int c = 0; c < 3; c++) {
      const PetscReal lo = p[2 * c] - x[c], hi = x[c] - p[2 * c + 1];
      q[c] = lo > 0 ? -lo : (hi > 0 ? hi : 0); /* signed excess over the slab */
      s += q[c] * q[c];
    }
    if (s > 0) { /* outside: distance to the nearest point of the box, over the axes outside */
      d = std::sqrt(s);
      for (int c = 0; c < 3; c++) n[c] = q[c] / d;
      if (H) /* (I_S - n n^T) / d on the axes S outside their slab: zero on a face's region */
        for (int a = 0; a < 3; a++)
          for (int b = 0; b < 3; b++)
            if (q[a] != 0 && q[b] != 0) H[3 * a + b] = ((a == b) - n[a] * n[b]) / d;
      return d;
    }
    /* inside: minus the distance to the nearest face */
    d = PETSC_MAX_REAL;
    for (int c = 0; c < 3; c++)
      for (int side = 0; side < 2; side++) {
        const PetscReal f = side ? p[2 * c + 1] - x[c] : x[c] - p[2 * c];
        if (f < d) {
          d    = f;
          n[0] = n[1] = n[2] = 0;
          n[c]               = side ? 1 : -1;
        }
      }
    return -d;
  }
  }
  return 0;
}

PetscReal MSimObstacleDistanceAt(const MSimObstacle *o, PetscReal t, const PetscReal x[3], PetscReal n[3], PetscReal H[9])
{
  const PetscReal y[3] = {x[0] - o->v[0] * t, x[1] - o->v[1] * t, x[2] - o->v[2] * t}; /* x relative to the moved obstacle */
  return MSimObstacleDistance(o, y, n, H);
}

/* the first t >= 0 at which x + t u is inside the box p (x0, x1, y0, y1, z0, z1): the slabs' test */
static PetscReal BoxHitTime(const PetscReal p[6], const PetscReal x[3], const PetscReal u[3])
{
  PetscReal tin = 0, tout = PETSC_INFINITY;
  for (int c = 0; c < 3; c++) {
    if (u[c] == 0) {
      if (x[c] < p[2 * c] || x[c] > p[2 * c + 1]) return PETSC_INFINITY;
      continue;
    }
    PetscReal t0 = (p[2 * c] - x[c]) / u[c], t1 = (p[2 * c + 1] - x[c]) / u[c];
    if (t0 > t1) std::swap(t0, t1);
    tin  = PetscMax(tin, t0);
    tout = PetscMin(tout, t1);
  }
  return tin <= tout ? tin : PETSC_INFINITY;
}

PetscReal MSimObstacleSafeStep(const MSimObstacle *o, PetscReal t, const PetscReal x[3], const PetscReal u[3], PetscReal tmax)
{
  const PetscReal y[3] = {x[0] - o->v[0] * t, x[1] - o->v[1] * t, x[2] - o->v[2] * t};
  if (o->kind == MSIM_OBSTACLE_MESH) return MSimMeshObstacleSafeStep(o->mesh, y, u, tmax);
  PetscReal hit = MSimObstacleHitTime(o, y, u);
  if (o->kind == MSIM_OBSTACLE_BOX && hit == PETSC_INFINITY) {
    /* A ray that misses the box may still graze it: a cloth vertex on a face's plane (a grid line
       on the box's edge, x = 0.2 = 4 h) sits outside the face's slab by an ulp, so its fall is
       parallel to the face at distance 1e-16 and the exact test lets it past the edge, down the
       side at a distance of 1e-16 to 1e-12, where the barrier's PD weight b''(d) ~ dhat^2/d^2
       locked it at its first iterate: it fell at its landing speed through every later step,
       stretching the springs (PD-10 on the box table diverged, runs/contact/README.md). Such a
       ray meets the box grown by a quarter of x's distance d0 (the start is outside it: some axis
       is beyond its slab by d0/sqrt(3)), and up to there every point is that far from the box, so
       the step keeps a gap of d0/4 where the vertex passes an edge. A ray that hits the box
       keeps its exact time. */
    PetscReal       n[3], g[6];
    const PetscReal d0 = MSimObstacleDistance(o, y, n, NULL), m = 0.25 * d0;
    if (d0 > 0) {
      for (int c = 0; c < 3; c++) g[2 * c] = o->p[2 * c] - m, g[2 * c + 1] = o->p[2 * c + 1] + m;
      hit = BoxHitTime(g, y, u);
    }
  }
  return 0.8 * hit < tmax ? 0.8 * hit : PETSC_INFINITY;
}

PetscReal MSimObstacleHitTime(const MSimObstacle *o, const PetscReal x[3], const PetscReal u[3])
{
  const PetscReal *p = o->p;

  switch (o->kind) {
  case MSIM_OBSTACLE_MESH: return MSimMeshObstacleSafeStep(o->mesh, x, u, PETSC_MAX_REAL);
  case MSIM_OBSTACLE_PLANE: {
    const PetscReal d = p[0] * x[0] + p[1] * x[1] + p[2] * x[2] - p[3], vn = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
    return vn < 0 ? d / -vn : PETSC_INFINITY;
  }
  case MSIM_OBSTACLE_SPHERE: { /* |q + t u| = r: a t^2 + 2 b t + c = 0, c > 0 outside */
    const PetscReal q[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
    const PetscReal a = u[0] * u[0] + u[1] * u[1] + u[2] * u[2], b = q[0] * u[0] + q[1] * u[1] + q[2] * u[2];
    const PetscReal c = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - p[3] * p[3], disc = b * b - a * c;
    if (a == 0 || b >= 0 || disc < 0) return PETSC_INFINITY;
    return c / (-b + std::sqrt(disc)); /* the smaller root, in the form without cancellation */
  }
  case MSIM_OBSTACLE_BOX: return BoxHitTime(p, x, u); /* slabs: the ray is inside all three over [tin, tout] */
  }
  return PETSC_INFINITY;
}

static const char *KindOption(MSimObstacleKind k)
{
  return k == MSIM_OBSTACLE_PLANE ? "-msim_contact_plane" : (k == MSIM_OBSTACLE_SPHERE ? "-msim_contact_sphere" : (k == MSIM_OBSTACLE_BOX ? "-msim_contact_box" : "-msim_contact_mesh"));
}

PetscErrorCode MSimContactView(MSimContact ct, PetscViewer viewer)
{
  PetscFunctionBeginUser;
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  /* the penalty's kc only where the integrator takes it (MSimContactRefuseUnread): the implicit
     integrators have none */
  PetscCall(PetscViewerASCIIPrintf(viewer, "contact: %d obstacle(s), distance dhat %g, friction mu %g\n", (int)ct->obs.size(), (double)ct->dhat, (double)ct->mu));
  for (size_t k = 0; k < ct->obs.size(); k++) {
    const PetscReal *p = ct->obs[k].p;
    switch (ct->obs[k].kind) {
    case MSIM_OBSTACLE_MESH: {
      const char *file;
      PetscInt    ntri;
      PetscBool   closed;
      MSimMeshObstacleInfo(ct->obs[k].mesh, &file, &ntri, &closed);
      PetscCall(PetscViewerASCIIPrintf(viewer, "  obstacle %d: mesh %s, %d triangles, %s, thickness %g\n", (int)k, file, (int)ntri, closed ? "closed (the cloth stays outside)" : "open (either side)", (double)ct->thickness));
    } break;
    case MSIM_OBSTACLE_PLANE: PetscCall(PetscViewerASCIIPrintf(viewer, "  obstacle %d: plane n = (%g, %g, %g), n.x >= %g\n", (int)k, (double)p[0], (double)p[1], (double)p[2], (double)p[3])); break;
    case MSIM_OBSTACLE_SPHERE: PetscCall(PetscViewerASCIIPrintf(viewer, "  obstacle %d: sphere centre (%g, %g, %g), radius %g\n", (int)k, (double)p[0], (double)p[1], (double)p[2], (double)p[3])); break;
    case MSIM_OBSTACLE_BOX: PetscCall(PetscViewerASCIIPrintf(viewer, "  obstacle %d: box [%g, %g] x [%g, %g] x [%g, %g]\n", (int)k, (double)p[0], (double)p[1], (double)p[2], (double)p[3], (double)p[4], (double)p[5])); break;
    }
    const PetscReal *v = ct->obs[k].v;
    if (v[0] != 0 || v[1] != 0 || v[2] != 0) PetscCall(PetscViewerASCIIPrintf(viewer, "    moving with velocity (%g, %g, %g) m/s\n", (double)v[0], (double)v[1], (double)v[2]));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* one array option: every group of `per` values an obstacle, each checked */
static PetscErrorCode ReadObstacles(PetscOptionItems *PetscOptionsObject, MSimSystem sys, MSimContact ct, MSimObstacleKind kind, const char help[])
{
  const int   per = kind == MSIM_OBSTACLE_BOX ? 6 : 4, nmax = 6 * 64;
  PetscReal   v[6 * 64];
  PetscInt    n = nmax;
  PetscBool   set;
  const char *name = KindOption(kind);

  PetscFunctionBeginUser;
  PetscCall(MSimOptionsRealArray(name, help, NULL, v, &n, &set));
  if (!set) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(n < nmax, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "%s: at most %d obstacles per option", name, nmax / per - 1);
  PetscCheck(n > 0 && n % per == 0, sys->comm, PETSC_ERR_ARG_WRONG, "%s takes %d values per obstacle (%s); got %d", name, per, kind == MSIM_OBSTACLE_PLANE ? "nx,ny,nz,d" : (kind == MSIM_OBSTACLE_SPHERE ? "cx,cy,cz,r" : "x0,x1,y0,y1,z0,z1"), (int)n);
  for (PetscInt k = 0; k < n / per; k++) {
    MSimObstacle o = {};
    o.kind         = kind;
    for (int c = 0; c < per; c++) o.p[c] = v[per * k + c];
    if (kind == MSIM_OBSTACLE_PLANE) {
      /* scaled first by the power of 2 nearest the largest component: the squares of 1e300
         overflowed (the normal became 0, every vertex on the plane) and those of 1e-200
         underflowed (refused as "a zero normal"); a power of 2 scales exactly, so a normal that
         did not overflow is normalised to the same bits as before */
      const PetscReal big = PetscMax(PetscAbsReal(o.p[0]), PetscMax(PetscAbsReal(o.p[1]), PetscAbsReal(o.p[2])));
      int             e;
      PetscCheck(big > 0, sys->comm, PETSC_ERR_ARG_WRONG, "%s: obstacle %d has a zero normal", name, (int)k);
      (void)std::frexp(big, &e);
      for (int c = 0; c < 4; c++) o.p[c] = std::ldexp(o.p[c], -e);
      const PetscReal len = std::sqrt(o.p[0] * o.p[0] + o.p[1] * o.p[1] + o.p[2] * o.p[2]);
      for (int c = 0; c < 4; c++) o.p[c] /= len; /* n.x >= d keeps its meaning with n normalised */
      PetscCheck(std::isfinite(o.p[3]), sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "%s: obstacle %d's offset %g over its normal's length %g overflows", name, (int)k, (double)v[per * k + 3], (double)std::ldexp(len, e));
    } else if (kind == MSIM_OBSTACLE_SPHERE) {
      PetscCheck(o.p[3] > 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "%s: obstacle %d has radius %g; it must be > 0", name, (int)k, (double)o.p[3]);
    } else {
      for (int c = 0; c < 3; c++) PetscCheck(o.p[2 * c] < o.p[2 * c + 1], sys->comm, PETSC_ERR_ARG_WRONG, "%s: obstacle %d is empty (%c0 = %g is not below %c1 = %g)", name, (int)k, "xyz"[c], (double)o.p[2 * c], "xyz"[c], (double)o.p[2 * c + 1]);
    }
    ct->obs.push_back(o);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* kc's default: the largest rest row sum of spring stiffnesses over free vertices */
static PetscErrorCode DefaultPenalty(MSimSystem sys, PetscReal *kc)
{
  const PetscScalar *f;
  PetscReal          best = 0;
  Vec                ksum;
  PetscScalar       *fl;

  PetscFunctionBeginUser;
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArray(sys->floc, &fl));
  MSimSpringsForEach(sys->springs, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal) {
    fl[3 * i] += k;
    fl[3 * j] += k;
  });
  PetscCall(VecRestoreArray(sys->floc, &fl));
  PetscCall(VecDuplicate(sys->mass, &ksum));
  PetscCall(VecZeroEntries(ksum));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, ksum));
  PetscCall(VecGetArrayRead(ksum, &f));
  for (PetscInt v = 0; v < sys->nown; v++) best = PetscMax(best, PetscRealPart(f[3 * v]));
  PetscCall(VecRestoreArrayRead(ksum, &f));
  PetscCall(VecDestroy(&ksum));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &best, 1, MPIU_REAL, MPIU_MAX, sys->comm));
  *kc = best > 0 ? best : 1.0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The refusal of the first flagged vertex in input order, whatever the rank count: flag (the
   free layout) holds per vertex 3 entries, the first non-zero where it is flagged; the message is
   made from the vertex's input id and its entries by the rank that holds it in the natural
   layout, and raised on every rank. Collective; flag is overwritten. */
static PetscErrorCode RefuseFirstFlagged(MSimSystem sys, Vec flag, const std::function<PetscErrorCode(PetscInt, const PetscScalar *, char *, size_t)> &message)
{
  const PetscScalar *nat;
  PetscInt           lo, hi, first = PETSC_MAX_INT;
  char               msg[768] = "";

  PetscFunctionBeginUser;
  PetscCall(MSimSystemNaturalVector(sys, flag));
  PetscCall(VecGetOwnershipRange(sys->natural, &lo, &hi));
  PetscCall(VecGetArrayRead(sys->natural, &nat));
  for (PetscInt i = 0; i < (hi - lo) / 3 && first == PETSC_MAX_INT; i++)
    if (PetscRealPart(nat[3 * i]) != 0) {
      const PetscInt id = lo / 3 + i, fid = sys->nat_file_id.empty() ? id : sys->nat_file_id[i];
      first = id;
      PetscCall(message(fid >= 0 ? fid : id, nat + 3 * i, msg, sizeof(msg)));
    }
  PetscCall(VecRestoreArrayRead(sys->natural, &nat));
  PetscInt gfirst = first;
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &gfirst, 1, MPIU_INT, MPI_MIN, sys->comm));
  PetscCall(MSimCollectiveCheck(sys->comm, (PetscBool)(first != gfirst), msg));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* every free vertex at X (time t) outside every obstacle of obs (outside the shell of a mesh);
   for the barrier, by more than a millionth of dhat: nearer, its force at the start is beyond any
   step's scale (a vertex 2e-16 from a box gave a first step with 2.5e9 N and |g| 3e5, accepted on
   the step norm); else on it (d = 0) is allowed: VI bounds rest there. A box's -0 (a vertex on
   its surface) is on it, named 0: the barrier named a vertex on a box's edge "inside (distance
   -0.)", which the penalty accepted as on it. The first offender named by
   its input id (the id users type, whatever the rank count) and the obstacle. The meshes answer as
   set (CheckState sets them to answer in full). near, where given, says whether some vertex is
   within the barrier's margin (on every rank), so that the barrier's check need not query again. */
static PetscErrorCode CheckVertices(MSimContact ct, const std::vector<MSimObstacle> &obs, PetscBool barrier, PetscReal t, Vec X, const char *when, PetscBool *near = NULL)
{
  MSimSystem         sys = ct->sys;
  const PetscScalar *x;
  PetscScalar       *f;
  PetscInt           counts[2] = {0, 0};
  const PetscReal    tol       = 1e-6 * ct->dhat;
  Vec                flag;
  PetscErrorCode     ierr;

  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(X, &flag));
  PetscCall(VecZeroEntries(flag));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArray(flag, &f));
  for (PetscInt v = 0; v < sys->nown; v++)
    for (size_t k = 0; k < obs.size(); k++) {
      PetscReal       n[3];
      const PetscReal dk = MSimObstacleDistanceAt(&obs[k], t, x + 3 * v, n, NULL), d = dk == 0 ? 0.0 : dk; /* -0 as 0 */
      if ((barrier ? d <= tol : d < 0) && f[3 * v] == 0) {
        f[3 * v] = (PetscScalar)(k + 1), f[3 * v + 1] = d;
        counts[0]++;
      }
      if (d <= tol) counts[1]++;
    }
  PetscCall(VecRestoreArray(flag, &f));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, counts, 2, MPIU_INT, MPI_SUM, sys->comm));
  if (near) *near = (PetscBool)(counts[1] > 0);
  ierr = counts[0] ? RefuseFirstFlagged(sys, flag, [&](PetscInt id, const PetscScalar *e, char *buf, size_t len) -> PetscErrorCode {
    const PetscInt  k = (PetscInt)(PetscRealPart(e[0]) + 0.5) - 1;
    const PetscReal d = PetscRealPart(e[1]);
    if (d < 0) PetscCall(PetscSNPrintf(buf, len, "vertex %d %s inside obstacle %d (%s, distance %g): move the scene or the obstacle", (int)id, when, (int)k, KindOption(obs[k].kind), (double)d));
    else PetscCall(PetscSNPrintf(buf, len, "vertex %d %s at distance %g from obstacle %d (%s), below 1e-6 of the contact distance %g: move the scene or the obstacle", (int)id, when, (double)d, (int)k, KindOption(obs[k].kind), (double)ct->dhat));
    return PETSC_SUCCESS;
  })
                   : PETSC_SUCCESS;
  PetscCall(VecDestroy(&flag));
  PetscCall(ierr);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactRefuseSqueezed(MSimContact ct, PetscReal tx, const std::vector<MSimSqueezed> &squeezed)
{
  MSimSystem     sys = ct->sys;
  PetscInt       any = !squeezed.empty();
  PetscScalar   *f;
  Vec            flag;
  PetscErrorCode ierr;

  PetscFunctionBeginUser;
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &any, 1, MPIU_INT, MPI_MAX, sys->comm));
  if (!any) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecDuplicate(sys->X0, &flag));
  PetscCall(VecZeroEntries(flag));
  PetscCall(VecGetArray(flag, &f));
  for (const MSimSqueezed &q : squeezed) f[3 * q.v] = (PetscScalar)(q.inside + 1), f[3 * q.v + 1] = (PetscScalar)(q.carrier + 1);
  PetscCall(VecRestoreArray(flag, &f));
  ierr = RefuseFirstFlagged(sys, flag, [&](PetscInt id, const PetscScalar *e, char *buf, size_t len) -> PetscErrorCode {
    const PetscInt k = (PetscInt)(PetscRealPart(e[0]) + 0.5) - 1, c = (PetscInt)(PetscRealPart(e[1]) + 0.5) - 1;
    /* carried by none: only the moving obstacles carry, one that reaches a vertex always does
       (FeasibleStart_Obstacles), and a static one is where it was, so the vertex was on or inside
       obstacle k at the step's start already; no obstacle squeezed or pushed it */
    if (c < 0) PetscCall(PetscSNPrintf(buf, len, "vertex %d is on or inside obstacle %d (%s) at t = %g s though no moving obstacle carried it: it was there at the step's start already", (int)id, (int)k, KindOption(ct->obs[k].kind), (double)tx));
    /* carried by the obstacle it ends in: it keeps its distance, so it is inside by roundoff */
    else if (c == k) PetscCall(PetscSNPrintf(buf, len, "vertex %d, pushed by the moving obstacle %d (%s), is inside it at t = %g s: no position outside it (a smaller -msim_dt)", (int)id, (int)k, KindOption(ct->obs[k].kind), (double)tx));
    /* the carry keeps the vertex's distance to its carrier whatever the step, so a smaller step
       does not help where the two come that near */
    else PetscCall(PetscSNPrintf(buf, len, "vertex %d is squeezed between obstacles %d (%s), which carries it, and %d (%s) at t = %g s: they come within its distance to the first, so no position is outside both, whatever the step: move them apart or change their -msim_contact_velocity", (int)id, (int)c, KindOption(ct->obs[c].kind), (int)k, KindOption(ct->obs[k].kind), (double)tx));
    return PETSC_SUCCESS;
  });
  PetscCall(VecDestroy(&flag));
  PetscCall(ierr);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* CheckVertices with the meshes answering in full (no band), so that a vertex deep inside one is
   found too; then back to the band the barrier's queries take (where it reaches) */
static PetscErrorCode CheckState(MSimContact ct, std::vector<MSimObstacle> &obs, PetscBool barrier, PetscReal t, Vec X, const char *when, PetscBool *near = NULL)
{
  PetscFunctionBeginUser;
  for (MSimObstacle &o : obs)
    if (o.mesh) MSimMeshObstacleSetBand(o.mesh, PETSC_MAX_REAL);
  PetscCall(CheckVertices(ct, obs, barrier, t, X, when, near));
  for (MSimObstacle &o : obs)
    if (o.mesh) MSimMeshObstacleSetBand(o.mesh, ct->thickness + ct->dhat);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the system's contact object whatever it holds (MSimContactGet gives NULL once it holds no
   obstacle for the barrier), or NULL before MSimContactGet made it */
static PetscErrorCode Query(MSimSystem sys, MSimContact *ct)
{
  PetscContainer container;

  PetscFunctionBeginUser;
  *ct = NULL;
  PetscCall(PetscObjectQuery((PetscObject)sys->X0, "MSimContact", (PetscObject *)&container));
  if (container) PetscCall(PetscContainerGetPointer(container, (void **)ct));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactCheckRestart(MSimSystem sys, PetscReal t, Vec X, PetscBool barrier)
{
  MSimContact ct;
  char        when[64];

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct)); /* made here if nothing made it yet */
  PetscCall(Query(sys, &ct));
  PetscCall(PetscSNPrintf(when, sizeof(when), "is at the restart (t = %g s)", (double)t));
  /* VI bounds hold every obstacle or none; their runs rest on a bound at d = 0 exactly (the step
     ends projected onto it), never inside */
  if (!ct->bounds.empty()) PetscCall(CheckState(ct, ct->bounds, PETSC_FALSE, t, X, when));
  else if (barrier) PetscCall(CheckState(ct, ct->obs, PETSC_TRUE, t, X, when)); /* not a penalty's: its vertices sink m g / kc into an obstacle at rest */
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactCheckBarrierStart(MSimSystem sys)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  /* the start's check already knows whether any vertex is that near: query again (meshes in
     full, a pass as dear as the set-up's) only to name it */
  if (ct && ct->start_near) PetscCall(CheckState(ct, ct->obs, PETSC_TRUE, 0.0, sys->X0, "starts"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the obstacles as -msim_scene_view numbers them: all in the barrier's list, or all in the VI
   bounds' (which took every one of them, contact_bounds.cpp) */
static const std::vector<MSimObstacle> &Obstacles(MSimContact ct)
{
  return ct->obs.empty() ? ct->bounds : ct->obs;
}

PetscErrorCode MSimContactWatchHandles(MSimSystem sys, PetscInt step, PetscReal t0, PetscReal t1)
{
  const PetscReal *w = sys->fix_velocity;
  MSimContact      ct;

  PetscFunctionBeginUser;
  PetscCall(Query(sys, &ct));
  /* the first entry on this rank is known once seen: the later steps' come after it */
  if (!ct || ct->handle_step >= 0 || sys->nat_fixed.empty() || (w[0] == 0 && w[1] == 0 && w[2] == 0 && !ct->moving)) PetscFunctionReturn(PETSC_SUCCESS);
  const std::vector<MSimObstacle> &obs = Obstacles(ct);
  /* the block's fixed vertices, each held by one rank (the natural layout's), at b0 + t w */
  for (size_t f = 0; f < sys->nat_fixed.size(); f++) {
    PetscReal x0[3], x1[3], n[3];
    for (int c = 0; c < 3; c++) {
      x0[c] = sys->nat_b0[3 * f + c] + t0 * w[c];
      x1[c] = sys->nat_b0[3 * f + c] + t1 * w[c];
    }
    for (size_t k = 0; k < obs.size(); k++)
      if (MSimObstacleDistanceAt(&obs[k], t1, x1, n, NULL) < 0 && MSimObstacleDistanceAt(&obs[k], t0, x0, n, NULL) >= 0) {
        const PetscInt v  = sys->nat_fixed[f];
        ct->handle_step     = step;
        ct->handle_id       = sys->nat_file_id.empty() || sys->nat_file_id[v] < 0 ? sys->dir.Start(sys->rank) + v : sys->nat_file_id[v];
        ct->handle_obstacle = (PetscInt)k;
        PetscFunctionReturn(PETSC_SUCCESS);
      }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactWarnHandles(MSimSystem sys)
{
  MSimContact           ct;
  std::vector<PetscInt> all(3 * sys->size);

  PetscFunctionBeginUser;
  PetscCall(Query(sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscInt mine[3] = {ct->handle_step, ct->handle_id, ct->handle_obstacle};
  PetscCallMPI(MPI_Allgather(mine, 3, MPIU_INT, all.data(), 3, MPIU_INT, sys->comm));
  PetscInt first = -1; /* the rank whose entry came first (the least step, then the least rank) */
  for (PetscMPIInt r = 0; r < sys->size; r++)
    if (all[3 * r] >= 0 && (first < 0 || all[3 * r] < all[3 * first])) first = r;
  if (first < 0) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscInt k = all[3 * first + 2];
  PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: fixed vertex %" PetscInt_FMT " enters obstacle %" PetscInt_FMT " (%s) at step %" PetscInt_FMT ": obstacles do not act on prescribed vertices, so it goes on along its path inside the obstacle\n", all[3 * first + 1], k,
                         KindOption(Obstacles(ct)[k].kind), all[3 * first]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactObstacleSpeed(MSimSystem sys, PetscReal *speed)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  *speed = 0;
  PetscCall(MSimContactGet(sys, &ct));
  if (ct)
    for (const MSimObstacle &o : ct->obs) *speed = PetscMax(*speed, PetscSqrtReal(o.v[0] * o.v[0] + o.v[1] * o.v[1] + o.v[2] * o.v[2]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Options set that act nowhere in this run, each refused in one line, "NAME WHY": read, PETSc
   counts them used, so the unused-option warning never named them */
static PetscErrorCode RefuseSet(MPI_Comm comm, size_t n, const char *const names[], const char why[])
{
  PetscFunctionBeginUser;
  for (size_t k = 0; k < n; k++) {
    PetscBool set;
    PetscCall(PetscOptionsHasName(NULL, NULL, names[k], &set));
    PetscCheck(!set, comm, PETSC_ERR_ARG_WRONG, "%s %s", names[k], why);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the implicit integrators' barrier and its PD and Newton weights (obstacles.cpp, pd_steps.cpp) */
static const char *const barrier_options[] = {"-msim_contact_kappa", "-msim_contact_pd_weight", "-msim_contact_pd_refactor", "-msim_contact_pd_refactor_selective", "-msim_contact_pd_bound", "-msim_contact_pc_pd_weight", "-msim_contact_psd_curvature"};

PetscErrorCode MSimContactRefuseUnread(MSimSystem sys, const char type[])
{
  MSimContact ct;
  PetscBool   barrier;
  char        why[256];

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  PetscCall(Query(sys, &ct)); /* also where VI bounds took every obstacle (MSimContactGet gives NULL then) */
  if (!ct || (ct->obs.empty() && ct->bounds.empty())) PetscFunctionReturn(PETSC_SUCCESS); /* MSimContactGet refused them */
  PetscCall(MSimImplicitSchemeIsRegistered(type, &barrier));
  if (!barrier) {
    PetscCall(PetscSNPrintf(why, sizeof(why), "with -msim_integrator %s is not supported: it tunes the barrier of implicit_euler and bdf2, and this integrator's contact is a penalty (-msim_contact_stiffness)", type));
    PetscCall(RefuseSet(sys->comm, PETSC_STATIC_ARRAY_LENGTH(barrier_options), barrier_options, why));
    if (sys->scene_view) PetscCall(PetscPrintf(sys->comm, "contact: penalty kc %g N/m per vertex and obstacle (-msim_integrator %s)\n", (double)ct->kc, type));
  } else {
    static const char *const penalty[] = {"-msim_contact_stiffness"};
    PetscCall(PetscSNPrintf(why, sizeof(why), "with -msim_integrator %s is not supported: it is the penalty's stiffness (the explicit integrators and ts); the barrier's is -msim_contact_kappa", type));
    PetscCall(RefuseSet(sys->comm, 1, penalty, why));
    /* VI bounds take every obstacle or refuse (contact_bounds.cpp): no barrier is left */
    if (!ct->bounds.empty()) PetscCall(RefuseSet(sys->comm, PETSC_STATIC_ARRAY_LENGTH(barrier_options), barrier_options, "with obstacles as variable bounds (-msim_contact_bounds, or a VI -snes_type) is not supported: it tunes the barrier, which the bounds replace"));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactGet(MSimSystem sys, MSimContact *contact)
{
  PetscContainer container;
  MSimContact    ct;

  PetscFunctionBeginUser;
  PetscCall(Query(sys, &ct));
  if (ct) {
    *contact = ct->obs.empty() ? NULL : ct;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  ct        = new _n_MSimContact();
  ct->sys   = sys;
  ct->dhat  = 1e-2 * PetscMax(sys->diameter, PETSC_SMALL);
  ct->mu    = 0;
  ct->kappa = 0;
  ct->h2_checked = 0;
  ct->kc    = 0;
  ct->eps_v = 1e-3 * PetscMax(sys->diameter, PETSC_SMALL);
  ct->thickness = 0;
  ct->moving    = PETSC_FALSE;
  ct->pd_weight  = PETSC_TRUE;
  ct->fr_xn      = NULL;
  ct->fr_t = ct->fr_tx = ct->fr_h = 0;
  ct->psd_curvature = PETSC_TRUE;
  ct->pd_refactor_selective = 128; /* msimllt's -pc_msimllt_update_max_rank: more rows than this refactor anyway (runs/contact/README.md, eighth session) */
  ct->pd_refactor    = 4; /* runs/contact/README.md: 21 -> 7 factorizations on the 101 x 101 drape, the same monitor */
  ct->pc_pd_weight   = PETSC_FALSE;
  ct->pd_bound       = PETSC_TRUE;
  PetscCall(PetscContainerCreate(PETSC_COMM_SELF, &container));
  PetscCall(PetscContainerSetPointer(container, ct));
  PetscCall(PetscContainerSetUserDestroy(container, ContactDestroy));
  PetscCall(PetscObjectCompose((PetscObject)sys->X0, "MSimContact", (PetscObject)container));
  PetscCall(PetscContainerDestroy(&container));
  PetscOptionsBegin(sys->comm, NULL, "msim contact with obstacles", NULL);
  PetscCall(ReadObstacles(PetscOptionsObject, sys, ct, MSIM_OBSTACLE_PLANE, "Half-spaces n.x >= d the free vertices stay in, 4 values each: nx,ny,nz,d (n normalised here)"));
  PetscCall(ReadObstacles(PetscOptionsObject, sys, ct, MSIM_OBSTACLE_SPHERE, "Solid spheres, 4 values each: cx,cy,cz,r"));
  PetscCall(ReadObstacles(PetscOptionsObject, sys, ct, MSIM_OBSTACLE_BOX, "Solid axis-aligned boxes, 6 values each: x0,x1,y0,y1,z0,z1"));
  PetscCall(MSimOptionsReal("-msim_contact_thickness", "Mesh obstacles: the cloth keeps this far from the surface (outside a closed one, either side of an open one)", NULL, ct->thickness, &ct->thickness, NULL));
  {
    /* one slot more than the files taken: PETSc drops the values beyond the array silently, so a
       full array means that some file was left out */
    char     *files[65];
    PetscInt  nfile = 65;
    PetscBool set;
    PetscCall(PetscOptionsStringArray("-msim_contact_mesh", "Static triangle surfaces (OBJ/OFF/STL, comma-separated files): closed ones keep the cloth outside, open ones on either side (the penalty of the explicit integrators and ts: only with a thickness > 0), at -msim_contact_thickness", NULL, files, &nfile, &set));
    /* PETSc leaves the option unset, silently, when it is given without a value */
    PetscBool named;
    PetscCall(PetscOptionsHasName(PetscOptionsObject->options, PetscOptionsObject->prefix, "-msim_contact_mesh", &named));
    PetscCheck(set || !named, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_contact_mesh needs a value (comma-separated files)");
    if (!set) nfile = 0;
    const PetscBool too_many = (PetscBool)(nfile == 65);
    PetscErrorCode  ierr     = PETSC_SUCCESS;
    for (PetscInt k = 0; k < nfile; k++) {
      MSimObstacle o = {};
      o.kind         = MSIM_OBSTACLE_MESH;
      if (!ierr && !too_many && ct->thickness >= 0) ierr = MSimMeshObstacleCreate(sys->comm, files[k], ct->thickness, &o.mesh);
      if (!ierr && o.mesh) ct->obs.push_back(o);
      PetscCall(PetscFree(files[k]));
    }
    PetscCheck(ct->thickness >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_thickness must be >= 0 (got %g)", (double)ct->thickness);
    PetscCheck(!too_many, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_mesh: at most 64 files");
    PetscCall(ierr);
  }
  {
    /* one value more than the obstacles take (PETSc drops the rest silently): a full array is too
       long a list, whatever the number of obstacles */
    std::vector<PetscReal> v(3 * ct->obs.size() + 1, 0.0);
    PetscInt               nv = (PetscInt)v.size();
    PetscBool              set;
    PetscCall(MSimOptionsRealArray("-msim_contact_velocity", "Obstacles' constant velocities, m/s: one vx,vy,vz per obstacle in -msim_scene_view's order (planes, spheres, boxes, meshes, each as given); default static. A travel in a step |v| s of at most dhat / sqrt(eps): s = sqrt(beta) h for the implicit integrators, h for the explicit ones and ts", NULL, v.data(), &nv, &set));
    if (set) {
      PetscCheck(nv == 3 * (PetscInt)ct->obs.size(), sys->comm, PETSC_ERR_ARG_WRONG, "-msim_contact_velocity takes one vx,vy,vz per obstacle (%d obstacles: %d values); got %s%d values", (int)ct->obs.size(), 3 * (int)ct->obs.size(), nv == (PetscInt)v.size() ? "more than " : "", (int)(nv == (PetscInt)v.size() ? nv - 1 : nv));
      for (size_t k = 0; k < ct->obs.size(); k++)
        for (int c = 0; c < 3; c++) {
          ct->obs[k].v[c] = v[3 * k + c];
          if (v[3 * k + c] != 0) ct->moving = PETSC_TRUE;
        }
    }
  }
  PetscCall(MSimOptionsReal("-msim_contact_distance", "Contact distance dhat: the barrier (implicit) acts below it (default 1e-2 of the scene's diameter; at least sqrt(eps) times the largest start coordinate)", NULL, ct->dhat, &ct->dhat, NULL));
  PetscCall(MSimOptionsReal("-msim_contact_kappa", "Barrier stiffness per unit mass, 1/s^2 (0: 1/(beta h^2 b''(dhat/2)), the barrier as stiff as the mass at dhat/2; else within eps to 1/eps times that)", NULL, ct->kappa, &ct->kappa, NULL));
  PetscCall(MSimOptionsReal("-msim_contact_stiffness", "Penalty stiffness kc of the explicit integrators and -msim_integrator ts, N/m per vertex (0: the largest sum of spring stiffnesses at a free vertex)", NULL, ct->kc, &ct->kc, NULL));
  PetscCall(PetscOptionsBool("-msim_contact_pd_weight", "PD: each vertex within dhat of an obstacle gets the barrier's stiffness beta h^2 kappa m b''(d) on A's diagonal (A refactored per -msim_contact_pd_refactor); 0: the barrier's force in the right-hand side only", NULL, ct->pd_weight, &ct->pd_weight, NULL));
  PetscCall(MSimOptionsReal("-msim_contact_pd_refactor", "PD with -msim_contact_pd_weight: keep the factor until some vertex's wanted diagonal (A's plus the barrier's weight, taken once per step) is off the factored one by more than this factor; 0: refactor whenever the set of vertices within dhat changes", NULL, ct->pd_refactor, &ct->pd_refactor, NULL));
  PetscCall(PetscOptionsBool("-msim_contact_pd_bound", "PD: take the global step's length from a bound on Phi that needs only the contact terms' change (no pass over the springs); 0: halve until Phi, evaluated in full, does not rise", NULL, ct->pd_bound, &ct->pd_bound, NULL));
  PetscCall(MSimOptionsInt("-msim_contact_pd_refactor_selective", "PD with -msim_contact_pd_refactor r > 0: when some vertex's weight is off by more than r, only the vertices off by more than sqrt(r) take their current weight (the others keep the factored one, so msimllt can update its factor instead of refactoring), while at most this many vertices change; more: every vertex takes its weight. 0: every vertex always", NULL, ct->pd_refactor_selective, &ct->pd_refactor_selective, NULL));
  PetscCall(PetscOptionsBool("-msim_contact_pc_pd_weight", "Newton with -msim_pc_pd: the PD factor preconditioning CG includes the barrier's weights (taken at every Jacobian, refactored by -msim_contact_pd_refactor's rule or where the set of vertices within dhat changes)", NULL, ct->pc_pd_weight, &ct->pc_pd_weight, NULL));
  PetscCall(PetscOptionsBool("-msim_contact_psd_curvature", "PSD Newton: keep the barrier's curvature term b'(d) D^2 d (negative semidefinite) scaled so that the vertex's inertia plus it stays >= m/2; 0: drop it", NULL, ct->psd_curvature, &ct->psd_curvature, NULL));
  PetscCall(MSimOptionsReal("-msim_friction", "Coulomb friction coefficient mu with the obstacles and, with -msim_self_contact, between surfaces in self-contact (implicit_euler, bdf2: IPC's lagged smoothed friction; the penalty of the explicit integrators and ts has none, and refuses it; obstacles as variable bounds, -msim_contact_bounds, have none; at most 1/sqrt(eps))", NULL, ct->mu, &ct->mu, NULL));
  PetscCall(MSimOptionsReal("-msim_friction_eps", "Friction's smoothing (IPC's): tangential speed (m/s) below which the friction force grows linearly with the speed instead of being mu times the normal force, so a load below the static limit creeps at a fraction of it (default 1e-3 of the scene's diameter per second; at least sqrt(eps) times the largest start coordinate over sqrt(beta) h)", NULL, ct->eps_v, &ct->eps_v, NULL));
  PetscOptionsEnd();
  PetscCheck(ct->dhat > 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_distance must be > 0 (got %g)", (double)ct->dhat);
  PetscCheck(ct->kappa >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_kappa must be >= 0 (got %g)", (double)ct->kappa);
  PetscCheck(ct->kc >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_stiffness must be >= 0 (got %g)", (double)ct->kc);
  /* a coefficient above 1/sqrt(eps) holds any load a larger one holds, and its products with the
     normal forces over friction's smoothing overflow (-msim_friction 1e300: DIVERGED_FNORM_NAN at
     step 5 of a drape, the frames written; 1e15: DIVERGED_LINEAR_SOLVE; 1e8 runs) */
  PetscCheck(ct->mu >= 0 && ct->mu <= 1 / PETSC_SQRT_MACHINE_EPSILON, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_friction must be in [0, %g] (1/sqrt(eps); got %g)", (double)(1 / PETSC_SQRT_MACHINE_EPSILON), (double)ct->mu);
  PetscCheck(ct->pd_refactor == 0 || ct->pd_refactor >= 1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_pd_refactor must be 0 or >= 1 (got %g)", (double)ct->pd_refactor);
  PetscCheck(ct->pd_refactor_selective >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_pd_refactor_selective must be >= 0 (got %" PetscInt_FMT ")", ct->pd_refactor_selective);
  PetscCheck(ct->eps_v > 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_friction_eps must be > 0 (got %g)", (double)ct->eps_v);
  /* a coefficient or a thickness that would act nowhere is refused, not dropped (the penalty and
     the VI bounds refuse friction likewise) */
  {
    PetscBool mesh = PETSC_FALSE;
    for (const MSimObstacle &o : ct->obs) mesh = (PetscBool)(mesh || o.kind == MSIM_OBSTACLE_MESH);
    PetscCheck(ct->thickness == 0 || mesh, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_contact_thickness %g acts on mesh obstacles (-msim_contact_mesh) only, and there is none", (double)ct->thickness);
  }
  PetscCheck(ct->mu == 0 || !ct->obs.empty() || sys->self_contact.on, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_friction %g acts on nothing: friction is with obstacles (-msim_contact_plane, _sphere, _box, _mesh) or between surfaces in self-contact (-msim_self_contact), and there are neither", (double)ct->mu);
  {
    /* the rest act only with an obstacle, and friction's smoothing only with friction (given as 0
       it turns off what an options file set up, smoothing with it) */
    static const char *const with_obstacle[] = {"-msim_contact_distance", "-msim_contact_stiffness"};
    static const char *const smoothing[]     = {"-msim_friction_eps"};
    const char              *why             = "has no effect without an obstacle (-msim_contact_plane, _sphere, _box or _mesh)";
    PetscBool                eps_set;
    if (ct->obs.empty()) {
      PetscCall(RefuseSet(sys->comm, PETSC_STATIC_ARRAY_LENGTH(with_obstacle), with_obstacle, why));
      PetscCall(RefuseSet(sys->comm, PETSC_STATIC_ARRAY_LENGTH(barrier_options), barrier_options, why));
    }
    PetscCall(PetscOptionsHasName(NULL, NULL, smoothing[0], &eps_set));
    PetscCall(MSimOptionsRefuseWithout(sys->comm, "-msim_friction", 1, smoothing, &eps_set));
  }
  *contact = NULL;
  if (ct->obs.empty()) PetscFunctionReturn(PETSC_SUCCESS);
  {
    /* A contact distance below sqrt(eps) of the coordinates is lost in their roundoff: the
       barrier's distances, differences of coordinates, are off by eps |x|, over 1e-8 of such a
       dhat, and its energy's changes drown in Phi's roundoff (-msim_contact_distance 1e-9 on a
       1 m drape: steps stalled, then "diverged at step 17", the frames written) */
    PetscReal xmax;
    PetscCall(VecNorm(sys->X0, NORM_INFINITY, &xmax));
    PetscCheck(ct->dhat >= PETSC_SQRT_MACHINE_EPSILON * xmax, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_distance must be >= %g m here, sqrt(eps) times the largest start coordinate %g m, below which distances are lost in the coordinates' roundoff (got %g)", (double)(PETSC_SQRT_MACHINE_EPSILON * xmax), (double)xmax, (double)ct->dhat);
  }
  if (ct->kc == 0) PetscCall(DefaultPenalty(sys, &ct->kc));
  /* inside refused here, whatever takes the obstacles; the barrier's margin once it is known to be
     the barrier (MSimContactCheckBarrierStart): a penalty or VI bounds start on an obstacle well */
  PetscCall(CheckState(ct, ct->obs, PETSC_FALSE, 0.0, sys->X0, "starts", &ct->start_near));
  /* -msim_scene_view is the scene's option; the system carries it here */
  if (sys->scene_view) PetscCall(MSimContactView(ct, PETSC_VIEWER_STDOUT_(sys->comm)));
  *contact = ct;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactAddPenaltyForce(MSimSystem sys, PetscReal t, Vec X, Vec F)
{
  MSimContact        ct;
  const PetscScalar *x;
  PetscScalar       *f;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArray(F, &f));
  MSimContactForEachNear(ct, sys->nown, x, t, 0.0, PETSC_FALSE, [&](PetscInt v, const MSimObstacle &, PetscReal d, const PetscReal *n, const PetscReal *) {
    for (int c = 0; c < 3; c++) f[3 * v + c] += -ct->kc * d * n[c];
  });
  PetscCall(VecRestoreArray(F, &f));
  PetscCall(VecRestoreArrayRead(X, &x));
  /* a shell whose side some vertex lost (it entered the shell from farther than dhat in one
     query, mesh_obstacle.cpp's ShellSide) cannot be held: the run stops rather than let the cloth
     pass through. The first loss is noted here, with no communication (a reduction per force
     evaluation cost a collective per stage); the step's energy reduction says it
     (MSimContactCheckShellSides) */
  for (size_t k = 0; k < ct->obs.size() && ct->side_lost.empty(); k++) {
    PetscBool lost;
    PetscReal p[3];
    if (ct->obs[k].kind != MSIM_OBSTACLE_MESH || !MSimMeshObstacleKeepsSides(ct->obs[k].mesh, &lost, p) || !lost) continue;
    const char *file;
    char        msg[512];
    MSimMeshObstacleInfo(ct->obs[k].mesh, &file, NULL, NULL);
    PetscCall(PetscSNPrintf(msg, sizeof(msg), "a vertex entered the shell of obstacle %d (-msim_contact_mesh %s, thickness %g) at (%g, %g, %g), t = %g s, from farther than the contact distance %g in one step, so the penalty cannot tell which side it came from: reduce -msim_dt or raise -msim_contact_distance", (int)k, file, (double)ct->thickness, (double)p[0], (double)p[1], (double)p[2], (double)t, (double)ct->dhat));
    ct->side_lost = msg;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactShellSideLost(MSimSystem sys, PetscBool *lost)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Query(sys, &ct));
  *lost = (PetscBool)(ct && !ct->side_lost.empty());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactCheckShellSides(MSimSystem sys)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  PetscCall(Query(sys, &ct));
  PetscCall(MSimCollectiveCheck(sys->comm, (PetscBool)(!ct || ct->side_lost.empty()), ct ? ct->side_lost : std::string()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactAddPenaltyStiffness(MSimSystem sys, PetscReal t, Vec X, Mat K)
{
  MSimContact        ct;
  const PetscScalar *x;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(X, &x));
  for (PetscInt v = 0; v < sys->nown; v++) {
    PetscScalar blk[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    PetscInt    idx[3];
    for (const MSimObstacle &o : ct->obs) {
      PetscReal n[3];
      (void)MSimObstacleDistanceAt(&o, t, x + 3 * v, n, NULL);
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) blk[3 * a + b] += ct->kc * n[a] * n[b];
    }
    for (int a = 0; a < 3; a++) idx[a] = 3 * (sys->rstart + v) + a;
    PetscCall(MatSetValues(K, 3, idx, 3, idx, blk, ADD_VALUES));
  }
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(MatAssemblyBegin(K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactAddPenaltyJacobian(MSimSystem sys, PetscReal t, Vec X, PetscReal w, Mat K)
{
  MSimContact        ct;
  const PetscScalar *x;
  PetscErrorCode     ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  if (!ct) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(X, &x));
  /* f = -kc d n: df/dx = -kc (n n^T + d dn/dx), dn/dx = D^2 d (0 for a plane or a box face) */
  MSimContactForEachNear(ct, sys->nown, x, t, 0.0, PETSC_TRUE, [&](PetscInt v, const MSimObstacle &, PetscReal d, const PetscReal *n, const PetscReal *H) {
    PetscScalar blk[9];
    PetscInt    idx[3];
    for (int a = 0; a < 3; a++) {
      idx[a] = 3 * (sys->rstart + v) + a;
      for (int b = 0; b < 3; b++) blk[3 * a + b] = w * ct->kc * (n[a] * n[b] + d * H[3 * a + b]);
    }
    if (!ierr) ierr = MatSetValues(K, 3, idx, 3, idx, blk, ADD_VALUES);
  });
  PetscCall(ierr);
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(MatAssemblyBegin(K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Each obstacle's travel in a step of scale s (named by `scale`), |v| s, at most dhat / sqrt(eps):
   its position x - v t has roundoff eps |v t|, past sqrt(eps) of the contact distance beyond
   that, and a speed whose travel in a step outgrows the scene that far is no input a step can
   resolve (a plane rising 1e300 m/s: NaN at step 1 of the barrier, "the state is not finite" at
   step 10 of the explicit penalty, the frames written) */
static PetscErrorCode CheckSpeeds(MSimContact ct, PetscReal s, const char scale[])
{
  PetscFunctionBeginUser;
  for (size_t k = 0; k < ct->obs.size(); k++) {
    const PetscReal *v = ct->obs[k].v, speed = std::hypot(v[0], std::hypot(v[1], v[2])); /* no overflow at 1e300 */
    PetscCheck(speed * s <= ct->dhat / PETSC_SQRT_MACHINE_EPSILON, ct->sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_velocity: obstacle %d's speed must be <= %g m/s here, a travel in a step (%s = %g s) of at most the contact distance %g over sqrt(eps), or its roundoff is past sqrt(eps) of the contact distance (got %g m/s)", (int)k, (double)(ct->dhat / PETSC_SQRT_MACHINE_EPSILON / s), scale, (double)s, (double)ct->dhat, (double)speed);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The barrier's values against the step, once per h2 (the first call is the implicit integrator's
   set-up, before any output), s = sqrt(h2) = sqrt(beta) h the step's scale kappa's default takes:
   - kappa within [eps, 1/eps] of its default 1/(h2 b''(dhat/2)): beyond, the barrier's stiffness
     at dhat/2 is past the mass's by more than the Hessian's roundoff resolves, or below it by as
     much, so that it holds a vertex only within the coordinates' roundoff (kappa 1e300, 1e18 x
     the default: the drape failed at steps 5 and 6; 1e15 x and 1e-5 x ran; 1e-300: "diverged");
   - friction's smoothing distance eps_v s at least sqrt(eps) times the largest start coordinate,
     as the contact distance is (friction_eps 1e-300 and 1e-10 m/s: DIVERGED_LINEAR_SOLVE; 1e-8 ran);
   - each obstacle's travel in a step |v| s at most dhat / sqrt(eps) (CheckSpeeds; a plane rising
     1e300 m/s gave NaN at step 1, 1e10 a stalled step). */
static PetscErrorCode CheckStep(MSimContact ct, PetscReal h2)
{
  MSimSystem      sys = ct->sys;
  const PetscReal s   = PetscSqrtReal(h2), eps = PETSC_MACHINE_EPSILON;
  PetscReal       b, db, d2b, xmax;

  PetscFunctionBeginUser;
  MSimBarrier(0.5 * ct->dhat, ct->dhat, &b, &db, &d2b);
  const PetscReal k0 = 1.0 / (h2 * d2b);
  PetscCheck(ct->kappa == 0 || (ct->kappa >= eps * k0 && ct->kappa <= k0 / eps), sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_contact_kappa must be 0 (the default) or in [%g, %g] 1/s^2 here, eps to 1/eps times the default 1/(beta h^2 b''(dhat/2)) = %g (got %g)", (double)(eps * k0), (double)(k0 / eps), (double)k0, (double)ct->kappa);
  if (ct->mu > 0) {
    PetscCall(VecNorm(sys->X0, NORM_INFINITY, &xmax));
    PetscCheck(ct->eps_v * s >= PETSC_SQRT_MACHINE_EPSILON * xmax, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_friction_eps must be >= %g m/s here: friction's smoothing distance eps_v sqrt(beta) h (sqrt(beta) h = %g s) below sqrt(eps) times the largest start coordinate %g m is lost in the coordinates' roundoff (got %g)", (double)(PETSC_SQRT_MACHINE_EPSILON * xmax / s), (double)s, (double)xmax, (double)ct->eps_v);
  }
  PetscCall(CheckSpeeds(ct, s, "sqrt(beta) h"));
  if (ct->kappa == 0) ct->kappa = k0;
  ct->h2_checked = h2;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactGetForStep(MSimSystem sys, PetscReal h2, MSimContact *ct)
{
  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, ct));
  if (*ct && (*ct)->h2_checked != h2) PetscCall(CheckStep(*ct, h2));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactCheckPenaltyStep(MSimSystem sys, const char type[], PetscReal h)
{
  MSimContact ct;
  PetscBool   barrier;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitSchemeIsRegistered(type, &barrier));
  if (barrier) PetscFunctionReturn(PETSC_SUCCESS); /* CheckStep, at the integrator's set-up */
  PetscCall(MSimContactGet(sys, &ct));
  if (ct) PetscCall(CheckSpeeds(ct, h, "h"));
  PetscFunctionReturn(PETSC_SUCCESS);
}
