/* The obstacles' force per vertex at a state (msim/contact_force.h), for the frames and the
   monitor. The implicit contact's is what obstacles.cpp's and friction.cpp's gradients add,
   divided by the step's weight beta h^2: the barrier's normal force -kappa m b'(d) n (b' <= 0, so it
   pushes out along n) plus friction's -mu lambda f1(y)/y u,
   the slip u measured from the x_n of the step that friction's term last evaluated (the state
   passed is that step's result), with lambda and P those its last solve used: taken at x_n, or at
   the lag point of its last lag iteration (-msim_friction_lag_iterations), where, once the lag
   converged, a vertex carries friction exactly where it is within dhat at the result; the penalty's is what
   MSimContactAddPenaltyForce adds. Computed here from msim/contact.h's geometry rather than read
   back from the solver, whose last evaluation is at its last iterate or line-search trial, not
   the step's result. Which of the two applies is kept on the system's X0 (a composed container,
   like the contact object itself) so that the output, which knows only the system, finds it. */
#include <msim/contact_force.h>
#include <msim/contact.h>
#include <msim/contact_bounds.h>
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/contactimpl.h>
#include <vector>

static const char barrier_key[] = "MSimContactForceBarrier";

PetscErrorCode MSimContactForceSetIntegrator(MSimSystem sys, const char type[])
{
  PetscBool      barrier;
  PetscContainer mark;
  MSimContact    ct;

  PetscFunctionBeginUser;
  /* the implicit integrators (the registered schemes) use the barrier; the others the penalty */
  PetscCall(MSimImplicitSchemeIsRegistered(type, &barrier));
  /* the penalty has no friction: a coefficient it would ignore is refused, not dropped */
  PetscCall(MSimContactGet(sys, &ct));
  PetscCheck(barrier || !ct || ct->mu == 0, sys->comm, PETSC_ERR_SUP, "-msim_friction with -msim_integrator %s is not supported: its contact is a penalty, which has no friction; use implicit_euler or bdf2 (IPC's friction)", type);
  /* variable bounds are the implicit integrators' SNES's (contact_bounds.cpp): the others ran the
     penalty and said only that the option was never used */
  if (!barrier) {
    PetscBool bounds = PETSC_FALSE;
    PetscCall(PetscOptionsGetBool(NULL, NULL, "-msim_contact_bounds", &bounds, NULL));
    PetscCheck(!bounds, sys->comm, PETSC_ERR_SUP, "-msim_contact_bounds with -msim_integrator %s is not supported: its contact is a penalty force; variable bounds need an implicit integrator's SNES (implicit_euler or bdf2)", type);
  }
  /* the penalty pushes only where the distance is negative: an open surface's distance is the
     unsigned one less the thickness, never negative at thickness 0, so the cloth would fall
     through it with no force at all (the barrier keeps a vertex on the side it starts on) */
  if (!barrier && ct && ct->thickness == 0)
    for (const MSimObstacle &o : ct->obs) {
      const char *file;
      PetscInt    ntri;
      PetscBool   closed = PETSC_TRUE;
      if (o.kind == MSIM_OBSTACLE_MESH) MSimMeshObstacleInfo(o.mesh, &file, &ntri, &closed);
      PetscCheck(closed, sys->comm, PETSC_ERR_SUP, "-msim_contact_mesh %s is an open surface, which the penalty of -msim_integrator %s cannot hold anything on at -msim_contact_thickness 0 (it pushes only inside the thickness shell); give a thickness > 0, or use implicit_euler or bdf2 (the barrier keeps either side)", file, type);
    }
  /* the penalty's vertices sink deeper than the barrier's band: the meshes answer for them
     (msim/contact.h, MSimMeshObstacleSetPenalty); the barrier's answers stay as they are */
  if (!barrier && ct)
    for (const MSimObstacle &o : ct->obs)
      if (o.kind == MSIM_OBSTACLE_MESH) MSimMeshObstacleSetPenalty(o.mesh, PETSC_TRUE);
  if (barrier) {
    PetscCall(PetscContainerCreate(PETSC_COMM_SELF, &mark));
    PetscCall(PetscObjectCompose((PetscObject)sys->X0, barrier_key, (PetscObject)mark));
    PetscCall(PetscContainerDestroy(&mark));
  } else PetscCall(PetscObjectCompose((PetscObject)sys->X0, barrier_key, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactHasObstacles(MSimSystem sys, PetscBool *has)
{
  MSimContact ct;
  Vec         R;

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  PetscCall(MSimContactBoundsGetReaction(sys, &R));
  *has = (PetscBool)(ct != NULL || R != NULL);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimContactForce(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscReal totals[5])
{
  MSimContact        ct;
  PetscObject        mark;
  const PetscScalar *x, *m;
  PetscScalar       *f = NULL;
  PetscReal          sum[5] = {0, 0, 0, 0, 0}; /* force x, y, z; vertices in contact; energy */

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  if (F) PetscCall(VecZeroEntries(F));
  if (ct) {
    PetscCall(PetscObjectQuery((PetscObject)sys->X0, barrier_key, &mark));
    const PetscBool barrier = (PetscBool)(mark != NULL);
    std::vector<char> touch(sys->nown, 0);
    PetscCall(VecGetArrayRead(X, &x));
    PetscCall(VecGetArrayRead(sys->mass, &m));
    if (F) PetscCall(VecGetArray(F, &f));
    const auto add = [&](PetscInt v, const PetscReal *s, char mark) {
      for (int c = 0; c < 3; c++) {
        if (f) f[3 * v + c] += s[c];
        sum[c] += s[c];
      }
      touch[v] = (char)(touch[v] | mark);
    };
    if (barrier) {
      /* the barrier's normal force, the same clamp as obstacles.cpp's gradient, and the energy
         kappa m b(d) whose gradient it is (obstacles.cpp's E over beta h^2) */
      MSimContactForEachNear(ct, sys->nown, x, t, ct->dhat, PETSC_FALSE, [&](PetscInt v, const MSimObstacle &, PetscReal d, const PetscReal *n, const PetscReal *) {
        PetscReal e, de, d2e, s[3];
        MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &e, &de, &d2e);
        for (int c = 0; c < 3; c++) s[c] = -ct->kappa * PetscRealPart(m[3 * v]) * de * n[c];
        add(v, s, 1);
        sum[4] += ct->kappa * PetscRealPart(m[3 * v]) * e;
      });
      /* and friction's, -mu lambda f1(y)/y u, at this state against the step's x_n, with the
         contacts of the lag point, that its term left (friction.cpp; none before the first step) */
      if (ct->mu > 0 && ct->fr_xn) {
        const PetscScalar *xn, *xl;
        const PetscReal    eps = ct->eps_v * ct->fr_h;
        PetscCall(VecGetArrayRead(ct->fr_xn, &xn));
        PetscCall(VecGetArrayRead(ct->fr_xl, &xl));
        MSimContactForEachSliding(ct, sys->nown, x, xn, xl, m, ct->fr_t, ct->fr_tl, ct->fr_tx, [&](PetscInt v, PetscReal lambda, const PetscReal *, const PetscReal *u, PetscReal y) {
          const PetscReal a = -ct->mu * lambda * MSimFrictionF1OverY(y, eps), s[3] = {a * u[0], a * u[1], a * u[2]};
          add(v, s, 0); /* counted where its normal force is */
        });
        PetscCall(VecRestoreArrayRead(ct->fr_xl, &xl));
        PetscCall(VecRestoreArrayRead(ct->fr_xn, &xn));
      }
    } else
      MSimContactForEachNear(ct, sys->nown, x, t, 0.0, PETSC_FALSE, [&](PetscInt v, const MSimObstacle &, PetscReal d, const PetscReal *n, const PetscReal *) {
        const PetscReal s[3] = {-ct->kc * d * n[0], -ct->kc * d * n[1], -ct->kc * d * n[2]};
        add(v, s, 1);
        sum[4] += 0.5 * ct->kc * d * d; /* the penalty's energy, whose gradient is -s */
      });
    for (char c : touch) sum[3] += c;
    if (F) PetscCall(VecRestoreArray(F, &f));
    PetscCall(VecRestoreArrayRead(sys->mass, &m));
    PetscCall(VecRestoreArrayRead(X, &x));
  }
  {
    /* obstacles taken as variable bounds (msim/contact_bounds.h): their reactions of the step */
    Vec R;
    PetscCall(MSimContactBoundsGetReaction(sys, &R));
    if (R) {
      const PetscScalar *r;
      PetscCall(VecGetArrayRead(R, &r));
      if (F) PetscCall(VecGetArray(F, &f));
      for (PetscInt v = 0; v < sys->nown; v++) {
        PetscBool touch = PETSC_FALSE;
        for (int c = 0; c < 3; c++) {
          if (f) f[3 * v + c] += r[3 * v + c];
          sum[c] += PetscRealPart(r[3 * v + c]);
          touch = (PetscBool)(touch || r[3 * v + c] != 0.0);
        }
        sum[3] += touch;
      }
      if (F) PetscCall(VecRestoreArray(F, &f));
      PetscCall(VecRestoreArrayRead(R, &r));
    }
  }
  if (totals) {
    PetscCall(MPIU_Allreduce(sum, totals, 5, MPIU_REAL, MPIU_SUM, sys->comm));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
