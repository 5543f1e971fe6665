/* What the fuzz harnesses share: PETSc started without its signal handler (which would catch a
   crash and abort before the sanitizer and libFuzzer report it and keep the input), and an error
   handler that prints nothing, since refusals are expected. */
#pragma once
#include <petscsys.h>

static PetscErrorCode MSimFuzzQuiet(MPI_Comm, int, const char *, const char *, PetscErrorCode n, PetscErrorType, const char *, void *)
{
  return n;
}

static inline int MSimFuzzInitializePETSc(void)
{
  static char  arg0[] = "fuzz", arg1[] = "-no_signal_handler";
  static char *args[] = {arg0, arg1, nullptr};
  int          argc   = 2;
  char       **argv   = args;
  return PetscInitialize(&argc, &argv, NULL, NULL) != PETSC_SUCCESS;
}
