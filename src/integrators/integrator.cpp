/* Integrator object: registry, options, dispatch. */
#include <msim/integrator.h>
#include <msim/registry.h>
#include <msim/implicit.h>
#include <msim/self_contact.h>
#include <msim/log.h>
#include <msim/private/integratorimpl.h>
#include <msim/private/systemimpl.h>

static MSimRegistry<PetscErrorCode (*)(MSimIntegrator)> MSimIntegrators;

PetscErrorCode MSimIntegratorRegister(const char name[], PetscErrorCode (*create)(MSimIntegrator))
{
  return MSimIntegrators.Add(name, create);
}

PetscErrorCode MSimIntegratorRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (!MSimIntegrators.Fill()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimIntegratorRegister(MSIMEXPLICITEULER, MSimIntegratorCreate_ExplicitEuler));
  PetscCall(MSimIntegratorRegister(MSIMSYMPLECTICEULER, MSimIntegratorCreate_SymplecticEuler));
  PetscCall(MSimIntegratorRegister(MSIMRK4, MSimIntegratorCreate_RK4));
  PetscCall(MSimIntegratorRegister(MSIMTS, MSimIntegratorCreate_TS));
  PetscCall(MSimIntegratorRegisterImplicit()); /* one per time scheme */
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorFinalizePackage(void)
{
  return MSimIntegrators.Destroy();
}

