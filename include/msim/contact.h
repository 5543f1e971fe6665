/* Contact with obstacles (planes, spheres, solid boxes, triangle meshes), each static or moving with
   a constant velocity, read from options once per system:
   the geometry every integrator shares (signed distance, its gradient and Hessian, the largest
   feasible step of a vertex along a ray), the barrier of the implicit term (src/implicit/terms/
   obstacles.cpp) and the penalty of the explicit force. One contact object per system, made on
   first use (MSimContactGet) and freed at PetscFinalize, so no header of the system or the
   problem changes. Queries are per owned vertex: no communication but the reductions of a
   maximum step and of the monitor's totals. */
#pragma once
#include <msim/system.h>
#include <vector>

typedef enum { MSIM_OBSTACLE_PLANE, MSIM_OBSTACLE_SPHERE, MSIM_OBSTACLE_BOX, MSIM_OBSTACLE_MESH } MSimObstacleKind;

/* A static triangle surface (src/contact/mesh_obstacle.cpp: CGAL's AABB tree, kept in that one
   file). Every rank holds the whole surface (read on rank 0 by msim's readers, broadcast once), so
   queries about its own vertices need no communication. */
typedef struct _n_MSimMeshObstacle *MSimMeshObstacle;
/* Reads F (OBJ/OFF/STL... by extension, msim's readers and MSimMeshCheck: their one-line errors),
   builds the tree. Collective. */
PetscErrorCode MSimMeshObstacleCreate(MPI_Comm comm, const char file[], PetscReal thickness, MSimMeshObstacle *mesh);
void           MSimMeshObstacleDestroy(MSimMeshObstacle *mesh);
/* points farther than band from the surface are taken as outside without the inside test */
void MSimMeshObstacleSetBand(MSimMeshObstacle mesh, PetscReal band);
/* the band's queries from the candidate cache (default) or, PETSC_FALSE, from the tree at every
   query: both give the same answers (tests/unit/test_mesh_obstacle.cpp compares them) */
void MSimMeshObstacleSetCache(MSimMeshObstacle mesh, PetscBool use);
/* the explicit penalty's answers (on where the penalty is the contact, MSimContactForceSetIntegrator),
   for vertices that sink deeper than band, which the barrier's never do: a closed surface answers
   its inside at any depth, and a shell (an open surface with a thickness) keeps each vertex's side
   in MSimMeshObstacleDistanceVertex, so that one past the surface is pushed back to the side it
   came from (src/contact/mesh_obstacle.cpp, ShellSide) */
void MSimMeshObstacleSetPenalty(MSimMeshObstacle mesh, PetscBool on);
/* whether the mesh keeps its vertices' sides (a shell with the penalty); *lost: some vertex of the
   rank entered the shell from beyond band in one query (its side unknown, the nearer taken), x the
   first such point */
PetscBool MSimMeshObstacleKeepsSides(MSimMeshObstacle mesh, PetscBool *lost, PetscReal x[3]);
/* a shell's sides of the rank's vertices [0, n) for checkpoints, as two arrays in X's layout (3
   numbers a vertex): each vertex's last gradient m and its state (in its first number); Set puts
   them back at a restart */
void MSimMeshObstacleGetSides(MSimMeshObstacle mesh, PetscInt n, PetscScalar m[], PetscScalar state[]);
void MSimMeshObstacleSetSides(MSimMeshObstacle mesh, PetscInt n, const PetscScalar m[], const PetscScalar state[]);
/* file name, triangles, closed (every edge in two triangles: the cloth stays outside) */
void MSimMeshObstacleInfo(MSimMeshObstacle mesh, const char **file, PetscInt *ntri, PetscBool *closed);
/* distance - thickness (negative inside a closed surface or within the shell), unit gradient n,
   Hessian of the distance (face region 0; edge (I - n n^T - e e^T)/r; vertex (I - n n^T)/r) */
PetscReal MSimMeshObstacleDistance(MSimMeshObstacle mesh, const PetscReal x[3], PetscReal n[3], PetscReal H[9]);
/* the further contacts of a vertex in a concave crease (right or acute), beside its nearest
   triangle's: each another face's distance less the thickness and its unit normal towards the vertex
   (the distance to the face's plane: Hessian 0), or, at an open surface's rim corner, the distance d
   whose barrier b(d) is the corner's share of the pair's energy and n = grad / b'(d), not a unit
   vector (src/contact/mesh_obstacle.cpp, RimCorner; friction takes its length apart,
   msim/private/contactimpl.h's MSimFrictionNormal), or, on an open surface with an obtuse
   crease, one contact carrying the sum over its faces, edges and vertices less the nearest's
   (FeatureSum: n not a unit vector either), up to MSIM_MESH_CREASE_MAX of them
   (src/contact/mesh_obstacle.cpp, CreaseContacts) */
