/* Self-contact's options (one block, read once by the scene; the system carries them to the
   implicit term and the integrators' check) and the refusal of the integrators that cannot keep
   its guarantee. */
#include <msim/self_contact.h>
#include <msim/options.h>
#include <msim/private/systemimpl.h>

PetscErrorCode MSimSelfContactGetOptions(MPI_Comm comm, MSimSelfContactOptions *o)
{
  static const char *const refining[] = {"-msim_self_contact_distance", "-msim_self_contact_stiffness", "-msim_self_contact_ccd_fraction", "-msim_self_contact_halo", "-msim_self_contact_start_gap", "-msim_self_contact_once", "-msim_self_contact_start_check"};
  PetscBool                set[7];

  PetscFunctionBeginUser;
  o->on        = PETSC_FALSE;
  o->dhat      = 0;
  o->stiffness = 1;
  o->ccd_s     = 0.1;
  o->halo      = PETSC_TRUE;
  o->start_gap   = -1;
  o->start_check = PETSC_TRUE;
  o->once        = PETSC_FALSE;
  PetscOptionsBegin(comm, NULL, "msim self-contact", NULL);
  PetscCall(PetscOptionsBool("-msim_self_contact", "Self-contact: IPC distance barriers between the surface's vertex-disjoint point-triangle and edge-edge pairs (cloth, a surface mesh's triangles, a tet mesh's boundary faces), with a CCD-filtered line search (implicit integrators)", NULL, o->on, &o->on, NULL));
  PetscCall(MSimOptionsReal("-msim_self_contact_distance", "Self-contact: distance dhat below which the barrier acts, m (0: a quarter of the shortest rest edge)", NULL, o->dhat, &o->dhat, &set[0]));
  PetscCall(MSimOptionsReal("-msim_self_contact_stiffness", "Self-contact: factor on the barrier's weight (1: a pair's stiffness at dhat/2 equals a mean vertex's mass term)", NULL, o->stiffness, &o->stiffness, &set[1]));
  PetscCall(MSimOptionsReal("-msim_self_contact_ccd_fraction", "Self-contact: additive CCD stops a step where a pair's gap falls to this fraction of its start (0 < s < 1)", NULL, o->ccd_s, &o->ccd_s, &set[2]));
  PetscCall(PetscOptionsBool("-msim_self_contact_halo", "Self-contact: include neighbouring ranks' elements (0 only to test that the halo matters)", NULL, o->halo, &o->halo, &set[3]));
  PetscCall(MSimOptionsReal("-msim_self_contact_start_gap", "Self-contact: refuse a start whose vertex-disjoint surface elements are closer than this, m (-1: the contact distance dhat, and 0 at a restart's checkpoint, which may rest in contact; 0: refuse only elements that cross or touch; a start resting in contact gives its gap)", NULL, o->start_gap, &o->start_gap, &set[4]));
  /* off by default: the weighted energy is not C1 where two edges lie parallel and overlap (an
     edge-edge pair then has two closest vertex-edge features at once but is counted in the weights
     of both, so the energy there is the max of the two vertices' barriers, not their sum), and a
     fold of a regular grid settles on such a kink: Newton stalls at it, on the PSD Hessian and on
     the signed one alike (tests/self_contact_ranks.py's sheet: 200 iterations a step from step 11;
     runs/self_contact/README.md, "Each contact counted once") */
  PetscCall(PetscOptionsBool("-msim_self_contact_once", "Self-contact: count each contact once whatever features are closest (point-edge and point-point terms weighted by inclusion-exclusion), not once per point-triangle and edge-edge pair; Newton may stall on folds of regular grids (parallel edges) with it", NULL, o->once, &o->once, &set[5]));
  PetscCall(PetscOptionsBool("-msim_self_contact_start_check", "Self-contact: check the start for crossing or touching elements (0 only to test the stall report: crossing elements stay locked through each other)", NULL, o->start_check, &o->start_check, &set[6]));
  PetscOptionsEnd();
  PetscCall(MSimOptionsRefuseWithout(comm, "-msim_self_contact", 7, refining, set));
  PetscCheck(o->dhat >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_self_contact_distance must be >= 0 m (got %g)", (double)o->dhat);
  PetscCheck(o->stiffness > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_self_contact_stiffness must be > 0 (got %g)", (double)o->stiffness);
  PetscCheck(o->start_gap >= 0 || o->start_gap == -1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_self_contact_start_gap must be >= 0 m, or -1 for the contact distance (got %g)", (double)o->start_gap);
  PetscCheck(o->ccd_s > 0 && o->ccd_s < 1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_self_contact_ccd_fraction must be in (0, 1) (got %g)", (double)o->ccd_s);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSelfContactCheckIntegrator(MSimSystem sys, const char type[], PetscBool implicit)
{
  PetscFunctionBeginUser;
  if (implicit) PetscFunctionReturn(PETSC_SUCCESS);
  /* ts is refused whatever its -ts_type: its implicit types solve their stages without msim's
     feasible line search too (the message said "an explicit step" under -ts_type beuler) */
  PetscCheck(!sys->self_contact.on, sys->comm, PETSC_ERR_SUP, "-msim_self_contact with -msim_integrator %s is not supported: %s no line search to keep the surface from passing through itself; use an implicit integrator (implicit_euler or bdf2)", type,
             strcmp(type, "ts") ? "an explicit step has" : "its steps, explicit or implicit -ts_type, have");
  PetscFunctionReturn(PETSC_SUCCESS);
}
