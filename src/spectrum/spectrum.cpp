/* SLEPc spectra: Krylov-Schur on the GHEP (K, M). M is diagonal, so the mass solve is exact with
   -st_ksp_type preonly -st_pc_type jacobi (the defaults set here; options override). The top of a
   spring spectrum is clustered: ncv defaults to max(2 nev, 64) (FACTS: 34 restarts instead of 831). */
#include <msim/spectrum.h>
#include <msim/output.h>
#include <msim/contact.h>
#include <msim/volume.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <slepceps.h>

static PetscInt MSimSpectrumLastIterations = 0; /* restarts of the last solve, for the report */

static PetscErrorCode MSimSpectrumSolve(MSimSystem sys, Vec X, PetscInt nev, PetscBool largest, PetscReal shift, std::vector<PetscReal> &lambda, std::vector<Vec> *modes)
{
  Mat       K, M;
  EPS       eps;
  ST        st;
  KSP       ksp;
  PC        pc;
  PetscInt  nconv, n = 3 * sys->nfree;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Spectrum, 0, 0, 0, 0));
  PetscCheck(nev >= 1 && nev <= n, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "number of eigenvalues must be in [1, %" PetscInt_FMT "] (got %" PetscInt_FMT ")", n, nev);
  PetscCall(MSimSystemCreateMatrix(sys, &K));
  {
    const MSimMatrixCoefficients c = {0.0, X, 0.0, 0.0, 1.0, PETSC_FALSE, 0.0, NULL, 0.0}; /* K(X) alone */
    PetscCall(MSimSystemAssembleMatrix(sys, &c, K));
    if (largest) PetscCall(MSimContactAddPenaltyStiffness(sys, 0.0, X, K)); /* the explicit penalty's kc, every vertex as if in contact (msim/contact.h) */
    PetscCall(MSimSystemVolumeHessian(sys, 0.0, X, 1.0, PETSC_FALSE, K)); /* the tets' volume term, if any */
  }
  PetscCall(MSimSystemCreateMassMatrix(sys, &M));
  PetscCall(EPSCreate(sys->comm, &eps));
  PetscCall(EPSSetOperators(eps, K, M));
  PetscCall(EPSSetProblemType(eps, EPS_GHEP));
  PetscCall(EPSSetType(eps, EPSKRYLOVSCHUR));
  PetscCall(EPSSetDimensions(eps, nev, PetscMin(n, PetscMax(2 * nev + 16, 64)), PETSC_DEFAULT));
  PetscCall(EPSSetTolerances(eps, 1e-12, 10000));
  PetscCall(EPSGetST(eps, &st));
  PetscCall(STGetKSP(st, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  if (largest) {
    PetscCall(EPSSetWhichEigenpairs(eps, EPS_LARGEST_REAL));
    PetscCall(KSPSetType(ksp, KSPPREONLY));
    PetscCall(PCSetType(pc, PCJACOBI));
  } else {
    /* lowest modes: shift-and-invert about a small negative shift (K is only semidefinite: a
       straight chain or a flat cloth has zero-stiffness transverse modes), so K - shift M is SPD */
    PetscCall(EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE));
    PetscCall(EPSSetTarget(eps, shift));
    PetscCall(STSetType(st, STSINVERT));
    PetscCall(KSPSetType(ksp, KSPPREONLY));
    PetscCall(PCSetType(pc, PCCHOLESKY));
    if (sys->size > 1) PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
    PetscCall(EPSSetOptionsPrefix(eps, "low_"));
  }
  PetscCall(EPSSetFromOptions(eps));
  PetscCall(EPSSolve(eps));
  PetscCall(EPSGetConverged(eps, &nconv));
  PetscCall(EPSGetIterationNumber(eps, &MSimSpectrumLastIterations));
  PetscCheck(nconv >= nev, sys->comm, PETSC_ERR_NOT_CONVERGED, "SLEPc converged %" PetscInt_FMT " of %" PetscInt_FMT " eigenvalues: raise -%seps_max_it or -%seps_ncv", nconv, nev, largest ? "" : "low_", largest ? "" : "low_");
  lambda.resize(nev);
  for (PetscInt k = 0; k < nev; k++) {
    PetscScalar kr;
    Vec         v = NULL;
    if (modes) PetscCall(MatCreateVecs(K, &v, NULL));
    PetscCall(EPSGetEigenpair(eps, k, &kr, NULL, v, NULL));
    lambda[k] = PetscRealPart(kr);
    if (modes) modes->push_back(v);
  }
  PetscCall(EPSDestroy(&eps));
  PetscCall(MatDestroy(&K));
  PetscCall(MatDestroy(&M));
  PetscCall(PetscLogEventEnd(MSIM_Spectrum, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSpectrumLargest(MSimSystem sys, Vec X, PetscInt nev, std::vector<PetscReal> &lambda)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSpectrumSolve(sys, X, nev, PETSC_TRUE, 0.0, lambda, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSpectrumOmegaMax(MSimSystem sys, Vec X, PetscReal *omega_max)
{
  std::vector<PetscReal> lambda;

  PetscFunctionBeginUser;
  PetscCall(MSimSpectrumLargest(sys, X, 1, lambda));
  *omega_max = PetscSqrtReal(PetscMax(lambda[0], 0.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSpectrumFromOptions(MSimSystem sys, Vec X, PetscBool *ran)
{
  PetscBool              on = PETSC_FALSE;
  PetscInt               nlargest = 1, nlow = 0;
  char                   dir[PETSC_MAX_PATH_LEN] = "";
  std::vector<PetscReal> lambda, low;
  std::vector<Vec>       modes;
  PetscReal              mmax;

  PetscBool              set[3];

  PetscFunctionBeginUser;
  PetscOptionsBegin(sys->comm, NULL, "msim spectrum (SLEPc)", NULL);
  PetscCall(PetscOptionsBool("-msim_spectrum", "Compute omega_max and the critical step of each explicit method, then exit", NULL, on, &on, NULL));
  PetscCall(MSimOptionsInt("-msim_spectrum_largest", "With -msim_spectrum: number of largest eigenvalues to print", NULL, nlargest, &nlargest, &set[0]));
  PetscCall(MSimOptionsInt("-msim_spectrum_lowest", "With -msim_spectrum: number of lowest modes (natural frequencies in Hz; options prefix low_)", NULL, nlow, &nlow, &set[1]));
  PetscCall(PetscOptionsString("-msim_spectrum_modes", "With -msim_spectrum: directory for the lowest mode shapes as .vtu files", NULL, dir, dir, sizeof(dir), &set[2]));
  PetscOptionsEnd();
  *ran = on;
  if (!on) {
    /* read above (-help lists them), so PETSc counts them used and its unused-option warning never
       named them: the run stepped without a word where the spectrum was asked for in part */
    static const char *const names[] = {"-msim_spectrum_largest", "-msim_spectrum_lowest", "-msim_spectrum_modes"};
    for (int k = 0; k < 3; k++)
      if (set[k]) PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: %s has no effect without -msim_spectrum (which computes the spectrum instead of the run's steps)\n", names[k]));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  {
    /* the counts against the unknowns (3 per free vertex), naming the option (the solver's own
       check named none, and a negative -msim_spectrum_lowest computed no mode without a word) */
    const PetscInt n = 3 * sys->nfree;
    PetscCheck(nlargest >= 1 && nlargest <= n, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_spectrum_largest must be in [1, %" PetscInt_FMT "], the scene's unknowns (got %" PetscInt_FMT ")", n, nlargest);
    PetscCheck(nlow >= 0 && nlow <= n, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_spectrum_lowest must be in [0, %" PetscInt_FMT "], the scene's unknowns (got %" PetscInt_FMT ")", n, nlow);
  }
  PetscCall(MSimSystemVolumeCheckStart(sys, 0.0, X, NULL)); /* K holds the inversion barrier's Hessian */
  PetscCall(MSimSpectrumLargest(sys, X, nlargest, lambda));
  const PetscReal wmax = PetscSqrtReal(PetscMax(lambda[0], 0.0));
  PetscCall(VecMax(sys->mass, NULL, &mmax));
  PetscCall(PetscPrintf(sys->comm, "spectrum of (K, M) at the initial state, %" PetscInt_FMT " unknowns (SLEPc %s)\n", 3 * sys->nfree, "krylovschur"));
  PetscCall(PetscPrintf(sys->comm, "  omega_max = %.12g rad/s (Krylov-Schur restarts: %" PetscInt_FMT ")\n", (double)wmax, MSimSpectrumLastIterations));
  for (PetscInt k = 0; k < nlargest; k++) PetscCall(PetscPrintf(sys->comm, "  lambda[%" PetscInt_FMT "] = %.15g\n", k, (double)lambda[k]));
  PetscCall(PetscPrintf(sys->comm, "  critical time step: symplectic_euler h < %.6g s, rk4 h <= %.6g s\n", (double)(2.0 / wmax), (double)(2.0 * PETSC_SQRT2 / wmax)));
  if (sys->drag > 0) PetscCall(PetscPrintf(sys->comm, "  explicit_euler: stable for h <= %.6g s (drag rate %g 1/s over omega_max^2)\n", (double)((sys->drag / mmax) / (wmax * wmax)), (double)(sys->drag / mmax)));
  else PetscCall(PetscPrintf(sys->comm, "  explicit_euler: unstable for every h without drag (growth sqrt(1 + h^2 omega^2) per step)\n"));
  if (nlow > 0) {
    PetscCall(MSimSpectrumSolve(sys, X, nlow, PETSC_FALSE, -1e-8 * lambda[0], low, dir[0] ? &modes : NULL));
    PetscCall(PetscPrintf(sys->comm, "  lowest %" PetscInt_FMT " modes:\n", nlow));
    for (PetscInt k = 0; k < nlow; k++) PetscCall(PetscPrintf(sys->comm, "    mode %" PetscInt_FMT ": lambda %.10g, f = %.8g Hz\n", k, (double)(PetscAbsReal(low[k]) < 1e-10 * lambda[0] ? 0.0 : low[k]), (double)(PetscAbsReal(low[k]) < 1e-10 * lambda[0] ? 0.0 : PetscSqrtReal(PetscMax(low[k], 0.0)) / (2 * PETSC_PI))));
    if (dir[0]) {
      std::vector<PetscReal> pos, disp;
      std::vector<char>      fixed;
      std::vector<PetscInt>  cells;
      PetscCall(MSimMakeDirectory(sys->comm, dir, "-msim_spectrum_modes", NULL, 0));
      PetscCall(MSimSystemGatherTopology(sys, fixed, cells));
      PetscCall(MSimSystemGatherPositions(sys, 0.0, X, pos));
      for (PetscInt k = 0; k < nlow; k++) {
        char path[PETSC_MAX_PATH_LEN];
        PetscCall(MSimSystemGatherVector(sys, modes[k], disp));
        if (sys->rank == 0) {
          PetscCall(PetscSNPrintf(path, sizeof(path), "%s/mode_%03" PetscInt_FMT ".vtu", dir, k));
          PetscCall(MSimWriteVTU(path, sys->nv, pos.data(), (PetscInt)(cells.size() / sys->out_cell_size), sys->out_cell_size, cells.data(), fixed.data(), "mode", disp.data()));
        }
        PetscCall(VecDestroy(&modes[k]));
      }
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
