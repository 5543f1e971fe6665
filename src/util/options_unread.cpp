/* The options the user set that nothing has read yet (PETSc marks an option used when code looks it
   up): a warning for each one left at the end, and a watch that tells which of them some code
   reads (the options that define a scene are those its creation reads). */
#include <msim/options.h>
#include <algorithm>
#include <cstring>
#include <vector>

PetscErrorCode MSimWarnUnusedOptions(MPI_Comm comm)
{
  PetscBool left;
  PetscInt  n;
  char    **names, **values;

  PetscFunctionBeginUser;
  /* PETSc's own option, read by PetscFinalize, which no msim object owns: only asked here whether
     PETSc will list the unread options itself */
  PetscCall(PetscOptionsHasName(NULL, NULL, "-options_left", &left));
  if (left) PetscFunctionReturn(PETSC_SUCCESS); /* PetscFinalize lists them */
  PetscCall(PetscOptionsLeftGet(NULL, &n, &names, &values));
  for (PetscInt i = 0; i < n; i++) {
    /* read by PetscFinalize, after this check */
    PetscBool at_finalize = PETSC_FALSE;
    for (const char *f : {"options_view", "objects_dump", "malloc_view", "memory_view", "log_view", "log_view_memory"})
      if (!strcmp(names[i], f)) at_finalize = PETSC_TRUE;
    if (!at_finalize) PetscCall(PetscFPrintf(comm, PETSC_STDERR, "msim: warning: -%s was set but never used (misspelled? -help lists every option)\n", names[i]));
  }
  PetscCall(PetscOptionsLeftRestore(NULL, &n, &names, &values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsWatchBegin(MSimOptionsWatch *watch)
{
  PetscInt n;
  char   **names, **values;

  PetscFunctionBeginUser;
  watch->names.clear();
  watch->values.clear();
  PetscCall(PetscOptionsLeftGet(NULL, &n, &names, &values));
  for (PetscInt i = 0; i < n; i++) {
    /* PETSc's own (-help, which every options block looks up) are not msim's to watch */
    if (strncmp(names[i], "msim_", 5)) continue;
    watch->names.push_back(names[i]);
    watch->values.push_back(values[i] ? values[i] : "");
  }
  PetscCall(PetscOptionsLeftRestore(NULL, &n, &names, &values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsWatchEnd(MSimOptionsWatch *watch, std::string &read)
{
  std::vector<std::string> lines;

  PetscFunctionBeginUser;
  for (size_t i = 0; i < watch->names.size(); i++) {
    PetscBool used; /* PETSc stores and compares names without their dash */
    PetscCall(PetscOptionsUsed(NULL, watch->names[i].c_str(), &used));
    if (used) lines.push_back("-" + watch->names[i] + (watch->values[i].empty() ? "" : " " + watch->values[i]));
  }
  watch->names.clear();
  watch->values.clear();
  std::sort(lines.begin(), lines.end());
  read.clear();
  for (const std::string &l : lines) read += l + "\n";
  PetscFunctionReturn(PETSC_SUCCESS);
}
