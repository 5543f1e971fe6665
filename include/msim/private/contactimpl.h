/* The contact object's body, for the contact code and the terms and forces that use it (PETSc's
   include/petsc/private pattern); msim/contact.h holds the handle, the obstacles and the
   functions. Also the per-vertex loops that the implicit terms (obstacles, friction) and the
   output's contact force share, so that the force written is the one the solver applied. */
#pragma once
#include <msim/contact.h>
#include <cmath>
#include <vector>
#include <string>

struct _n_MSimContact {
  MSimSystem                sys;
  std::vector<MSimObstacle> obs;
  std::vector<MSimObstacle> bounds; /* those the VI's variable bounds took out of obs (msim/contact_bounds.h): a restart is checked against them */
  PetscReal                 dhat;  /* the barrier acts below this distance */
  PetscReal                 mu;    /* Coulomb friction coefficient */
  PetscReal                 kappa; /* barrier stiffness per unit mass (1/s^2); 0: chosen at the first step */
  PetscReal                 h2_checked; /* the beta h^2 kappa, friction's smoothing and the velocities were last checked against (MSimContactGetForStep; 0: none yet) */
  PetscReal                 kc;    /* explicit penalty stiffness, N/m per vertex */
  PetscReal                 eps_v; /* friction's static velocity threshold (m/s) */
  PetscReal                 thickness; /* mesh obstacles: the shell the cloth keeps out of */
  PetscBool                 moving;    /* some obstacle has a velocity */
  PetscBool                 start_near; /* the start's check found a vertex within the barrier's margin (1e-6 dhat): MSimContactCheckBarrierStart names it */
  PetscBool                 pd_weight; /* PD: the barrier's stiffness in the matrix (else the rhs only) */
  PetscBool                 psd_curvature; /* PSD Hessian: keep the barrier's curvature term, clamped */
  PetscReal                 pd_refactor; /* PD's contact weights: refactor when some vertex's diagonal is off the factored one by more than this factor (0: whenever the set within dhat changes) */
  PetscInt                  pd_refactor_selective; /* at such a refactorization only the vertices off by more than sqrt(r) take their current weight while at most this many do (PD's own steps; 0: every vertex always) */
  PetscBool                 pc_pd_weight; /* the PD factor as Newton's preconditioner includes the contact weights */
  PetscBool                 pd_bound; /* PD: the global step's length from the contact terms' change alone (pd_gap), no Phi pass */
  /* the first fixed vertex this rank saw enter an obstacle (MSimContactWatchHandles): the step
     (-1: none yet), its input id and the obstacle's index */
  PetscInt                  handle_step = -1, handle_id = 0, handle_obstacle = 0;
  /* the first shell side this rank lost (MSimContactAddPenaltyForce's one-line message; empty:
     none), said by MSimContactCheckShellSides */
  std::string               side_lost;
  /* friction's last step (set by its term at every evaluation, non-owning): x_n, the step's start
     and unknown's times and h, so that the output's force at the step's result includes friction;
     and the lag point its normal forces and tangent bases were taken at, with the obstacles' time
     there: x_n at t, or after lag iterations (-msim_friction_lag_iterations) the state the step's
     last solve took them at, at tx */
  Vec                       fr_xn;
  PetscReal                 fr_t, fr_tx, fr_h;
  Vec                       fr_xl = NULL;
  PetscReal                 fr_tl = 0;
};

/* kappa's default once h is known (h2 = beta h^2): the barrier as stiff as the mass at dhat/2;
   kappa, friction's smoothing and the obstacles' speeds checked against the step there */
PetscErrorCode MSimContactGetForStep(MSimSystem sys, PetscReal h2, MSimContact *ct);

/* Moving obstacles' feasible start (obstacles.cpp): the rank's vertex v, carried by obstacle
   carrier (-1: none), ends inside or passes through obstacle inside at tx */
struct MSimSqueezed {
  PetscInt v, inside, carrier;
};

/* Collective: where some rank has squeezed vertices, one error naming the first of all of them
   in input order (so the same vertex at every rank count) by its input id, and its obstacles */
PetscErrorCode MSimContactRefuseSqueezed(MSimContact ct, PetscReal tx, const std::vector<MSimSqueezed> &squeezed);

/* obstacle o's contacts with the rank's vertex v at xv (o where it is at time t): f(d, n, H) for
   each with d < reach, its distance, unit gradient and (when hessian) Hessian: the nearest point's,
   then, on a mesh, those of the concave creases v sits in (msim/contact.h's MSimMeshCreases,
   Hessian 0; at an open surface's rim corner n is grad E / b'(d) for the pair's energy E = b(d),
   not a unit vector: mesh_obstacle.cpp's RimCorner; on an open surface with an obtuse crease one
   contact, the features' sum less the nearest's, likewise: mesh_obstacle.cpp's FeatureSum).
   Returns the nearest distance, the least of them. */
