/* Physics of the explicit integrators, checked against what can be derived:
   - two masses on a spring oscillate with period 2 pi sqrt(mu/k) (RK4, within 0.5%);
   - rk4 and symplectic_euler agree with their PETSc TS counterparts to roundoff;
   - symplectic Euler's energy error stays bounded over 10^4 steps below its limit, explicit
     Euler's grows;
   - fixed vertices never move (and moving handles follow b(t) = b0 + t v exactly). */
#include "harness.h"
#include <vector>

static PetscErrorCode SpringLength(TestSim *s, PetscReal *l)
{
  std::vector<PetscReal> all;
  PetscFunctionBeginUser;
  PetscCall(MSimSystemGatherPositions(s->sys, 0, s->X, all));
  if (s->rank == 0) *l = std::sqrt(std::pow(all[3] - all[0], 2) + std::pow(all[4] - all[1], 2) + std::pow(all[5] - all[2], 2));
  PetscCallMPI(MPI_Bcast(l, 1, MPIU_REAL, 0, PETSC_COMM_WORLD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestOscillatorPeriod(void)
{
  /* m = 1 kg each (total 2), k = 100 N/m: mu = 0.5 kg, T = 2 pi sqrt(mu / k) */
  const PetscReal k = 100, mu = 0.5, T = 2 * PETSC_PI * std::sqrt(mu / k), L = 1.0;
  const PetscInt  per = 100, nsteps = 3 * per + 5;
  TestSim         s;
  char            opts[512];
  std::vector<PetscReal> down; /* times at which l crosses L going down */

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(opts, sizeof(opts), "-msim_scene chain -msim_chain_n 2 -msim_chain_length 1 -msim_fix none -msim_gravity 0,0,0 -msim_stiffness %g -msim_mass 2 -msim_prestretch 1.1 -msim_integrator rk4 -msim_dt %.17g", (double)k, (double)(T / per)));
  PetscCall(TestSimCreate(opts, &s));
  PetscReal lprev, l, t = 0;
  PetscCall(SpringLength(&s, &lprev));
  for (PetscInt n = 0; n < nsteps; n++) {
    PetscCall(MSimIntegratorStep(s.integ, t, s.X, s.V));
    t += s.dt;
    PetscCall(SpringLength(&s, &l));
    if (lprev > L && l <= L) down.push_back(t - s.dt * (l - L) / (l - lprev));
    lprev = l;
  }
  CHECK(down.size() >= 3, "found %zu crossings", down.size());
  if (down.size() >= 3) {
    const PetscReal Tm = (down.back() - down.front()) / (down.size() - 1);
    NOTE("two-mass oscillator: period %.8f s, analytic %.8f s, relative error %.2e\n", (double)Tm, (double)T, (double)std::abs(Tm - T) / T);
    CHECK(std::abs(Tm - T) <= 5e-3 * T, "period %g vs %g", (double)Tm, (double)T);
  }
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Runs nsteps of a named integrator and of a TS counterpart; returns |X1 - X2| / |X1|. */
static PetscErrorCode CompareWithTS(const char *base, const char *mine, const char *ts, PetscReal *rel)
{
  TestSim   a, b;
  char      opts[1024];
  PetscReal nx, nd;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(opts, sizeof(opts), "%s -msim_integrator %s", base, mine));
  PetscCall(TestSimCreate(opts, &a));
  PetscCall(PetscSNPrintf(opts, sizeof(opts), "%s -msim_integrator ts %s", base, ts));
  PetscCall(TestSimCreate(opts, &b));
  for (PetscInt n = 0; n < 200; n++) {
    PetscCall(MSimIntegratorStep(a.integ, n * a.dt, a.X, a.V));
    PetscCall(MSimIntegratorStep(b.integ, n * b.dt, b.X, b.V));
  }
  PetscCall(VecNorm(a.X, NORM_2, &nx));
  PetscCall(VecAXPY(b.X, -1.0, a.X));
  PetscCall(VecNorm(b.X, NORM_2, &nd));
  *rel = nd / nx;
  PetscCall(TestSimDestroy(&a));
  PetscCall(TestSimDestroy(&b));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestTSCounterparts(void)
{
  const char *base = "-msim_scene cloth -msim_cloth_n 8 -msim_dt 5e-4 -msim_fix_velocity 0.1,0,0";
  PetscReal   rel;

  PetscFunctionBeginUser;
  PetscCall(CompareWithTS(base, "rk4", "-ts_type rk -ts_rk_type 4 -ts_adapt_type none", &rel));
  NOTE("rk4 vs TS rk4: relative difference %.2e\n", (double)rel);
  CHECK(rel < 1e-12, "rk4 differs from -ts_type rk -ts_rk_type 4 by %g", (double)rel);
  PetscCall(CompareWithTS(base, "symplectic_euler", "-ts_type basicsymplectic -ts_basicsymplectic_type 1", &rel));
  NOTE("symplectic_euler vs TS basicsymplectic 1: relative difference %.2e\n", (double)rel);
  CHECK(rel < 1e-12, "symplectic_euler differs from -ts_type basicsymplectic by %g", (double)rel);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Energy over 10^4 steps on an undamped chain without gravity, h omega_max <= 0.25 (an eighth of
   symplectic Euler's limit). final_ratio: E_end / E_0 (infinite once the state overflowed). */
static PetscErrorCode EnergyHistory(const char *integrator, PetscReal *early, PetscReal *late, PetscReal *final_ratio)
{
  TestSim   s;
  char      opts[512];
  PetscReal kin, pot, E0, omega2;
  const PetscInt nsteps = 10000;

  PetscFunctionBeginUser;
  /* omega_max <= Gershgorin bound; choose h = 1/2 of the symplectic limit 2/omega */
  PetscCall(TestSimCreate("-msim_scene chain -msim_chain_n 12 -msim_fix corners -msim_gravity 0,0,0 -msim_perturb 0.01 -msim_stiffness 100 -msim_mass 1", &s));
  PetscCall(MSimSystemGershgorin(s.sys, &omega2));
  PetscCall(TestSimDestroy(&s));
  PetscCall(PetscSNPrintf(opts, sizeof(opts), "-msim_scene chain -msim_chain_n 12 -msim_fix corners -msim_gravity 0,0,0 -msim_perturb 0.01 -msim_stiffness 100 -msim_mass 1 -msim_integrator %s -msim_dt %.17g", integrator, (double)(0.25 / std::sqrt(omega2))));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(MSimSystemComputeEnergy(s.sys, 0, s.X, s.V, &kin, &pot));
  E0     = kin + pot;
  *early = *late = 0;
  for (PetscInt n = 0; n < nsteps; n++) {
    PetscCall(MSimIntegratorStep(s.integ, n * s.dt, s.X, s.V));
    PetscCall(MSimSystemComputeEnergy(s.sys, 0, s.X, s.V, &kin, &pot));
    const PetscReal err = std::abs(kin + pot - E0) / E0;
    if (n < 1000) *early = PetscMax(*early, err);
    if (n >= nsteps - 1000) *late = PetscMax(*late, err);
  }
  *final_ratio = PetscIsInfOrNanReal(kin + pot) ? PETSC_INFINITY : (kin + pot) / E0;
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestEnergyBehaviour(void)
{
  PetscReal early, late, ratio;

  PetscFunctionBeginUser;
  PetscCall(EnergyHistory("symplectic_euler", &early, &late, &ratio));
  NOTE("symplectic Euler: max relative energy error, first 1000 steps %.3e, last 1000 %.3e\n", (double)early, (double)late);
  CHECK(late < 0.1, "symplectic Euler energy error %g is not bounded", (double)late);
  CHECK(late <= 1.5 * early, "symplectic Euler energy drifts: %g early, %g late", (double)early, (double)late);
  PetscCall(EnergyHistory("explicit_euler", &early, &late, &ratio));
  NOTE("explicit Euler: energy after 10^4 steps is %.3e times the initial energy\n", (double)ratio);
  CHECK(ratio > 2.0, "explicit Euler's energy did not grow (ratio %g)", (double)ratio);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestFixedVertices(void)
{
  TestSim                s;
  std::vector<PetscReal> before, after;
  const PetscReal        vfix[3] = {0.3, -0.1, 0.2};

  PetscFunctionBeginUser;
  for (int moving = 0; moving < 2; moving++) {
    PetscCall(TestSimCreate(moving ? "-msim_cloth_n 9 -msim_fix edge -msim_fix_velocity 0.3,-0.1,0.2 -msim_integrator symplectic_euler -msim_dt 2e-4" : "-msim_cloth_n 9 -msim_fix edge -msim_integrator rk4 -msim_dt 2e-4", &s));
    PetscCall(MSimSystemGatherPositions(s.sys, 0, s.X, before));
    const PetscInt nsteps = 300;
    for (PetscInt n = 0; n < nsteps; n++) PetscCall(MSimIntegratorStep(s.integ, n * s.dt, s.X, s.V));
    const PetscReal t = nsteps * s.dt;
    PetscCall(MSimSystemGatherPositions(s.sys, t, s.X, after));
    std::vector<char>     fixed;
    std::vector<PetscInt> cells;
    PetscCall(MSimSystemGatherTopology(s.sys, fixed, cells));
    PetscInt nv;
    PetscCall(MSimSystemGetSizes(s.sys, &nv, NULL, NULL));
    if (s.rank == 0) {
      PetscReal errfix = 0, movefree = 0;
      for (PetscInt v = 0; v < nv; v++)
        for (int c = 0; c < 3; c++) {
          const PetscReal d = after[3 * v + c] - before[3 * v + c];
          if (fixed[v]) errfix = PetscMax(errfix, std::abs(d - (moving ? t * vfix[c] : 0.0)));
          else movefree = PetscMax(movefree, std::abs(d));
        }
      CHECK(errfix <= 1e-14, "fixed vertices strayed by %g (moving %d)", (double)errfix, moving);
      CHECK(movefree > 1e-3, "free vertices did not move (moving %d)", moving);
    }
    PetscCall(TestSimDestroy(&s));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestExplicit(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestOscillatorPeriod());
  PetscCall(TestTSCounterparts());
  PetscCall(TestEnergyBehaviour());
  PetscCall(TestFixedVertices());
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(TestExplicit)
