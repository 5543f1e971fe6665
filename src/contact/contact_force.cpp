/* The obstacles' force per vertex at a state (msim/contact_force.h), for the frames and the
   monitor. The barrier's force is what obstacles.cpp's gradient adds, divided by the step's weight
   beta h^2: -kappa m b'(d) n (b' <= 0, so it pushes out along n); the penalty's is what
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

static const char barrier_key[] = "MSimContactForceBarrier";

PetscErrorCode MSimContactForceSetIntegrator(MSimSystem sys, const char type[])
{
  PetscBool      barrier;
  PetscContainer mark;

  PetscFunctionBeginUser;
  /* the implicit integrators (the registered schemes) use the barrier; the others the penalty */
  PetscCall(MSimImplicitSchemeIsRegistered(type, &barrier));
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

PetscErrorCode MSimContactForce(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscReal totals[4])
{
  MSimContact        ct;
  PetscObject        mark;
  const PetscScalar *x, *m;
  PetscScalar       *f = NULL;
  PetscReal          sum[4] = {0, 0, 0, 0};

  PetscFunctionBeginUser;
  PetscCall(MSimContactGet(sys, &ct));
  if (F) PetscCall(VecZeroEntries(F));
  if (ct) {
    PetscCall(PetscObjectQuery((PetscObject)sys->X0, barrier_key, &mark));
    const PetscBool barrier = (PetscBool)(mark != NULL);
    PetscCall(VecGetArrayRead(X, &x));
    PetscCall(VecGetArrayRead(sys->mass, &m));
    if (F) PetscCall(VecGetArray(F, &f));
    for (PetscInt v = 0; v < sys->nown; v++) {
      PetscBool touch = PETSC_FALSE;
      for (const MSimObstacle &o : ct->obs) {
        PetscReal       n[3], s = 0;
        const PetscReal d = MSimObstacleDistanceAt(&o, t, x + 3 * v, n, NULL); /* moving obstacles where they are at t */
        if (barrier) {
          PetscReal b, db, d2b;
          if (d >= ct->dhat) continue;
          touch = PETSC_TRUE;
          /* the clamp obstacles.cpp's gradient uses (a feasible state never reaches it) */
          MSimBarrier(PetscMax(d, PETSC_SMALL * ct->dhat), ct->dhat, &b, &db, &d2b);
          s = -ct->kappa * PetscRealPart(m[3 * v]) * db;
        } else {
          if (d >= 0) continue;
          touch = PETSC_TRUE;
          s = -ct->kc * d;
        }
        for (int c = 0; c < 3; c++) {
          if (f) f[3 * v + c] += s * n[c];
          sum[c] += s * n[c];
        }
      }
      sum[3] += touch;
    }
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
    PetscCall(MPIU_Allreduce(sum, totals, 4, MPIU_REAL, MPIU_SUM, sys->comm));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