template <class F>
inline PetscReal MSimObstacleContacts(const MSimObstacle &o, PetscInt v, const PetscScalar *xv, PetscReal t, PetscReal reach, PetscBool hessian, F &&f)
{
  static const PetscReal H0[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  PetscReal              n[3], H[9], y[3];
  MSimMeshCreases        cr;
  cr.k = 0;
  for (int c = 0; c < 3; c++) y[c] = xv[c] - o.v[c] * t; /* as MSimObstacleDistanceAt */
  /* the creases only for the barrier (reach dhat): a penalty (reach 0) pushes along the nearest
     face alone, its explicit steps needing no smooth energy, and is spared their work */
  const PetscReal d = o.kind == MSIM_OBSTACLE_MESH ? MSimMeshObstacleDistanceVertex(o.mesh, v, y, n, hessian ? H : NULL, reach > 0 ? &cr : NULL) : MSimObstacleDistanceAt(&o, t, xv, n, hessian ? H : NULL);
  if (d < reach) {
    f(d, (const PetscReal *)n, (const PetscReal *)H);
    for (PetscInt k = 0; k < cr.k; k++)
      if (cr.d[k] < reach) f(cr.d[k], (const PetscReal *)cr.n[k], H0);
  }
  return d;
}

/* f(v, o, d, n, H) for every owned vertex v (x: its coordinates, 3 per vertex) and contact with an
   obstacle o (where it is at time t: MSimObstacleContacts) with d < reach; H only when hessian */
template <class F>
inline void MSimContactForEachNear(const _n_MSimContact *ct, PetscInt nown, const PetscScalar *x, PetscReal t, PetscReal reach, PetscBool hessian, F &&f)
{
  for (PetscInt v = 0; v < nown; v++)
    for (const MSimObstacle &o : ct->obs) MSimObstacleContacts(o, v, x + 3 * v, t, reach, hessian, [&](PetscReal d, const PetscReal *n, const PetscReal *H) { f(v, o, d, n, H); });
}

/* -msim_friction_lag_iterations and -msim_friction_lag_rtol, checked (src/implicit/terms/friction.cpp):
   IPC's lag iterations, for the obstacles' friction and self-friction alike */
PetscErrorCode MSimFrictionLagOptions(MSimSystem sys, PetscInt *lag_max, PetscReal *lag_rtol);

/* A contact's normal force lambda and tangent projector P for friction, from the barrier's force
   f = kappa m |b'(d)| and its direction n: lambda = f |n|, P = I - n n^T / |n|^2. n is a unit vector
   but at an open surface's rim corner (grad E / b'(d), |n| from 0.16 to 8.7 around the open box's),
   where taking it as one made P indefinite and Newton diverge under friction; a unit n (within
   1e-12) is taken as it is, so every other contact keeps its bits. */
inline void MSimFrictionNormal(PetscReal f, const PetscReal n[3], PetscReal *lambda, PetscReal P[9])
{
  const PetscReal nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  if (PetscAbsReal(nn - 1) <= 1e-12) { /* the expressions of a unit n, so that they compile alike */
    *lambda = f;
    for (int a = 0; a < 3; a++)
      for (int c = 0; c < 3; c++) P[3 * a + c] = (a == c) - n[a] * n[c];
  } else {
    *lambda = f * PetscSqrtReal(nn);
    for (int a = 0; a < 3; a++)
      for (int c = 0; c < 3; c++) P[3 * a + c] = (a == c) - n[a] * n[c] / nn;
  }
}

/* IPC's lagged friction (src/implicit/terms/friction.cpp): f(v, lambda, P, u, y) for every owned
   vertex within dhat of an obstacle at the lag point xl (obstacle at tl: x_n at t, or a lag
   iteration's state at tx), lambda the barrier's normal force there and P its tangent projector
   (MSimFrictionNormal), u = P (x - x_n - v_o (tx - t)) its slip over the step relative to the
   obstacle, y = |u| */
template <class F>
inline void MSimContactForEachSliding(const _n_MSimContact *ct, PetscInt nown, const PetscScalar *x, const PetscScalar *xn, const PetscScalar *xl, const PetscScalar *m, PetscReal t, PetscReal tl, PetscReal tx, F &&f)
{
  MSimContactForEachNear(ct, nown, xl, tl, ct->dhat, PETSC_FALSE, [&](PetscInt v, const MSimObstacle &o, PetscReal d, const PetscReal *n, const PetscReal *) {
    PetscReal e, de, d2e, P[9], u[3], y = 0;
    if (d <= 0) return;
    PetscReal lambda;
    MSimBarrier(d, ct->dhat, &e, &de, &d2e);
    MSimFrictionNormal(ct->kappa * PetscRealPart(m[3 * v]) * PetscAbsReal(de), n, &lambda, P);
    for (int a = 0; a < 3; a++) {
      u[a] = 0;
      for (int c = 0; c < 3; c++) u[a] += P[3 * a + c] * PetscRealPart(x[3 * v + c] - xn[3 * v + c] - o.v[c] * (tx - t));
      y += u[a] * u[a];
    }
    f(v, lambda, P, u, std::sqrt(y));
  });
}

/* G += what f(g) adds through G's array (the contact terms' gradients and PD right-hand sides) */
template <class F>
inline PetscErrorCode MSimContactAddToVec(Vec G, F &&f)
{
  PetscScalar *g;

  PetscFunctionBeginUser;
  PetscCall(VecGetArray(G, &g));
  PetscCall(f(g));
  PetscCall(VecRestoreArray(G, &g));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* friction's smoothing f1(y)/y (IPC's f1: 2y/eps - y^2/eps^2 below eps, 1 beyond) */
inline PetscReal MSimFrictionF1OverY(PetscReal y, PetscReal eps)
{
  return y < eps ? 2 / eps - y / (eps * eps) : 1 / y;
}

/* f0 with f0' = f1: -y^3/(3 eps^2) + y^2/eps + eps/3 below eps, y beyond (C^2 at eps) */
inline PetscReal MSimFrictionF0(PetscReal y, PetscReal eps)
{
  return y < eps ? -y * y * y / (3 * eps * eps) + y * y / eps + eps / 3 : y;
}

/* the friction Hessian's coefficient of u u^T, (f1'(y) y - f1(y)) / y^3 (its coefficient of the
   tangent projector is f1(y)/y) */
inline PetscReal MSimFrictionHessianUU(PetscReal y, PetscReal eps)
{
  return y < eps ? -1 / (eps * eps * PetscMax(y, PETSC_SMALL * eps)) : -1 / (y * y * y);
}

/* how far a vertex queried at x (its coordinates' largest magnitude xmax) may move before some
   obstacle can come within dhat: its least distance dmin less dhat, less a margin for the
   distances' roundoff (a few eps of the coordinates and the distance). The distance is
   1-Lipschitz, so within that of x every obstacle stays beyond dhat; <= 0: none. The obstacles'
   and friction's skips both rest on it. */
inline PetscReal MSimContactAnchorExcess(PetscReal dmin, PetscReal dhat, PetscReal xmax)
{
  return dmin - dhat - 1e-9 * (dhat + PetscAbsReal(dmin) + xmax);
}

/* The anchored loops' query of the rank's vertex v at xv (the obstacles where they are at time t),
   shared by the obstacles term's (NearLoop) and friction's (Collect): f(o, d, n, H) for each of its
   contacts with reach dhat (MSimObstacleContacts, every obstacle in turn; H only when hessian),
   then its anchor (3 coordinates) set to xv. Returns its excess (MSimContactAnchorExcess) from a
   lower bound on each obstacle's distance: the distance, but where a mesh answers "band" (at least
   dhat) beyond its band the larger of that and the vertex's clearance
   (MSimMeshObstacleVertexClearance: the depth of its point in the vertex's far balls), so that the
   anchor's ball skips the vertex while it falls past the mesh instead of after every small move.
   *dmin (when not NULL): the least distance itself. */
template <class F>
inline PetscReal MSimContactAnchorVertex(const _n_MSimContact *ct, PetscInt v, const PetscScalar *xv, PetscReal t, PetscBool hessian, PetscReal anchor[3], PetscReal *dmin, F &&f)
{
  PetscReal dm = PETSC_MAX_REAL, dlow = PETSC_MAX_REAL, xmax = 0;
  for (const MSimObstacle &o : ct->obs) {
    const PetscReal d = MSimObstacleContacts(o, v, xv, t, ct->dhat, hessian, [&](PetscReal dc, const PetscReal *n, const PetscReal *H) { f(o, dc, n, H); });
    dm                = PetscMin(dm, d);
    if (o.kind == MSIM_OBSTACLE_MESH && d >= ct->dhat) {
      const PetscReal y[3] = {xv[0] - o.v[0] * t, xv[1] - o.v[1] * t, xv[2] - o.v[2] * t}; /* MSimObstacleContacts' point */
      dlow                 = PetscMin(dlow, PetscMax(d, MSimMeshObstacleVertexClearance(o.mesh, v, y)));
    } else dlow = PetscMin(dlow, d);
  }
  for (int c = 0; c < 3; c++) {
    anchor[c] = xv[c];
    xmax      = PetscMax(xmax, PetscAbsReal(xv[c]));
  }
  if (dmin) *dmin = dm;
  return MSimContactAnchorExcess(dlow, ct->dhat, xmax);
}
