/* Time loop: stability guard, steps, monitors, output, divergence detection. */
#include <csignal>
#include <msim/run.h>
#include <msim/errors.h>
#include <msim/spectrum.h>
#include <msim/contact.h>
#include <msim/contact_force.h>
#include <msim/implicit.h>
#include <msim/signals.h>
#include <msim/log.h>
#include <msim/private/integratorimpl.h>
#include <msim/private/systemimpl.h>
#include <cmath>

/* |R(x mu)|^2 - 1 = sum_m p[m] x^m for R(z) = sum_k c[k] z^k and mu = -s + i sqrt(1 - s^2) */
static void StabilityModulusPolynomial(PetscInt degree, const PetscReal c[], PetscReal s, PetscReal p[])
{
  PetscReal are[MSIM_STABILITY_MAX_DEGREE + 1], aim[MSIM_STABILITY_MAX_DEGREE + 1], mre = -s, mim = PetscSqrtReal(1 - s * s), zre = 1, zim = 0;

  for (PetscInt k = 0; k <= degree; k++) { /* a_k = c_k mu^k */
    are[k] = c[k] * zre;
    aim[k] = c[k] * zim;
    const PetscReal t = zre * mre - zim * mim;
    zim = zre * mim + zim * mre;
    zre = t;
  }
  for (PetscInt m = 0; m <= 2 * degree; m++) {
    p[m] = 0;
    for (PetscInt j = PetscMax(0, m - degree); j <= PetscMin(m, degree); j++) p[m] += are[j] * are[m - j] + aim[j] * aim[m - j];
  }
  p[0] -= 1;
}

/* The largest x = h omega with |R(x' mu)| <= 1 for every x' in [0, x], where R(z) = sum_k c[k] z^k
   is an explicit method's stability polynomial and mu = -s + i sqrt(1 - s^2) the direction of the
   eigenvalue h lambda of a spring mode of frequency omega with drag (s = gamma / (2 omega); 0:
   undamped, the imaginary axis); 0 where no step is stable. |R(x mu)|^2 - 1 is a polynomial in x
   whose lowest terms vanish by the method's order conditions, which the tableau's rounding leaves
   at ~1e-16: those below 1e-10 are taken as 0 (the first true one is 1/72 for RK4, 2s for any
   method with drag), the rest divided by the lowest power left, and the first root is found on a
   geometric grid to the Cauchy bound, then by bisection. */
PetscErrorCode MSimStabilityPolynomialLimit(PetscInt degree, const PetscReal c[], PetscReal s, PetscReal *x)
{
  PetscReal       p[2 * MSIM_STABILITY_MAX_DEGREE + 1], bound = 0, lo, hi;
  PetscInt        m0 = 1, top = 2 * degree;
  const PetscInt  n  = 100000;
  auto            Q  = [&](PetscReal xx) {
    PetscReal q = 0;
    for (PetscInt m = top; m >= m0; m--) q = q * xx + p[m];
    return q;
  };

  PetscFunctionBeginUser;
  PetscCheck(degree >= 1 && degree <= MSIM_STABILITY_MAX_DEGREE, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "stability polynomial of degree %" PetscInt_FMT " (1 to %d)", degree, MSIM_STABILITY_MAX_DEGREE);
  StabilityModulusPolynomial(degree, c, PetscMin(PetscMax(s, 0), 1), p);
  while (top > 0 && p[top] == 0) top--;
  while (m0 < top && PetscAbsReal(p[m0]) < 1e-10) m0++;
  *x = 0;
  if (p[m0] > 0 || top <= m0) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt m = m0; m < top; m++) bound = PetscMax(bound, PetscAbsReal(p[m] / p[top]));
  bound += 1;
  lo = 0;
  hi = bound;
  for (PetscInt i = 0; i <= n; i++) {
    const PetscReal xi = bound * PetscPowReal(10.0, -12.0 + 12.0 * i / n);
    if (Q(xi) > 0) {
      hi = xi;
      break;
    }
    lo = xi;
  }
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; it++) {
    const PetscReal mid = 0.5 * (lo + hi);
    if (Q(mid) > 0) hi = mid;
    else lo = mid;
  }
  *x = lo;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Largest stable h for an explicit method given omega_max. Without damping: limit / omega_max.
   Explicit Euler has limit 0 undamped; with drag rate gamma = c/m it is stable iff
   h <= gamma / omega_max^2 (|1 + h lambda| <= 1 for lambda = -gamma/2 +- i omega_d), and any other
   method with limit 0 and a stability polynomial where |R(h lambda)| <= 1 first fails (the same
   for Euler's 1 + z). Drag is not counted where the limit is above 0 (RK4's 2 sqrt(2) / omega_max
   either way). */