enum { MSIM_MESH_CREASE_MAX = 4 };
typedef struct {
  PetscInt  k;
  PetscReal d[MSIM_MESH_CREASE_MAX], n[MSIM_MESH_CREASE_MAX][3];
} MSimMeshCreases;
/* the same for a rank's vertex v (>= 0; the per-vertex loops of msim/private/contactimpl.h): the
   same numbers, with a point asked again answered from v's last answers and a far vertex that
   moved little answered as beyond band without a lookup (with the cache off: the plain query);
   with cr, also its creases' contacts (v < 0: the plain query's) */
PetscReal MSimMeshObstacleDistanceVertex(MSimMeshObstacle mesh, PetscInt v, const PetscReal x[3], PetscReal n[3], PetscReal H[9], MSimMeshCreases *cr = NULL);
/* a lower bound of x's distance (less the thickness) from what vertex v's last queries certified:
   where the answer at x was "beyond band" (the band less the thickness) and x lies in one of v's
   far balls (the points its last full query showed beyond band), band + x's depth in it less the
   thickness; else PETSC_MIN_REAL. For the callers' anchors: x's neighbourhood that stays beyond
   band, larger than the answer shows */
PetscReal MSimMeshObstacleVertexClearance(MSimMeshObstacle mesh, PetscInt v, const PetscReal x[3]);
/* a step t in [0, tmax] for which the segment x -> x + t u keeps off the thickness shell
   (conservative advancement; PETSC_INFINITY where x + [0, tmax] u cannot reach it) */
PetscReal MSimMeshObstacleSafeStep(MSimMeshObstacle mesh, const PetscReal x[3], const PetscReal u[3], PetscReal tmax);
/* the same for a rank's vertex v (>= 0), its distance at x from MSimMeshObstacleDistanceVertex */
PetscReal MSimMeshObstacleSafeStepVertex(MSimMeshObstacle mesh, PetscInt v, const PetscReal x[3], const PetscReal u[3], PetscReal tmax);
/* the vertex queries within the band around the surface's box so far: answered from the vertex's
   last answers, skipped as beyond band (moved less than its last distance's excess over band),
   computed in full, and answered from the vertex's near set (its last full query's nearest triangles);
   and of the skipped ones, those skipped by the ball around their cell's centre alone */
void MSimMeshObstacleVertexCounts(MSimMeshObstacle mesh, PetscInt64 counts[5]);

typedef struct {
  MSimObstacleKind kind;
  PetscReal        p[6]; /* plane: unit n, d (n.x >= d); sphere: c, r; box: x0,x1,y0,y1,z0,z1 */
  MSimMeshObstacle mesh; /* MSIM_OBSTACLE_MESH (owned by the contact object) */
  PetscReal        v[3]; /* constant velocity (-msim_contact_velocity): at time t the obstacle is
                            its given shape moved by v t */
} MSimObstacle;

/* The body is private (msim/private/contactimpl.h). */
typedef struct _n_MSimContact *MSimContact;

/* The system's contact object (NULL when no obstacle option is given), made from the options on
   the first call: reads -msim_contact_*, checks every start vertex outside every obstacle (or on
   it). */
PetscErrorCode MSimContactGet(MSimSystem sys, MSimContact *contact);
PetscErrorCode MSimContactView(MSimContact contact, PetscViewer viewer);
/* After the integrator's set-up (of type, its name): the contact options set that act nowhere in
   it refused in one line naming them: the barrier's (-msim_contact_kappa, -msim_contact_pd_*, ...)
   with a penalty integrator or with obstacles as VI bounds, the penalty's stiffness with the
   barrier. Collective; nothing without obstacles (MSimContactGet refuses them there). */
PetscErrorCode MSimContactRefuseUnread(MSimSystem sys, const char type[]);
/* Integrators of type `type` whose contact is the penalty (the explicit ones and ts), stepping by
   h: each obstacle's speed against the step, as the implicit integrators check it at their set-up
   with their step's scale sqrt(beta) h (-msim_contact_velocity refused in one line). Collective;
   nothing without obstacles or for the implicit integrators. */
PetscErrorCode MSimContactCheckPenaltyStep(MSimSystem sys, const char type[], PetscReal h);
/* The start state against the obstacles the barrier takes, with its margin: one error line naming
   the first vertex within 1e-6 dhat of one (MSimContactGet refuses only a vertex inside, as a
   penalty or VI bounds can start on an obstacle; the implicit integrators call this where the
   obstacles stay with the barrier, not bounds). Collective; nothing without obstacles. */
PetscErrorCode MSimContactCheckBarrierStart(MSimSystem sys);
/* A restarted run's state X at time t against the obstacles, as the start's: one error line naming
   the first vertex inside an obstacle or within 1e-6 dhat of one (the obstacles are options, not
   part of the checkpoint). Only where contact is the barrier (barrier true): the penalty's state
   rests inside an obstacle by design; against the obstacles VI bounds hold, a vertex strictly
   inside (d < 0), as their runs rest on them at d = 0. Collective; nothing without obstacles. */
