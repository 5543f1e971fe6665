/* The registries of time schemes and energy terms (PetscFunctionList, as PETSc's own types), and
   the problem's creation from them: the scheme by name, the terms from -msim_implicit_terms. */
#include <msim/implicit.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <msim/private/contactimpl.h>

static PetscFunctionList MSimSchemeList = NULL, MSimTermList = NULL;
static PetscBool         MSimImplicitRegistered = PETSC_FALSE;

PetscErrorCode MSimImplicitSchemeRegister(const char name[], PetscErrorCode (*create)(MSimImplicitScheme))
{
  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListAdd(&MSimSchemeList, name, create));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitTermRegister(const char name[], PetscErrorCode (*create)(MSimImplicitTerm))
{
  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListAdd(&MSimTermList, name, create));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MSimImplicitFinalizePackage(void)
{
  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListDestroy(&MSimSchemeList));
  PetscCall(PetscFunctionListDestroy(&MSimTermList));
  MSimImplicitRegistered = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A scheme from its type's table: constants copied, work vectors made like x */
template <const MSimImplicitSchemeType *type>
static PetscErrorCode MSimImplicitSchemeCreateFromType(MSimImplicitScheme scheme)
{
  PetscFunctionBeginUser;
  PetscCheck(type->nwork <= MSIM_SCHEME_MAX_WORK && type->nhistory <= type->nwork, PETSC_COMM_SELF, PETSC_ERR_PLIB, "scheme %s: %d work vectors (at most %d), %d of them history", scheme->type, (int)type->nwork, MSIM_SCHEME_MAX_WORK, (int)type->nhistory);
  scheme->beta           = type->beta;
  scheme->gamma          = type->gamma;
  scheme->guess          = type->guess;
  scheme->no_barrier     = type->no_barrier;
  scheme->no_objective   = type->no_objective;
  scheme->ops.begin_step = type->begin_step;
  scheme->ops.end_step   = type->end_step;
  scheme->ops.predict    = type->predict;
  scheme->nhistory       = type->nhistory;
  scheme->history_at_h   = type->history_at_h;
  for (; scheme->nwork < type->nwork; scheme->nwork++) PetscCall(VecDuplicate(scheme->imp->sys->X0, &scheme->work[scheme->nwork]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* One line per scheme and per term: each is a file of schemes/ (its table) or terms/. */
extern const MSimImplicitSchemeType MSimImplicitSchemeEuler, MSimImplicitSchemeBDF2, MSimImplicitSchemeMidpoint, MSimImplicitSchemeNewmark, MSimImplicitSchemeDiscreteGradient;
PetscErrorCode MSimImplicitTermCreate_Springs(MSimImplicitTerm);
PetscErrorCode MSimImplicitTermCreate_Drag(MSimImplicitTerm);
PetscErrorCode MSimImplicitTermCreate_Obstacles(MSimImplicitTerm);
PetscErrorCode MSimImplicitTermCreate_Friction(MSimImplicitTerm);
PetscErrorCode MSimImplicitTermCreate_SelfContact(MSimImplicitTerm);
PetscErrorCode MSimImplicitTermCreate_SelfFriction(MSimImplicitTerm);
PetscErrorCode MSimImplicitTermCreate_Volume(MSimImplicitTerm);

PetscErrorCode MSimImplicitRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (MSimImplicitRegistered) PetscFunctionReturn(PETSC_SUCCESS);
  MSimImplicitRegistered = PETSC_TRUE;
  PetscCall(PetscRegisterFinalize(MSimImplicitFinalizePackage));
  PetscCall(MSimImplicitSchemeRegister(MSIMSCHEMEEULER, MSimImplicitSchemeCreateFromType<&MSimImplicitSchemeEuler>));
  PetscCall(MSimImplicitSchemeRegister(MSIMSCHEMEBDF2, MSimImplicitSchemeCreateFromType<&MSimImplicitSchemeBDF2>));
  PetscCall(MSimImplicitSchemeRegister(MSIMSCHEMEMIDPOINT, MSimImplicitSchemeCreateFromType<&MSimImplicitSchemeMidpoint>));
  PetscCall(MSimImplicitSchemeRegister(MSIMSCHEMENEWMARK, MSimImplicitSchemeCreateFromType<&MSimImplicitSchemeNewmark>));
  PetscCall(MSimImplicitSchemeRegister(MSIMSCHEMEDISCGRAD, MSimImplicitSchemeCreateFromType<&MSimImplicitSchemeDiscreteGradient>));
  PetscCall(MSimImplicitTermRegister(MSIMTERMSPRINGS, MSimImplicitTermCreate_Springs));
  PetscCall(MSimImplicitTermRegister(MSIMTERMDRAG, MSimImplicitTermCreate_Drag));
  PetscCall(MSimImplicitTermRegister("obstacles", MSimImplicitTermCreate_Obstacles));
  PetscCall(MSimImplicitTermRegister("friction", MSimImplicitTermCreate_Friction));
  PetscCall(MSimImplicitTermRegister("self_contact", MSimImplicitTermCreate_SelfContact));
  PetscCall(MSimImplicitTermRegister("self_friction", MSimImplicitTermCreate_SelfFriction)); /* after self_contact: it reads its pairs */
  PetscCall(MSimImplicitTermRegister("volume", MSimImplicitTermCreate_Volume));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSchemeGetNames(const char ***names, PetscInt *n)
{
  int count;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitRegisterAll());
  PetscCall(PetscFunctionListGet(MSimSchemeList, names, &count));
  *n = count - 1; /* PETSc counts the closing NULL */
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitSchemeIsRegistered(const char type[], PetscBool *is)
{
  PetscErrorCode (*create)(MSimImplicitScheme) = NULL;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitRegisterAll());
  PetscCall(PetscFunctionListFind(MSimSchemeList, type, &create));
  *is = (PetscBool)(create != NULL);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The position of the term called name in imp's Phi, -1 if absent */
static PetscErrorCode FindTerm(MSimImplicit imp, const char name[], PetscInt *at)
{
  PetscFunctionBeginUser;
  *at = -1;
  for (PetscInt k = 0; k < imp->nterms && *at < 0; k++) {
    PetscBool same;
    PetscCall(PetscStrcmp(imp->terms[k]->type, name, &same));
    if (same) *at = k;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode AddTerm(MSimImplicit imp, const char name[])
{
  PetscErrorCode (*create)(MSimImplicitTerm);
  MSimImplicitTerm term;
  PetscInt         at;

  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListFind(MSimTermList, name, &create));
  PetscCheck(create, imp->sys->comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "-msim_implicit_terms: no energy term '%s' (see -help for the list)", name);
  PetscCheck(imp->nterms < (PetscInt)(sizeof(imp->terms) / sizeof(imp->terms[0])), imp->sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_implicit_terms: at most %d terms", (int)(sizeof(imp->terms) / sizeof(imp->terms[0])));
  PetscCall(FindTerm(imp, name, &at));
  PetscCheck(at < 0, imp->sys->comm, PETSC_ERR_ARG_WRONG, "-msim_implicit_terms: '%s' given twice", name);
  term      = new _n_MSimImplicitTerm();
  term->imp = imp;
  PetscCall(PetscStrncpy(term->type, name, sizeof(term->type)));
  imp->terms[imp->nterms++] = term;
  PetscCall((*create)(term));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitCheckTermsCoverScene(MSimImplicit imp)
{
  MSimSystem     sys = imp->sys;
  MSimContact    ct  = NULL, any = NULL;
  PetscContainer container;
  PetscInt       self_at, self_friction_at;

  PetscFunctionBeginUser;
  /* the contact object carries -msim_friction even where there is no obstacle (self-friction reads it there) */
  PetscCall(MSimContactGet(sys, &ct));
  PetscCall(PetscObjectQuery((PetscObject)sys->X0, "MSimContact", (PetscObject *)&container));
  if (container) PetscCall(PetscContainerGetPointer(container, (void **)&any));
  const struct {
    const char *term, *what;
    PetscBool   needed;
  } need[] = {
    {MSIMTERMSPRINGS, "the scene's springs",                                 (PetscBool)(sys->nspring_global > 0)                },
    {MSIMTERMDRAG,    "-msim_drag",                                          (PetscBool)(sys->drag != 0)                         },
    {"obstacles",     "the obstacles (-msim_contact_*)",                     (PetscBool)(ct != NULL)                             },
    {"friction",      "-msim_friction with obstacles",                      (PetscBool)(ct && ct->mu > 0)                       },
    {"self_contact",  "-msim_self_contact",                                  sys->self_contact.on                                },
    {"self_friction", "-msim_friction with -msim_self_contact",              (PetscBool)(sys->self_contact.on && any && any->mu > 0)},
    {"volume",        "the tets' volume (-msim_volume)",                (PetscBool)(sys->tets.ntet > 0)                     },
  };
  /* a term left out drops its physics without a trace, and the monitor and frames would still
     report its contact force from the state: refuse it instead */
  for (const auto &n : need) {
    PetscInt at;
    PetscCall(FindTerm(imp, n.term, &at));
    PetscCheck(!n.needed || at >= 0, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_implicit_terms leaves out '%s', the term of %s: add it to the list (or leave -msim_implicit_terms out for every term)", n.term, n.what);
  }
  /* self_friction reads self_contact's pairs, so it comes after it (before it, it would act nowhere) */
  PetscCall(FindTerm(imp, "self_contact", &self_at));
  PetscCall(FindTerm(imp, "self_friction", &self_friction_at));
  PetscCheck(!sys->self_contact.on || self_friction_at < 0 || self_friction_at > self_at, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_implicit_terms: 'self_friction' must come after 'self_contact', whose pairs it reads");
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const char *const kGuessTypes[] = {"constant_velocity", "extrapolate", "filtered", "inertial"}; /* MSIM_GUESS_* */

PetscErrorCode MSimImplicitCreateWithScheme(MSimSystem sys, const char scheme[], MSimImplicit *imp)
{
  PetscErrorCode (*create)(MSimImplicitScheme);
  const char **names;
  int          nnames;
  char         help[512] = "Energy terms of the implicit step's Phi, in order (registered:", *list[16];
  PetscInt     nlist = 16;
  PetscBool    set;

  PetscFunctionBeginUser;
  PetscCall(MSimImplicitRegisterAll());
  if (!scheme) scheme = MSIMSCHEMEEULER;
  PetscCall(PetscFunctionListFind(MSimSchemeList, scheme, &create));
  PetscCheck(create, sys->comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "no implicit time scheme '%s' (see -msim_integrator in -help)", scheme);
  *imp        = new _n_MSimImplicit();
  (*imp)->sys = sys;
  (*imp)->psd = PETSC_TRUE;
  PetscCall(VecDuplicate(sys->X0, &(*imp)->Xn));
  PetscCall(VecDuplicate(sys->X0, &(*imp)->Y));
  (*imp)->scheme = new _n_MSimImplicitScheme();
  PetscCall(PetscStrncpy((*imp)->scheme->type, scheme, sizeof((*imp)->scheme->type)));
  (*imp)->scheme->beta  = 1;
  (*imp)->scheme->gamma = 1;
  (*imp)->scheme->guess = 1;
  (*imp)->scheme->imp   = *imp;
  PetscCall((*create)((*imp)->scheme));
  /* the terms: every registered one unless -msim_implicit_terms names them */
  PetscCall(PetscFunctionListGet(MSimTermList, &names, &nnames));
  nnames--; /* PETSc counts the closing NULL */
  for (int k = 0; k < nnames; k++) {
    PetscCall(PetscStrlcat(help, k ? ", " : " ", sizeof(help)));
    PetscCall(PetscStrlcat(help, names[k], sizeof(help)));
  }
  PetscCall(PetscStrlcat(help, "); default: all of them; a term the scene needs (its springs, drag, obstacles, friction, self-contact, volume) cannot be left out", sizeof(help)));
  PetscOptionsBegin(sys->comm, NULL, "msim implicit problem", NULL);
  PetscCall(PetscOptionsStringArray("-msim_implicit_terms", help, NULL, list, &nlist, &set));
  PetscCall(PetscOptionsEList("-msim_implicit_guess", "First iterate of each implicit step: constant_velocity (x_n + h v_n), extrapolate (the scheme's position at v_{n+1} = 2 v_n - v_{n-1}: O(h^3), exact under constant acceleration), filtered (v_{n+1} = v_n + A^-1 M (v_n - v_{n-1}), A the PD matrix: one PD solve a step, stable with PD-10) or inertial (the scheme's y)", NULL, kGuessTypes, 4, kGuessTypes[(*imp)->guess_type], &(*imp)->guess_type, NULL));
  PetscOptionsEnd();
  if ((*imp)->guess_type != MSIM_GUESS_CONSTANT_VELOCITY) PetscCall(VecDuplicate(sys->X0, &(*imp)->Vstar));
  if ((*imp)->guess_type == MSIM_GUESS_EXTRAPOLATE || (*imp)->guess_type == MSIM_GUESS_FILTERED) PetscCall(VecDuplicate(sys->X0, &(*imp)->Vprev));
  if ((*imp)->guess_type == MSIM_GUESS_FILTERED) PetscCall(VecDuplicate(sys->X0, &(*imp)->Vwork));
  if (!set) {
    for (int k = 0; k < nnames; k++) PetscCall(AddTerm(*imp, names[k]));
  } else {
    PetscErrorCode ierr = PETSC_SUCCESS;
    for (PetscInt k = 0; k < nlist; k++) {
      if (!ierr) ierr = AddTerm(*imp, list[k]);
      PetscCall(PetscFree(list[k]));
    }
    PetscCall(ierr);
  }
  PetscCall(PetscFree(names));
  /* a scheme whose residual is not Phi's gradient takes each active term's discrete gradient */
  for (PetscInt k = 0; k < (*imp)->nterms && (*imp)->scheme->no_objective; k++) {
    MSimImplicitTerm term = (*imp)->terms[k];
    PetscCheck(!term->ops.gradient || term->ops.discrete_gradient, sys->comm, PETSC_ERR_SUP, "-msim_integrator %s: the energy term '%s' has no discrete gradient (%s)", scheme, term->type, (*imp)->scheme->no_objective);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
