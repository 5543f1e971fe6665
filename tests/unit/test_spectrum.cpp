/* Spectra and stability (SLEPc):
   - fixed-fixed chain of N free masses m and N+1 springs k: all N eigenvalues of (K, M) that
     belong to the chain's axial motion equal omega_j^2 = 4 k/m sin^2(j pi / (2(N+1))), 1e-8 relative;
   - symplectic Euler and RK4 at 0.98 of the SLEPc-predicted limit stay bounded for 10^4 steps,
     at 1.02 of it they are detected as diverged within 10^4 steps;
   - the guard warns exactly when h exceeds the bound it used;
   - the imaginary-axis limit found from a stability polynomial: RK4 2 sqrt(2), RK3 sqrt(3) (the
     roots of |R(iy)|^2 - 1 = y^6 (y^2 - 8) / 576 and y^4 (y^2 - 3) / 36), forward Euler and Heun 0
     (|R(iy)|^2 = 1 + y^2, 1 + y^4 / 4), forward Euler with drag 2 s (|1 + x mu|^2 = 1 - 2 s x +
     x^2); and -msim_integrator ts finds the same for -ts_type rk 4, 3, 1fe and euler from PETSc's
     tableaus, and for ssp rks3 with 4 stages that of Ketcheson's SSP(4,3) (R = 1 + z + z^2/2 +
     z^3/6 + z^4/48), for rk104 a polynomial whose first five terms are e^z's (fourth order). */
#include "harness.h"
#include <msim/private/integratorimpl.h>
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

/* the guard's limit h omega_max of -msim_integrator ts with the TS options given, and its polynomial */
static PetscErrorCode TSLimit(const char *ts_opts, PetscReal *limit, PetscInt *degree, PetscReal c[])
{
  TestSim   s;
  char      opts[1024], extra[512];
  PetscReal h;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(extra, sizeof(extra), "-msim_integrator ts %s", ts_opts));
  PetscCall(ChainOptions(opts, sizeof(opts), extra));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(MSimIntegratorSetUp(s.integ));
  PetscCall(MSimStabilityLimit(s.sys, s.integ, 1.0, &h));
  *limit  = h;
  *degree = s.integ->stability_degree;
  for (PetscInt k = 0; k <= *degree; k++) c[k] = s.integ->stability_poly[k];
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestStabilityPolynomials(void)
{
  const PetscReal euler[] = {1, 1}, heun[] = {1, 1, 0.5}, rk3[] = {1, 1, 0.5, 1.0 / 6}, rk4[] = {1, 1, 0.5, 1.0 / 6, 1.0 / 24}, ssp43[] = {1, 1, 0.5, 1.0 / 6, 1.0 / 48};
  PetscReal       x, ref, c[MSIM_STABILITY_MAX_DEGREE + 1];
  PetscInt        degree;

  PetscFunctionBeginUser;
  PetscCall(MSimStabilityPolynomialLimit(4, rk4, 0, &x));
  CHECK(std::abs(x - 2 * PETSC_SQRT2) <= 1e-12, "RK4's imaginary-axis limit %.15g, not 2 sqrt(2)", (double)x);
  PetscCall(MSimStabilityPolynomialLimit(3, rk3, 0, &x));
  CHECK(std::abs(x - std::sqrt(3.0)) <= 1e-12, "RK3's imaginary-axis limit %.15g, not sqrt(3)", (double)x);
  PetscCall(MSimStabilityPolynomialLimit(1, euler, 0, &x));
  CHECK(x == 0, "forward Euler's imaginary-axis limit %g, not 0", (double)x);
  PetscCall(MSimStabilityPolynomialLimit(2, heun, 0, &x));
  CHECK(x == 0, "Heun's imaginary-axis limit %g, not 0", (double)x);
  for (PetscReal sd : {1e-6, 1e-3, 0.1}) {
    PetscCall(MSimStabilityPolynomialLimit(1, euler, sd, &x));
    CHECK(std::abs(x - 2 * sd) <= 1e-12 * sd, "forward Euler with drag s = %g: limit %.15g, not 2 s", (double)sd, (double)x);
  }
  NOTE("stability polynomials: RK4 2 sqrt(2), RK3 sqrt(3), Euler and Heun 0, Euler with drag 2 s\n");
  PetscCall(TSLimit("-ts_type rk -ts_rk_type 4 -ts_adapt_type none", &x, &degree, c));
  CHECK(std::abs(x - 2 * PETSC_SQRT2) <= 1e-12, "ts rk 4: limit %.15g, not 2 sqrt(2)", (double)x);
  PetscCall(TSLimit("-ts_type rk -ts_rk_type 3 -ts_adapt_type none", &x, &degree, c));
  CHECK(std::abs(x - std::sqrt(3.0)) <= 1e-12, "ts rk 3: limit %.15g, not sqrt(3)", (double)x);
  PetscCall(TSLimit("-ts_type rk -ts_rk_type 1fe -ts_adapt_type none", &x, &degree, c));
  CHECK(x == 0, "ts rk 1fe: limit %g, not 0", (double)x);
  PetscCall(TSLimit("-ts_type euler", &x, &degree, c));
  CHECK(x == 0, "ts euler: limit %g, not 0", (double)x);
  PetscCall(TSLimit("-ts_type ssp -ts_ssp_type rks3 -ts_ssp_nstages 4", &x, &degree, c));
  PetscCall(MSimStabilityPolynomialLimit(4, ssp43, 0, &ref));
  CHECK(degree == 4 && std::abs(x - ref) <= 1e-12, "ts ssp rks3 with 4 stages: degree %" PetscInt_FMT ", limit %.15g, SSP(4,3)'s %.15g", degree, (double)x, (double)ref);
  NOTE("ts ssp rks3 4 stages: limit %.12g (SSP(4,3): %.12g)\n", (double)x, (double)ref);
  PetscCall(TSLimit("-ts_type ssp -ts_ssp_type rk104", &x, &degree, c));
  CHECK(degree == 10, "ts ssp rk104: degree %" PetscInt_FMT ", not its 10 stages", degree);
  for (PetscInt k = 0, f = 1; k <= 4; k++, f *= PetscMax(k, 1)) CHECK(std::abs(c[k] - 1.0 / f) <= 1e-14, "ts ssp rk104: c_%" PetscInt_FMT " = %.17g, not 1/%" PetscInt_FMT "!", k, (double)c[k], k);
  NOTE("ts ssp rk104: limit %.12g\n", (double)x);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestSpectrum(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestStabilityPolynomials());
  PetscCall(TestChainEigenvalues());
  PetscCall(TestGuard());
  PetscCall(TestStabilityLimits());
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestSpectrum)
