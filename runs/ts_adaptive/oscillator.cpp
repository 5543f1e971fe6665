/* The single spring of runs/ts_adaptive/spring.py in PETSc's TS alone, without msim: one mass on a
   spring, x'' = -(x - rest), x(0) = rest + 0.1, v(0) = 0, exact x = rest + 0.1 cos t, as
   U = [x_1..x_d; v_1..v_d] with the motion along the first axis and
   F(t, U, U') = [x' - v; v' + (x - rest)]. -dim 3 -rest 1 has msim's unknowns for the free vertex
   (its 3 positions, then its 3 velocities), so the error control weighs the same 6 entries.
   -frame_dt 0.1 -nframes 120: the run's frames (T = 12 s). -mode:
     step    TSStep from frame to frame, the last step of each shortened to land on it (msim's loop)
     match   one TSSolve to T, TS_EXACTFINALTIME_MATCHSTEP
     interp  one TSSolve to T, TS_EXACTFINALTIME_INTERPOLATE (steps past T, interpolates back)
   Prints the final x and v, their errors and the TS's steps and rejections. */
#include <petscts.h>

static PetscInt  dim  = 1;
static PetscReal rest = 0;

static PetscErrorCode IFunction(TS ts, PetscReal t, Vec U, Vec Ud, Vec F, void *ctx)
{
  const PetscScalar *u, *ud;
  PetscScalar       *f;

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayRead(U, &u));
  PetscCall(VecGetArrayRead(Ud, &ud));
  PetscCall(VecGetArray(F, &f));
  for (PetscInt i = 0; i < dim; i++) {
    f[i]       = ud[i] - u[dim + i];
    f[dim + i] = ud[dim + i] + u[i] - (i == 0 ? rest : 0);
  }
  PetscCall(VecRestoreArray(F, &f));
  PetscCall(VecRestoreArrayRead(Ud, &ud));
  PetscCall(VecRestoreArrayRead(U, &u));
  PetscFunctionReturn(0);
}

/* dF/dU + a dF/dU' = [[a I, -I], [I, a I]] */
static PetscErrorCode IJacobian(TS ts, PetscReal t, Vec U, Vec Ud, PetscReal a, Mat J, Mat P, void *ctx)
{
  PetscFunctionBeginUser;
  PetscCall(MatZeroEntries(P));
  for (PetscInt i = 0; i < dim; i++) {
    PetscCall(MatSetValue(P, i, i, a, INSERT_VALUES));
    PetscCall(MatSetValue(P, i, dim + i, -1, INSERT_VALUES));
    PetscCall(MatSetValue(P, dim + i, i, 1, INSERT_VALUES));
    PetscCall(MatSetValue(P, dim + i, dim + i, a, INSERT_VALUES));
  }
  PetscCall(MatAssemblyBegin(P, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(P, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

/* msim's loop (src/integrators/impls/ts.cpp, Step_TS): each frame from its start in the TS's own
   steps, the first at the step proposed last, the one that would pass the frame shortened to
   land on it, whose proposal is not kept */
static PetscErrorCode StepFrames(TS ts, PetscReal dt, PetscInt nframes)
{
  PetscReal t = 0, h, hnext;

  PetscFunctionBeginUser;
  PetscCall(TSGetTimeStep(ts, &hnext));
  for (PetscInt k = 1; k <= nframes; k++) {
    const PetscReal tend = k * dt, eps = 1e-12 * PetscMax(1.0, tend);
    while (tend - t > eps) {
      h = PetscMin(hnext, tend - t);
      if (tend - t - h <= eps) h = tend - t;
      PetscCall(TSSetTimeStep(ts, h));
      PetscCall(TSStep(ts));
      PetscCall(TSGetTime(ts, &t));
      PetscCall(TSGetTimeStep(ts, &h));
      if (tend - t > eps) hnext = h;
    }
  }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  TS           ts;
  Vec          U;
  Mat          J;
  PetscReal    dt = 0.1, T, ex, ev;
  PetscInt     nframes = 120, steps, rejected;
  char         mode[16] = "step";
  PetscScalar *u;

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-frame_dt", &dt, NULL));
  PetscCall(PetscOptionsGetInt(NULL, NULL, "-nframes", &nframes, NULL));
  PetscCall(PetscOptionsGetInt(NULL, NULL, "-dim", &dim, NULL));
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-rest", &rest, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-mode", mode, sizeof(mode), NULL));
  PetscCheck(!strcmp(mode, "step") || !strcmp(mode, "match") || !strcmp(mode, "interp"), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-mode step, match or interp");
  T = dt * nframes;
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, 2 * dim, &U));
  PetscCall(VecSet(U, 0));
  PetscCall(VecSetValue(U, 0, rest + 0.1, INSERT_VALUES));
  PetscCall(VecAssemblyBegin(U));
  PetscCall(VecAssemblyEnd(U));
  PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, 2 * dim, 2 * dim, NULL, &J));
  PetscCall(TSCreate(PETSC_COMM_SELF, &ts));
  PetscCall(TSSetIFunction(ts, NULL, IFunction, NULL));
  PetscCall(TSSetIJacobian(ts, J, J, IJacobian, NULL));
  PetscCall(TSSetTimeStep(ts, dt));
  PetscCall(TSSetSolution(ts, U));
  PetscCall(TSSetMaxSteps(ts, PETSC_MAX_INT - 1));
  /* TSStep wants an end time: past T for the step mode, which lands on each frame itself */
  PetscCall(TSSetMaxTime(ts, strcmp(mode, "step") ? T : 2 * T));
  PetscCall(TSSetExactFinalTime(ts, strcmp(mode, "interp") ? TS_EXACTFINALTIME_MATCHSTEP : TS_EXACTFINALTIME_INTERPOLATE));
  PetscCall(TSSetFromOptions(ts));
  PetscCall(TSSetUp(ts));
  if (!strcmp(mode, "step")) PetscCall(StepFrames(ts, dt, nframes));
  else PetscCall(TSSolve(ts, U));
  PetscCall(TSGetStepNumber(ts, &steps));
  PetscCall(TSGetStepRejections(ts, &rejected));
  PetscCall(VecGetArray(U, &u));
  ex = PetscRealPart(u[0]) - rest - 0.1 * PetscCosReal(T);
  ev = PetscRealPart(u[dim]) + 0.1 * PetscSinReal(T);
  PetscCall(PetscPrintf(PETSC_COMM_SELF, "x %.16e v %.16e err_x %.3e err_v %.3e steps %" PetscInt_FMT " rejected %" PetscInt_FMT "\n", (double)PetscRealPart(u[0]), (double)PetscRealPart(u[dim]), (double)PetscAbsReal(ex), (double)PetscAbsReal(ev), steps, rejected));
  PetscCall(VecRestoreArray(U, &u));
  PetscCall(TSDestroy(&ts));
  PetscCall(MatDestroy(&J));
  PetscCall(VecDestroy(&U));
  PetscCall(PetscFinalize());
  return 0;
}
