/* Spectra and stability (SLEPc):
   - fixed-fixed chain of N free masses m and N+1 springs k: all N eigenvalues of (K, M) that
     belong to the chain's axial motion equal omega_j^2 = 4 k/m sin^2(j pi / (2(N+1))), 1e-8 relative;
   - symplectic Euler and RK4 at 0.98 of the SLEPc-predicted limit stay bounded for 10^4 steps,
     at 1.02 of it they are detected as diverged within 10^4 steps;
   - the guard warns exactly when h exceeds the bound it used. */
#include "harness.h"
#include <algorithm>
#include <vector>

static const PetscInt  kN = 8;    /* free masses */
static const PetscReal kK = 250;  /* N/m */
static const PetscReal kM = 0.03; /* kg per vertex */

static PetscErrorCode ChainOptions(char *opts, size_t len, const char *extra)
{
  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(opts, len, "-msim_scene chain -msim_chain_n %" PetscInt_FMT " -msim_fix corners -msim_stiffness %g -msim_mass %.17g -msim_gravity 0,0,0 %s", kN + 2, (double)kK, (double)(kM * (kN + 2)), extra));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestChainEigenvalues(void)
{
  TestSim                s;
  char                   opts[1024];
  std::vector<PetscReal> lambda;

  PetscFunctionBeginUser;
  PetscCall(ChainOptions(opts, sizeof(opts), ""));
  PetscCall(TestSimCreate(opts, &s));
  /* 3N unknowns: N axial modes, 2N transverse ones that have no stiffness in the straight chain */
  PetscCall(MSimSpectrumLargest(s.sys, s.X, kN, lambda));
  std::sort(lambda.begin(), lambda.end());
  for (PetscInt j = 1; j <= kN; j++) {
    const PetscReal w = 2 * std::sqrt(kK / kM) * std::sin(j * PETSC_PI / (2.0 * (kN + 1)));
    CHECK(std::abs(lambda[j - 1] - w * w) <= 1e-8 * w * w, "mode %" PetscInt_FMT ": lambda %.15g vs analytic %.15g", j, (double)lambda[j - 1], (double)(w * w));
    NOTE("mode %" PetscInt_FMT ": omega %.12f rad/s, analytic %.12f, relative error %.1e\n", j, (double)std::sqrt(lambda[j - 1]), (double)w, (double)(std::abs(lambda[j - 1] - w * w) / (w * w)));
  }
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode RunAtFraction(const char *integrator, PetscReal limit, PetscReal fraction, PetscBool *diverged, PetscInt *steps)
{
  TestSim        s;
  char           opts[1024], extra[512];
  PetscReal      wmax;
  MSimRunInfo    info;
  PetscErrorCode ierr;

  PetscFunctionBeginUser;
  PetscCall(ChainOptions(opts, sizeof(opts), "-msim_perturb 1e-3"));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(MSimSpectrumOmegaMax(s.sys, s.X, &wmax));
  PetscCall(TestSimDestroy(&s));
  PetscCall(PetscSNPrintf(extra, sizeof(extra), "-msim_perturb 1e-3 -msim_integrator %s -msim_dt %.17g -msim_steps 10000 -msim_spectrum_check 0 -msim_divergence_check_every 1", integrator, (double)(fraction * limit / wmax)));
  PetscCall(ChainOptions(opts, sizeof(opts), extra));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = MSimRun(s.sys, s.integ, s.X, s.V, &info);
  PetscCall(PetscPopErrorHandler());
  PetscCheck(ierr == 0 || ierr == PETSC_ERR_NOT_CONVERGED, PETSC_COMM_WORLD, ierr, "unexpected error %d", (int)ierr);
  *diverged = info.diverged;
  *steps    = info.steps_done;
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestStabilityLimits(void)
{
  const char     *names[]  = {"symplectic_euler", "rk4"};
  const PetscReal limits[] = {2.0, 2.0 * PETSC_SQRT2};
  PetscBool       div;
  PetscInt        steps;

  PetscFunctionBeginUser;
  for (int k = 0; k < 2; k++) {
    PetscCall(RunAtFraction(names[k], limits[k], 0.98, &div, &steps));
    NOTE("%s at 0.98 of the predicted limit: %s after %" PetscInt_FMT " steps\n", names[k], div ? "diverged" : "bounded", steps);
    CHECK(!div && steps == 10000, "%s diverged below its limit", names[k]);
    PetscCall(RunAtFraction(names[k], limits[k], 1.02, &div, &steps));
    NOTE("%s at 1.02 of the predicted limit: %s at step %" PetscInt_FMT "\n", names[k], div ? "diverged" : "bounded", steps);
    CHECK(div, "%s at 1.02 of its limit was not detected as diverged", names[k]);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestGuard(void)
{
  const char *names[] = {"symplectic_euler", "rk4"};
  PetscFunctionBeginUser;
  for (int k = 0; k < 2; k++)
    for (int above = 0; above < 2; above++) {
      TestSim     s;
      MSimRunInfo info;
      char        opts[1024], extra[256];
      PetscReal   omega2, hcrit;

      PetscCall(ChainOptions(opts, sizeof(opts), "-msim_integrator symplectic_euler"));
      PetscCall(TestSimCreate(opts, &s));
      PetscCall(MSimIntegratorSetType(s.integ, names[k]));
      PetscCall(MSimSystemGershgorin(s.sys, &omega2));
      PetscCall(MSimStabilityLimit(s.sys, s.integ, std::sqrt(omega2), &hcrit));
      PetscCall(TestSimDestroy(&s));
      PetscCall(PetscSNPrintf(extra, sizeof(extra), "-msim_integrator %s -msim_steps 1 -msim_dt %.17g", names[k], (double)(hcrit * (above ? 1.001 : 0.999))));
      PetscCall(ChainOptions(opts, sizeof(opts), extra));
      PetscCall(TestSimCreate(opts, &s));
      PetscCall(MSimRun(s.sys, s.integ, s.X, s.V, &info));
      CHECK(info.warned == (PetscBool)above, "%s: guard warned %d at h = %s the bound", names[k], (int)info.warned, above ? "1.001 x" : "0.999 x");
      CHECK(std::abs(info.critical_dt - hcrit) <= 1e-12 * hcrit, "guard used limit %g, expected %g", (double)info.critical_dt, (double)hcrit);
      PetscCall(TestSimDestroy(&s));
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestSpectrum(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestChainEigenvalues());
  PetscCall(TestGuard());
  PetscCall(TestStabilityLimits());
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestSpectrum)
