/* The unknown-type error of MSimRegistry (msim/registry.h). */
#include <msim/registry.h>
#include <string>

PetscErrorCode MSimRegistryUnknown(MPI_Comm comm, PetscFunctionList list, const char option[], const char type[])
{
  const char **names;
  int          n;
  std::string  choices;

  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListGet(list, &names, &n));
  for (int k = 0; k < n && names[k]; k++) { /* the array ends with NULL, counted in n */
    if (k) choices += (k + 1 < n && names[k + 1]) ? ", " : " or ";
    choices += names[k];
  }
  PetscCall(PetscFree(names));
  SETERRQ(comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "%s %s is not known (use %s)", option, type, choices.c_str());
}