PetscErrorCode MSimIntegratorCreate(MSimSystem sys, MSimIntegrator *integ)
{
  PetscFunctionBeginUser;
  PetscCall(MSimIntegratorRegisterAll());
  *integ                    = new _n_MSimIntegrator();
  (*integ)->comm            = sys->comm;
  (*integ)->sys             = sys;
  (*integ)->dt              = 2e-4;
  (*integ)->steps           = 5000;
  (*integ)->first_step      = 1;
  (*integ)->stability_limit = PETSC_INFINITY;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorSetType(MSimIntegrator integ, const char type[])
{
  PetscErrorCode (*create)(MSimIntegrator);
  PetscBool same;

  PetscFunctionBeginUser;
  PetscCall(PetscStrcmp(integ->type, type, &same));
  if (same) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimIntegrators.Find(integ->comm, "-msim_integrator", type, &create));
  if (integ->ops.destroy) PetscCall((*integ->ops.destroy)(integ));
  integ->ops             = MSimIntegratorOps();
  integ->data            = NULL;
  integ->stability_limit = PETSC_INFINITY;
  integ->stability_degree = 0;
  integ->setupcalled     = PETSC_FALSE;
  PetscCall(PetscStrncpy(integ->type, type, sizeof(integ->type)));
  PetscCall((*create)(integ));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorSetFromOptions(MSimIntegrator integ)
{
  char type[64] = MSIMSYMPLECTICEULER;

  PetscFunctionBeginUser;
  if (integ->type[0]) PetscCall(PetscStrncpy(type, integ->type, sizeof(type)));
  PetscOptionsBegin(integ->comm, NULL, "msim time integration", NULL);
  PetscCall(PetscOptionsFList("-msim_integrator", "Time integrator", NULL, MSimIntegrators.list, type, type, sizeof(type), NULL));
  PetscCall(MSimOptionsReal("-msim_dt", "Time step h, s", NULL, integ->dt, &integ->dt, NULL));
  PetscCall(MSimOptionsInt("-msim_steps", "Number of time steps", NULL, integ->steps, &integ->steps, NULL));
  PetscOptionsEnd();
  PetscCheck(integ->dt > 0, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_dt must be > 0 s (got %g)", (double)integ->dt);
  PetscCheck(integ->steps > 0, integ->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_steps must be >= 1 (got %" PetscInt_FMT ")", integ->steps);
  PetscCall(MSimIntegratorSetType(integ, type));
  if (integ->ops.setfromoptions) PetscCall((*integ->ops.setfromoptions)(integ));
  {
    /* -help lists every integrator's options (the TS's and the SNES's included): set up a
       throwaway integrator of each other type so their option blocks print */
    PetscBool help;
    PetscCall(PetscOptionsHasHelp(NULL, &help));
    if (help && !integ->help_listing) {
      const char **names;
      int           n;
      PetscCall(PetscFunctionListGet(MSimIntegrators.list, &names, &n));
      for (int k = 0; k < n && names[k]; k++) { /* the array ends with NULL, counted in n */
        MSimIntegrator other = NULL;
        if (!strcmp(names[k], type)) continue;
        PetscCall(MSimIntegratorCreate(integ->sys, &other));
        other->help_listing = PETSC_TRUE;
        PetscCall(MSimIntegratorSetType(other, names[k]));
        if (other->ops.setfromoptions) PetscCall((*other->ops.setfromoptions)(other));
        {
          /* a type that refuses this scene (e.g. implicit_midpoint with an obstacle) has listed
             its options by now; its refusal belongs to a run that chooses it, not to -help */
          PetscErrorCode ierr;
          PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
          ierr = MSimIntegratorSetUp(other);
          PetscCall(PetscPopErrorHandler());
          if (ierr) PetscCall(PetscInfo(NULL, "-help: %s's set-up refused this scene (error %d)\n", names[k], (int)ierr));
        }
        PetscCall(MSimIntegratorDestroy(&other));
      }
      PetscCall(PetscFree(names));
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorSetUp(MSimIntegrator integ)
{
  PetscFunctionBeginUser;
  if (integ->setupcalled) PetscFunctionReturn(PETSC_SUCCESS);
  if (!integ->type[0]) PetscCall(MSimIntegratorSetType(integ, MSIMSYMPLECTICEULER));
  if (!integ->help_listing) { /* self-contact and the tets' inversion barrier need an implicit scheme's feasible line search */
    PetscBool        implicit;
    const MSimTets  &T = integ->sys->tets;
    PetscCall(MSimImplicitSchemeIsRegistered(integ->type, &implicit));
    PetscCall(MSimSelfContactCheckIntegrator(integ->sys, integ->type, implicit));
    /* explicit steps take the barrier's force clamped (finite at J <= 0): it cannot keep a tet
       from inverting there (the schemes without a barrier refuse it themselves). ts has neither
       the implicit schemes' start check under moving handles nor their count of inverted tets
       after a step: its explicit types inverted 54 tets of a squashed box, beuler 5 frames'
       worth before its stages failed */
    PetscCheck(implicit || !T.ntet || T.kappa == 0, integ->comm, PETSC_ERR_SUP, "-msim_volume's inversion barrier with -msim_integrator %s is not supported: only an implicit scheme's line search keeps tets from inverting; use implicit_euler or bdf2, or -msim_volume_kappa 0 (the volume term without the barrier)", integ->type);
  }
  if (integ->ops.setup) PetscCall((*integ->ops.setup)(integ));
  integ->setupcalled = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorCheckStart(MSimIntegrator integ, PetscReal t, Vec X, const char *restart)
{
  PetscFunctionBeginUser;
  if (integ->ops.check_start) PetscCall((*integ->ops.check_start)(integ, t, X, restart));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorStep(MSimIntegrator integ, PetscReal t, Vec X, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(MSimIntegratorSetUp(integ));
  PetscCall(PetscLogEventBegin(MSIM_Step, X, V, 0, 0));
  integ->nonlinear_its = integ->linear_its = 0;
  integ->residual                          = 0;
  integ->phi                               = 0;
  integ->failed                            = PETSC_FALSE;
  integ->failed_what                       = NULL;
  integ->failed_t                          = -1;
  integ->stopped                           = PETSC_FALSE;
  integ->step++;
  PetscCall((*integ->ops.step)(integ, t, X, V));
  PetscCall(PetscLogEventEnd(MSIM_Step, X, V, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorView(MSimIntegrator integ, PetscViewer viewer)
{
  PetscFunctionBeginUser;
  PetscCall(PetscViewerASCIIPrintf(viewer, "msim integrator: %s, dt %g s, %" PetscInt_FMT " steps\n", integ->type, (double)integ->dt, integ->steps));
  if (integ->ops.view) {
    PetscCall(PetscViewerASCIIPushTab(viewer));
    PetscCall((*integ->ops.view)(integ, viewer));
    PetscCall(PetscViewerASCIIPopTab(viewer));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorDestroy(MSimIntegrator *integ)
{
  PetscFunctionBeginUser;
  if (!*integ) PetscFunctionReturn(PETSC_SUCCESS);
  if ((*integ)->ops.destroy) PetscCall((*(*integ)->ops.destroy)(*integ));
  delete *integ;
  *integ = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorGetTimeStep(MSimIntegrator integ, PetscReal *dt)
{
  PetscFunctionBeginUser;
  *dt = integ->dt;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimIntegratorGetStepResult(MSimIntegrator integ, PetscBool *failed, PetscInt *nonlinear_its, PetscInt *linear_its, PetscReal *residual)
{
  PetscFunctionBeginUser;
  if (failed) *failed = integ->failed;
  if (nonlinear_its) *nonlinear_its = integ->nonlinear_its;
  if (linear_its) *linear_its = integ->linear_its;
  if (residual) *residual = integ->residual;
  PetscFunctionReturn(PETSC_SUCCESS);
}