PetscErrorCode MSimContactCheckRestart(MSimSystem sys, PetscReal t, Vec X, PetscBool barrier);
/* *speed = the fastest obstacle's speed (-msim_contact_velocity; 0 without obstacles): a moving
   obstacle gives the scene kinetic energy, which the divergence check's energy scale counts */
PetscErrorCode MSimContactObstacleSpeed(MSimSystem sys, PetscReal *speed);
/* Fixed vertices are not unknowns, and no obstacle acts on them: one that moves into an obstacle
   (-msim_fix_velocity, or an obstacle's -msim_contact_velocity) stays inside it while the free
   vertices are kept out. Watch notes, with no communication, the first fixed vertex of this rank
   outside (or on) an obstacle at t0 and inside it at t1, the end of step `step`; nothing where
   neither the handles nor any obstacle moves (a vertex pinned inside a static obstacle is a valid
   scene). Warn (collective, at the run's end) says which vertex entered which obstacle first, in
   one warning line. Nothing without obstacles. */
PetscErrorCode MSimContactWatchHandles(MSimSystem sys, PetscInt step, PetscReal t0, PetscReal t1);
PetscErrorCode MSimContactWarnHandles(MSimSystem sys);
/* Signed distance of x to obstacle o (positive outside), its gradient n (unit) and, when H is
   not NULL, its Hessian (3 x 3, row major; zero for planes and box faces). */
PetscReal MSimObstacleDistance(const MSimObstacle *o, const PetscReal x[3], PetscReal n[3], PetscReal H[9]);
/* The same for the obstacle where it is at time t (its velocity times t away from its given place) */
PetscReal MSimObstacleDistanceAt(const MSimObstacle *o, PetscReal t, const PetscReal x[3], PetscReal n[3], PetscReal H[9]);
/* The first t > 0 at which x + t u reaches the obstacle's surface (PETSC_INFINITY: never), for x
   outside it (planes, spheres, boxes). */
PetscReal MSimObstacleHitTime(const MSimObstacle *o, const PetscReal x[3], const PetscReal u[3]);
/* The largest step in (0, tmax] (or PETSC_INFINITY beyond) the line searches may take from x along
   u against the obstacle at time t: 0.8 of the exact hit time (IPC's filter) for the analytic
   shapes, conservative advancement for meshes. */
PetscReal MSimObstacleSafeStep(const MSimObstacle *o, PetscReal t, const PetscReal x[3], const PetscReal u[3], PetscReal tmax);
/* The barrier b(d) = -(d - dhat)^2 log(d / dhat) on (0, dhat), 0 beyond (C2 at dhat), and its
   first two derivatives. */
void MSimBarrier(PetscReal d, PetscReal dhat, PetscReal *b, PetscReal *db, PetscReal *d2b);
/* F += the explicit penalty force kc max(0, -d) n per free owned vertex and obstacle at time t
   (nothing without obstacles). */
PetscErrorCode MSimContactAddPenaltyForce(MSimSystem sys, PetscReal t, Vec X, Vec F);
/* Whether a vertex of this rank entered a shell (a mesh obstacle with -msim_contact_thickness under
   the penalty) from farther than the contact distance in one query since the run began, its side
   unknown (no communication: MSimSystemComputeEnergy's reduction carries it); Check (collective,
   where some rank has one) stops the run in one line naming the first such vertex's point and
   time. */
PetscErrorCode MSimContactShellSideLost(MSimSystem sys, PetscBool *lost);
PetscErrorCode MSimContactCheckShellSides(MSimSystem sys);
/* K += kc n n^T on every free owned vertex for every obstacle (n its normal at X, at time t): the
   penalty's stiffness as if each vertex were pressed into each obstacle, an upper bound of every
   contact state's (Weyl: adding PSD blocks only raises eigenvalues), which the SLEPc stability guard
   adds to (K, M), as the Gershgorin guard adds kc to every row. Nothing without obstacles. */
PetscErrorCode MSimContactAddPenaltyStiffness(MSimSystem sys, PetscReal t, Vec X, Mat K);
/* K += w (-dF/dX) of MSimContactAddPenaltyForce's F at X: w kc (n n^T + d D^2 d) on the diagonal
   block of each free owned vertex inside an obstacle (d < 0), for the implicit integrators that
   take the penalty (PETSc's TS: a Newton step needs the penalty's stiffness, without which its
   steps in contact converge linearly, if at all). ADD_VALUES, then assembled. Nothing without
   obstacles. */
PetscErrorCode MSimContactAddPenaltyJacobian(MSimSystem sys, PetscReal t, Vec X, PetscReal w, Mat K);
