/* PETSc itself, and the shims that let msim's code use names newer PETSc versions have. */
#pragma once
#include <petsc.h>

#if PETSC_VERSION_LT(3, 19, 0)
  #define PETSC_SUCCESS 0
#endif