PetscErrorCode MSimStabilityLimit(MSimSystem sys, MSimIntegrator integ, PetscReal omega_max, PetscReal *hcrit)
{
  PetscReal mmax;

  PetscFunctionBeginUser;
  *hcrit = PETSC_INFINITY;
  if (integ->stability_limit >= PETSC_INFINITY || omega_max <= 0) PetscFunctionReturn(PETSC_SUCCESS);
  if (integ->stability_limit > 0) *hcrit = integ->stability_limit / omega_max;
  else {
    PetscCall(VecMax(sys->mass, NULL, &mmax));
    *hcrit = sys->drag > 0 ? (sys->drag / mmax) / (omega_max * omega_max) : 0.0;
    if (sys->drag > 0 && integ->stability_degree > 0) {
      PetscReal x;
      PetscCall(MSimStabilityPolynomialLimit(integ->stability_degree, integ->stability_poly, (sys->drag / mmax) / (2 * omega_max), &x));
      *hcrit = x / omega_max;
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MSimGuard(MSimSystem sys, MSimIntegrator integ, Vec X, MSimRunInfo *info)
{
  PetscBool check = PETSC_TRUE;
  char      bound[16] = "gershgorin";
  PetscReal omega2, hcrit;
  PetscBool slepc;

  PetscFunctionBeginUser;
  PetscOptionsBegin(sys->comm, NULL, "msim stability guard", NULL);
  PetscCall(PetscOptionsBool("-msim_spectrum_check", "Warn before stepping when h exceeds the explicit method's stability limit", NULL, check, &check, NULL));
  PetscCall(PetscOptionsString("-msim_spectrum_guard", "Bound the guard uses for omega_max: gershgorin (cheap) or slepc", NULL, bound, bound, sizeof(bound), NULL));
  PetscOptionsEnd();
  if (!check || integ->stability_limit >= PETSC_INFINITY) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscStrcmp(bound, "slepc", &slepc));
  if (slepc) {
    PetscCall(MSimSpectrumOmegaMax(sys, X, &omega2));
    omega2 *= omega2;
  } else {
    PetscBool g;
    PetscCall(PetscStrcmp(bound, "gershgorin", &g));
    PetscCheck(g, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_spectrum_guard %s is not known (use gershgorin or slepc)", bound);
    PetscCall(MSimSystemGershgorin(sys, &omega2));
  }
  info->omega_max_bound = PetscSqrtReal(omega2);
  PetscCall(MSimStabilityLimit(sys, integ, info->omega_max_bound, &hcrit));
  info->critical_dt = hcrit;
  if (integ->dt > hcrit) {
    info->warned = PETSC_TRUE;
    if (hcrit > 0)
      PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: -msim_dt %g exceeds the stability limit h <= %g of %s (omega_max <= %g from the %s bound)\n", (double)integ->dt, (double)hcrit, integ->type, (double)info->omega_max_bound, slepc ? "SLEPc" : "Gershgorin"));
    else
      PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: %s is unstable for every h without drag (omega_max <= %g from the %s bound); add -msim_drag or use another integrator\n", integ->type, (double)info->omega_max_bound, slepc ? "SLEPc" : "Gershgorin"));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimRun(MSimSystem sys, MSimIntegrator integ, Vec X, Vec V, MSimRunInfo *info)
{
  MSimMonitor    mon;
  MSimProgress   progress;
  MSimOutput     out;
  MSimCheckpoint ck;
  MSimStopSignal stop;
  PetscInt       step0 = 0;
  PetscReal      t_ck = 0, dt_ck = 0, E0_ck = 0;
  PetscBool      restarted;
  PetscBool   want_mon, want_out;
  PetscReal   factor = 10, kin, pot, E0, scale, gnorm, vobs, Ug0, Ug = 0;
  PetscInt    check_every = 10, last_good = 0;
  Vec         Xgood, Vgood, Xprev, Vprev; /* the last checked state; the one before this step */
  Vec         G;                          /* -m g per dof: gravity's potential of X is G.X */

  PetscFunctionBeginUser;
  *info = MSimRunInfo();
  info->critical_dt = PETSC_INFINITY;
  PetscOptionsBegin(sys->comm, NULL, "msim divergence detection", NULL);
  PetscCall(MSimOptionsReal("-msim_divergence_factor", "Stop when the total energy E (kinetic + potential, gravity's included) rises above its start E0 by more than this factor times the energy scale |E0| + M g (D + rise) + M (u^2 + w^2 + v^2)/2 (+ the contact barriers' start energy): M the mass, g gravity, D the scene's diagonal, rise how far gravity's potential of the free vertices has risen above its start (per M g), u the handles', w the wind's and v the fastest obstacle's speed; that bounds what the handles, wind and obstacles can add, and a blow-up passes any multiple of it within steps. Energy lost (damping, drag, friction, an implicit scheme, an inelastic landing) never stops a run; a state that is not finite always does", NULL, factor, &factor, NULL));
  PetscCall(MSimOptionsInt("-msim_divergence_check_every", "Check energy every k steps (always every step when monitoring)", NULL, check_every, &check_every, NULL));
  PetscOptionsEnd();
  PetscCheck(factor > 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_divergence_factor must be > 0 (got %g)", (double)factor);
  PetscCheck(check_every >= 1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_divergence_check_every must be >= 1 (got %" PetscInt_FMT ")", check_every);
  /* -log_view: the run's set-up in the Setup stage, its frames and monitor rows (the first
     frame's too) with its steps in Stepping (the integrator's set-up was in Setup, the rest,
     the first frame's write included, in the main stage: 21% of a short cloth_pd run) */
  PetscCall(PetscLogStagePush(MSIM_StageSetup));
  PetscCall(MSimMonitorCreate(sys->comm, &mon));
  PetscCall(MSimProgressCreate(sys->comm, integ->steps, &progress));
  PetscCall(MSimOutputCreate(sys, &out));
  PetscCall(MSimCheckpointCreate(sys, &ck));
  PetscCall(MSimMonitorWanted(&mon, &want_mon));
  integ->want_phi = want_mon;
  PetscCall(MSimIntegratorSetUp(integ));
  PetscCall(MSimContactRefuseUnread(sys, integ->type));
  PetscCall(MSimContactCheckPenaltyStep(sys, integ->type, integ->dt));
  PetscCall(MSimContactForceSetIntegrator(sys, integ->type)); /* the frames' and monitor's contact force */
  PetscCall(MSimGuard(sys, integ, X, info));
  PetscCall(MSimCheckpointSetIntegrator(ck, integ));
  PetscCall(MSimCheckpointRestart(ck, integ->steps, X, V, &step0, &t_ck, &dt_ck, &E0_ck, &restarted));
  if (restarted) { /* the obstacles may be new: the barrier's state must be outside them */
    PetscBool barrier;
    PetscCall(MSimImplicitSchemeIsRegistered(integ->type, &barrier));
    PetscCall(MSimContactCheckRestart(sys, t_ck, X, barrier));
  }
  {
    /* the state the steps start from, the scene's or the checkpoint's: a checkpoint written
       without self-contact or the inversion barrier can hold a surface through itself or an
       inverted tet, which the barrier would keep so (a restart from a crossing state ran on) */
    char ckstate[PETSC_MAX_PATH_LEN + 96];
    if (restarted) PetscCall(MSimCheckpointRestartState(ck, step0, t_ck, ckstate, sizeof(ckstate)));
    PetscCall(MSimIntegratorCheckStart(integ, restarted ? t_ck : 0.0, X, restarted ? ckstate : NULL));
  }
  /* all input is valid from here on: create the output directory (a monitor file may live in
     it), then open the monitor files */
  PetscCall(MSimOutputSetUp(out));
  if (restarted) PetscCall(MSimOutputResume(out, step0));
  integ->first_step = step0 + 1;
  {
    PetscErrorCode merr = MSimCheckpointCheckWritable(ck); /* first: a refusal leaves no file behind */
    if (!merr) merr = MSimViewFinalCheckWritable(sys);
    if (!merr) merr = MSimMonitorSetUp(sys->comm, &mon, restarted ? step0 : -1, t_ck);
    if (!merr && integ->ops.openfiles) merr = integ->ops.openfiles(integ);
    if (merr) { /* refused before anything is written: the new output directory goes again */
      PetscCall(MSimOutputRemoveIfUnused(out));
      PetscCall(merr);
    }
  }
  /* the time at step k: k h while the checkpoint's time is the step's k h (bit for bit the
     uninterrupted run's clock), else from the checkpoint's time. The step size alone does not
     tell: a run restarted with another step size writes checkpoints at t_ck + (k - step0) h with
     that h, and a restart from one of those with the same h, taken for k h, went back in time
     (dt 0.01 to step 10, 0.005 to step 20 at t = 0.15, then step 21 at t = 0.105: the monitor's
     t, the frames' and the moving handles, which jumped back by 0.05 s of their path) */
  const PetscBool same_clock = (PetscBool)(!restarted || t_ck == step0 * integ->dt);
  auto            time_at    = [&](PetscInt k) { return same_clock ? k * integ->dt : t_ck + (k - step0) * integ->dt; };

  /* Divergence test. A run's energy balance is E - E0 = W - D: D >= 0 what damping, drag,
     friction, an inelastic landing or an implicit scheme dissipate, W the work of what the
     options drive. Handles moving at u, wind w and obstacles moving at v can give the mass M at
     most their kinetic energy M (u^2 + w^2 + v^2)/2 and lift it: gravity's potential rises by
     M g times that lift, counted as it happens (Ug - Ug0, the free vertices' gravity potential
     against the start's). So E - E0 <= W, and a growth many times the scale below, the start's
     energy, that lift and those kinetic energies, plus M g D (what gravity can move between
     forms over the scene's diagonal D: an explicit scheme's bounded energy error), is not
     physical: a blow-up grows the energy geometrically and passes any multiple within steps.
     Energy lost is never divergence (a 10 x 10 cloth dropped 15 m, the 147 J gravity gave it
     lost in the landing, was stopped by the old test of |E - E0| against 10 x 14 J). */
  PetscCall(MSimSystemComputeEnergy(sys, 0, X, V, &kin, &pot));
  PetscCall(MSimContactObstacleSpeed(sys, &vobs));
  E0    = restarted ? E0_ck : kin + pot; /* a restarted run compares with the first run's start */
  gnorm = PetscSqrtReal(sys->gravity[0] * sys->gravity[0] + sys->gravity[1] * sys->gravity[1] + sys->gravity[2] * sys->gravity[2]);
  scale = PetscAbsReal(E0) + sys->total_mass * gnorm * sys->diameter + 0.5 * sys->total_mass * (sys->fix_velocity[0] * sys->fix_velocity[0] + sys->fix_velocity[1] * sys->fix_velocity[1] + sys->fix_velocity[2] * sys->fix_velocity[2] + sys->wind[0] * sys->wind[0] + sys->wind[1] * sys->wind[1] + sys->wind[2] * sys->wind[2] + vobs * vobs) + PETSC_SMALL;
  PetscCall(PetscLogStagePop());
  PetscCall(PetscLogStagePush(MSIM_StageStep));
  if (!restarted) { /* a restarted run has these from the first */
    if (want_mon) {
      PetscReal contact[5];
      PetscCall(MSimContactForce(sys, 0.0, X, NULL, contact));
      PetscCall(MSimMonitorWrite(sys->comm, &mon, 0, 0.0, kin, pot, 0, 0, 0.0, 0.0, contact));
    }
    PetscCall(MSimOutputWanted(out, 0, integ->steps, &want_out));
    if (want_out) PetscCall(MSimOutputWriteFrame(out, 0, 0.0, X, V));
  }
  last_good         = step0;
  integ->step       = step0; /* counted up by each MSimIntegratorStep */
  integ->first_step = step0 + 1;
  PetscCall(VecDuplicate(X, &Xgood));
  PetscCall(VecDuplicate(V, &Vgood));
  PetscCall(VecDuplicate(X, &Xprev));
  PetscCall(VecDuplicate(V, &Vprev));
  PetscCall(VecCopy(X, Xgood));
  PetscCall(VecCopy(V, Vgood));
  /* gravity's potential at the scene's start (a restarted run's too), from which the energy
     scale counts the rise */
  PetscCall(VecDuplicate(sys->mass, &G));
  {
    PetscScalar *g;
    PetscInt     n3;
    PetscCall(VecGetLocalSize(G, &n3));
    PetscCall(VecGetArray(G, &g));
    for (PetscInt i = 0; i < n3; i++) g[i] = -sys->gravity[i % 3];
    PetscCall(VecRestoreArray(G, &g));
  }
  PetscCall(VecPointwiseMult(G, G, sys->mass));
  PetscCall(VecDot(G, sys->X0, &Ug0));
  /* the test at a state of time t: its energies and whether it stops the run */
  auto Diverged = [&](PetscReal t, Vec x, Vec v, PetscReal *k, PetscReal *p, PetscReal *ug, PetscBool *out) -> PetscErrorCode {
    PetscCall(MSimSystemComputeEnergy(sys, t, x, v, k, p));
    PetscCall(VecDot(G, x, ug));
    *out = (PetscBool)(PetscIsInfOrNanReal(*k + *p) || *k + *p - E0 > factor * (scale + PetscMax(*ug - Ug0, 0)));
    return PETSC_SUCCESS;
  };

  /* a run that ends inside the loop (diverged, or stopped by a signal) closes what it opened,
     keeping what it wrote */
  auto EndEarly = [&]() -> PetscErrorCode {
    PetscCall(MSimStopSignalEnd(&stop));
    PetscCall(MSimMonitorDestroy(sys->comm, &mon));
    PetscCall(MSimOutputDestroy(&out));
    PetscCall(MSimCheckpointDestroy(&ck));
    PetscCall(VecDestroy(&Xgood));
    PetscCall(VecDestroy(&Vgood));
    PetscCall(VecDestroy(&Xprev));
    PetscCall(VecDestroy(&Vprev));
    PetscCall(VecDestroy(&G));
    PetscCall(PetscLogStagePop());
    PetscCall(MSimLogHideUnusedStages(sys->comm));
    return PETSC_SUCCESS;
  };
  /* the warnings that explain a run, printed after its steps, also when it stops on an error:
     they may name its cause (a handle driven into an obstacle, steps cut off at -snes_max_it
     before a divergence), which a failing run did not say. They count this run's steps up to n,
     the last one taken (a restarted run's counters start at its checkpoint) */
  auto Summarise = [&](PetscInt n) -> PetscErrorCode {
    if (integ->saddle_steps)
      PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: in %" PetscInt_FMT " of %" PetscInt_FMT " steps Newton converged to a saddle point of Phi, not a minimum (up to %" PetscInt_FMT " negative eigenvalues of the exact Hessian): an unstable state, usually a cloth compressed flat; -msim_inertia_correction or a descent method (-msim_psd 1, pd, qn) moves off it\n", integ->saddle_steps, n - step0, integ->saddle_negative));
    if (integ->unconverged_steps)
      PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: in %" PetscInt_FMT " of %" PetscInt_FMT " steps %s\n", integ->unconverged_steps, n - step0, integ->tolerance));
    if (integ->stalled_steps)
      PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: in %" PetscInt_FMT " of %" PetscInt_FMT " steps the solve stalled and did not converge: %s\n", integ->stalled_steps, n - step0, integ->stall));
    {
      /* the start's barrier energy, released as kinetic energy by the pairs within the contact
         distance: named where it exceeds the scene's energy scale, or where the obstacles' part
         could lift the scene's mass clear of their contact distance, out of contact (a cloth 1 mm over a floor,
         dhat 2.8 mm, h = 1e-3 with the default kappa ~ 1/h^2: 0.54 J stored, the monitor's total up
         0.18 J, hopped 1.8 cm unannounced) */
      const PetscReal eb = integ->barrier_energy0, eo = integ->barrier_obstacles0, es = eb - eo, other = scale - eb;
      if (eb > other || eo > sys->total_mass * gnorm * integ->barrier_dhat0) {
        char held[768] = "", lift[96] = "";
        if (eo > 0) PetscCall(PetscSNPrintf(held, sizeof(held), ", obstacles %g J within the contact distance %g m (%s)", (double)eo, (double)integ->barrier_dhat0, integ->barrier_near0));
        if (es > 0) PetscCall(PetscStrlcat(held, ", self-contact pairs within the self-contact distance the rest", sizeof(held)));
        if (gnorm > 0) PetscCall(PetscSNPrintf(lift, sizeof(lift), ", enough to lift the scene's mass %g m", (double)(eb / (sys->total_mass * gnorm))));
        PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: the contact barriers held %g J at the start%s; %g x the scene's energy scale %g J%s: elements that start within the contact distance (-msim_self_contact_start_gap below it, a vertex near an obstacle, or moving handles whose first step brings elements that near) spring apart and turn it into kinetic energy, more as the step is shorter (the default stiffness grows as 1/h^2); a start resting in contact needs its gaps near that distance, or a smaller %s%s%s\n", (double)eb, held, (double)(eb / other), (double)other, lift, eo > 0 ? "-msim_contact_distance" : "", eo > 0 && es > 0 ? " and " : "", es > 0 ? "-msim_self_contact_distance" : ""));
      }
    }
    PetscCall(MSimContactWarnHandles(sys));
    return PETSC_SUCCESS;
  };
  /* the run stopped by a signal after step k, the last whole one (cut: the signal came inside step
     k + 1, which was given up): its checkpoint written where asked, one line (quiet for a closed
     standard output) */
  auto Stop = [&](int signal_seen, PetscInt k, PetscReal tk, PetscBool cut) -> PetscErrorCode {
    /* stopped inside this run's first step: no step was taken, and the start is the scene's or the
       checkpoint's it restarted from, so nothing is written (a checkpoint of it would hold what the
       first step's BeginStep made up, BDF2's start-up past state, as history: restarted from it,
       step 1 was a full BDF2 step, 1.2e-3 against 5.3e-4 J of kinetic energy) */
    const PetscBool first = (PetscBool)(cut && k == step0);
    if (!first) PetscCall(MSimCheckpointWrite(ck, k, tk, integ->dt, E0, X, V));
    info->steps_done = k;
    info->t          = tk;
    if (signal_seen == SIGPIPE) { /* standard output's reader left: stop as for SIGTERM, quietly */
      PetscCall(EndEarly());
      return PETSC_ERR_SIG;
    }
    /* SIGINT or SIGTERM (a batch system's time limit) */
    char how[PETSC_MAX_PATH_LEN + 96], when[128];
    if (first) PetscCall(PetscSNPrintf(how, sizeof(how), "no step of this run was completed, so nothing was saved"));
    else PetscCall(MSimCheckpointPath(ck, how, sizeof(how)));
    /* C's %g: PETSc's prints 1 as "1." */
    if (cut) snprintf(when, sizeof(when), "t = %g s, step %" PetscInt_FMT " given up where it came", (double)tk, k + 1);
    else snprintf(when, sizeof(when), "t = %g s", (double)tk);
    PetscCall(Summarise(k));
    PetscCall(EndEarly());
    SETERRQ(sys->comm, PETSC_ERR_SIG, "stopped by %s after step %" PetscInt_FMT " of %" PetscInt_FMT " (%s); %s", signal_seen == SIGINT ? "SIGINT" : "SIGTERM", k, integ->steps, when, how);
  };
  PetscCall(MSimProgressBegin(&progress, step0));
  PetscCall(MSimStopSignalBegin(sys->comm, &stop));
  /* the time loop. Every way out of it ends the stop poll: an error inside a step (a solver's
     -ksp_error_if_not_converged, a frame that cannot be written) returned with the in-step
     poll's MPI_Iallreduce still pending at MPI_Finalize, and SIGINT/SIGTERM only noted, never
     acted on, for the rest of the run's teardown */
  auto Steps = [&]() -> PetscErrorCode {
    for (PetscInt n = step0 + 1; n <= integ->steps; n++) {
      const PetscReal t0 = time_at(n - 1), t = time_at(n);
      int             signal_seen;
      PetscBool       check = (PetscBool)(want_mon || n % check_every == 0 || n == integ->steps), bad = PETSC_FALSE, solver_failed;

      if (last_good != n - 1) { /* x_{n-1} was not checked: kept, so a failure here can still save it */
        PetscCall(VecCopy(X, Xprev));
        PetscCall(VecCopy(V, Vprev));
      }
      PetscCall(MSimIntegratorStep(integ, t0, X, V));
      if (n == 1) {
        /* the energy the contact barriers held at the start (known once the first step began),
           which pairs that start within the contact distance release as kinetic energy: part of
           the start's energy, as a checkpoint then carries it (a restarted run has E0 from it) */
        E0 += integ->barrier_energy0;
        scale += integ->barrier_energy0;
      }
      if (integ->stopped) { /* a signal inside the step: X, V are step n - 1's again */
        return Stop(MSimStopSignalAgreedInStep(), n - 1, t0, PETSC_TRUE);
      }
      PetscCall(MSimContactWatchHandles(sys, n, t0, t));
      solver_failed = integ->failed; /* the implicit solver gave up on this step */
      if (solver_failed) bad = PETSC_TRUE;
      if (check && !bad) PetscCall(Diverged(t, X, V, &kin, &pot, &Ug, &bad));
      if (bad) {
        char      limit[128] = "", why[256] = "";
        PetscBool prev_finite = PETSC_FALSE; /* step n - 1, where it was not checked before: finite */
        if (info->critical_dt < PETSC_INFINITY) PetscCall(PetscSNPrintf(limit, sizeof(limit), ", predicted limit h <= %g", (double)info->critical_dt));
        if (!solver_failed) {
          if (PetscIsInfOrNanReal(kin + pot)) PetscCall(PetscSNPrintf(why, sizeof(why), ": the state is not finite"));
          else snprintf(why, sizeof(why), ": the total energy rose by %g J (%g -> %g J), more than -msim_divergence_factor %g x the energy scale %g J", (double)(kin + pot - E0), (double)E0, (double)(kin + pot), (double)factor, (double)(scale + PetscMax(Ug - Ug0, 0))); /* C's %g: PETSc's prints 10 as "10." */
        }
        info->diverged   = PETSC_TRUE;
        info->steps_done = n;
        info->t          = t;
        if (last_good != n - 1) {
          /* the steps since the last check were not checked (-msim_divergence_check_every): the one
             before this is the last finite state if it passes the same test (a failed solve at step
             2 named and saved step 0, up to k - 1 good steps lost) */
          PetscReal k0, p0, u0;
          PetscBool bad0 = PETSC_TRUE;
          PetscCall(Diverged(t0, Xprev, Vprev, &k0, &p0, &u0, &bad0));
          prev_finite = (PetscBool)!PetscIsInfOrNanReal(k0 + p0);
          if (!bad0) {
            last_good = n - 1;
            PetscCall(VecSwap(Xgood, Xprev));
            PetscCall(VecSwap(Vgood, Vprev));
          }
        }
        /* the state kept: the last that passed the test, with what is known of the steps after it
           (not checked between checks; the step before this one checked just above) */
        char last[256], when[128];
        if (last_good == n - 1) PetscCall(PetscSNPrintf(last, sizeof(last), "last finite state is step %" PetscInt_FMT, last_good));
        else {
          char between[128] = "";
          if (n - 2 > last_good) PetscCall(PetscSNPrintf(between, sizeof(between), "steps %" PetscInt_FMT " to %" PetscInt_FMT " not checked at -msim_divergence_check_every %" PetscInt_FMT ", ", last_good + 1, n - 2, check_every));
          PetscCall(PetscSNPrintf(last, sizeof(last), "last state that passed the divergence test is step %" PetscInt_FMT ", kept as the last finite state (%sstep %" PetscInt_FMT " %s)", last_good, between, n - 1, prev_finite ? "finite but already past its energy bound" : "not finite"));
        }
        /* a failed step that got part of the way (a TS's internal steps): where it stopped */
        if (solver_failed && integ->failed_t >= 0) snprintf(when, sizeof(when), "stopped at t = %g s, within %g -> %g s", (double)integ->failed_t, (double)t0, (double)t); /* C's %g */
        else snprintf(when, sizeof(when), "t = %g s", (double)t);
        /* the run's outcome is the line: a write or close that fails on the way out (the disk
           full) is added to it, not raised in its place (the divergence went unsaid). Collective:
           every rank gets the same code from the writes' agreement */
        std::string    wmsg, emsg;
        PetscErrorCode werr = MSimCaptureError([&]() -> PetscErrorCode { return MSimOutputWriteExtra(out, "last_finite", time_at(last_good), Xgood, Vgood); }, wmsg);
        PetscCall(VecCopy(Xgood, X));
        PetscCall(VecCopy(Vgood, V));
        PetscCall(Summarise(n));
        PetscErrorCode eerr = MSimCaptureError([&]() -> PetscErrorCode { return EndEarly(); }, emsg);
        std::string    also = werr ? "; writing the last finite state failed: " + wmsg : "";
        if (eerr) also += "; closing the run's files failed: " + emsg;
        SETERRQ(sys->comm, PETSC_ERR_NOT_CONVERGED, "%s%s at step %" PetscInt_FMT " (%s)%s; %s, h = %g%s; %s%s", solver_failed ? (integ->failed_what ? integ->failed_what : "the nonlinear solver failed") : "diverged", solver_failed ? integ->failure : "", n, when, why, integ->type, (double)integ->dt, limit, last, also.c_str());
      }
      if (check) {
        last_good = n;
        PetscCall(VecCopy(X, Xgood));
        PetscCall(VecCopy(V, Vgood));
      }
      if (want_mon) {
        PetscReal contact[5]; /* at the step's result, as the frame's contact_force */
        PetscCall(MSimContactForce(sys, t, X, NULL, contact));
        PetscCall(MSimMonitorWrite(sys->comm, &mon, n, t, kin, pot, integ->nonlinear_its, integ->linear_its, integ->residual, integ->phi, contact));
      }
      PetscCall(MSimOutputWanted(out, n, integ->steps, &want_out));
      if (want_out) PetscCall(MSimOutputWriteFrame(out, n, t, X, V));
      PetscCall(MSimStopSignalPoll(&stop, &signal_seen));
      PetscCall(MSimCheckpointWanted(ck, n, integ->steps, &want_out));
      if (want_out && !signal_seen) PetscCall(MSimCheckpointWrite(ck, n, t, integ->dt, E0, X, V));
      if (signal_seen) return Stop(signal_seen, n, t, PETSC_FALSE);
      PetscCall(MSimProgressUpdate(&progress, n, t));
    }
    return PETSC_SUCCESS;
  };
  {
    const PetscErrorCode serr = Steps();
    if (serr) {
      PetscCall(MSimStopSignalEnd(&stop)); /* done already where the loop stopped for a signal or a divergence */
      PetscFunctionReturn(serr);
    }
  }
  PetscCall(MSimStopSignalEnd(&stop));
  PetscCall(MSimCheckpointDestroy(&ck));
  info->steps_done = integ->steps;
  info->t          = time_at(integ->steps);
  PetscCall(Summarise(integ->steps));
  PetscCall(MSimViewFinal(sys, info->t, X));
  PetscCall(MSimMonitorDestroy(sys->comm, &mon));
  PetscCall(MSimOutputDestroy(&out));
  PetscCall(PetscLogStagePop()); /* the final state's view and the series' closing in Stepping too */
  PetscCall(MSimLogHideUnusedStages(sys->comm));
  PetscCall(VecDestroy(&Xgood));
  PetscCall(VecDestroy(&Vgood));
  PetscCall(VecDestroy(&Xprev));
  PetscCall(VecDestroy(&Vprev));
  PetscCall(VecDestroy(&G));
  PetscFunctionReturn(PETSC_SUCCESS);
}
