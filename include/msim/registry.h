/* A list of types by name (scenes, partitioners, integrators): what each package's Register,
   RegisterAll, FinalizePackage and SetType share, so that each says only which types it has. */
#pragma once
#include <msim/petsc_compat.h>

/* The one error for an unknown type: "<option> <type> is not known (use a, b or c)", the choices
   taken from the list itself so that the message cannot fall behind a new type. */
PetscErrorCode MSimRegistryUnknown(MPI_Comm comm, PetscFunctionList list, const char option[], const char type[]);

template <class Create>
struct MSimRegistry {
  PetscFunctionList list   = NULL;
  PetscBool         filled = PETSC_FALSE; /* RegisterAll ran since the start or the last Destroy */

  PetscErrorCode Add(const char name[], Create create)
  {
    PetscFunctionBeginUser;
    PetscCall(PetscFunctionListAdd(&list, name, create));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* true on RegisterAll's first call only: later calls find the types already there */
  PetscBool Fill()
  {
    const PetscBool first = (PetscBool)!filled;
    filled                = PETSC_TRUE;
    return first;
  }
  /* FinalizePackage: the list goes, and a later RegisterAll fills it again */
  PetscErrorCode Destroy()
  {
    PetscFunctionBeginUser;
    PetscCall(PetscFunctionListDestroy(&list));
    filled = PETSC_FALSE;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* the function registered as type; an unknown type is an error naming option (collective on comm) */
  PetscErrorCode Find(MPI_Comm comm, const char option[], const char type[], Create *create) const
  {
    PetscFunctionBeginUser;
    PetscCall(PetscFunctionListFind(list, type, create));
    if (!*create) PetscCall(MSimRegistryUnknown(comm, list, option, type));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
};
