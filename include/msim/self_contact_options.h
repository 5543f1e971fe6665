/* Self-contact's options (-msim_self_contact*), read once per run in their own block by the scene
   (which keeps a mesh's cells for the surface when self-contact is on, as it does for -msim_volume)
   and carried by the system to the implicit term and the integrators' check (msim/self_contact.h).
   Apart from msim/self_contact.h so that the scene's data can hold them without the system's
   header. */
#pragma once
#include <msim/petsc_compat.h>

typedef struct {
  PetscBool on        = PETSC_FALSE; /* -msim_self_contact */
  PetscReal dhat      = 0;           /* -msim_self_contact_distance (0: a quarter of the shortest rest edge) */
  PetscReal stiffness = 1;           /* -msim_self_contact_stiffness: multiplies the default barrier weight */
  PetscReal ccd_s     = 0.1;         /* -msim_self_contact_ccd_fraction: ACCD keeps this fraction of the gap */
  PetscBool halo      = PETSC_TRUE;  /* -msim_self_contact_halo (testing: 0 leaves other ranks' elements out) */
  PetscReal start_gap   = -1;         /* -msim_self_contact_start_gap (-1: dhat, 0 at a restart): closer at the start is refused */
  PetscBool start_check = PETSC_TRUE; /* -msim_self_contact_start_check (0: no start check, for the stall report's test) */
  PetscBool once        = PETSC_FALSE; /* -msim_self_contact_once: each contact counted once (the term's feature weights) */
} MSimSelfContactOptions;

/* Reads the options block "msim self-contact" (collective); called once, by the scene. */
PetscErrorCode MSimSelfContactGetOptions(MPI_Comm comm, MSimSelfContactOptions *o);
