/* Reading msim's options (options.cpp), options files' repeats (options_file_repeats.cpp) and the
   options nobody read (options_unread.cpp). */
#pragma once
#include <msim/petsc_compat.h>
#include <string>
#include <vector>

/* msim's numeric options, inside a PetscOptionsBegin block: PETSc's, after a check that every
   item is a finite number (an integer within PetscInt for integer options); errors name the
   option, once. Arguments as PETSc's PetscOptionsReal etc. */
PetscErrorCode MSimOptionsReal_Private(PetscOptionItems *, const char[], const char[], const char[], PetscReal, PetscReal *, PetscBool *);
PetscErrorCode MSimOptionsInt_Private(PetscOptionItems *, const char[], const char[], const char[], PetscInt, PetscInt *, PetscBool *);
PetscErrorCode MSimOptionsRealArray_Private(PetscOptionItems *, const char[], const char[], const char[], PetscReal[], PetscInt *, PetscBool *);
PetscErrorCode MSimOptionsIntArray_Private(PetscOptionItems *, const char[], const char[], const char[], PetscInt[], PetscInt *, PetscBool *);
#define MSimOptionsReal(a, b, c, d, e, f)      MSimOptionsReal_Private(PetscOptionsObject, a, b, c, d, e, f)
#define MSimOptionsInt(a, b, c, d, e, f)       MSimOptionsInt_Private(PetscOptionsObject, a, b, c, d, e, f)
#define MSimOptionsRealArray(a, b, c, d, e, f) MSimOptionsRealArray_Private(PetscOptionsObject, a, b, c, d, e, f)
#define MSimOptionsIntArray(a, b, c, d, e, f)  MSimOptionsIntArray_Private(PetscOptionsObject, a, b, c, d, e, f)
/* Parse "a,b,c" into three reals inside a PetscOptionsBegin block; errors name the option. */
PetscErrorCode MSimOptionsVec3_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], PetscReal v[3], PetscBool *set);
#define MSimOptionsVec3(name, help, v, set) MSimOptionsVec3_Private(PetscOptionsObject, name, help, v, set)

/* Options that refine a flag option (-msim_volume_kappa of -msim_volume), read with their set
   flags: one set while the flag is not given at all is refused in one line naming both (read, it
   would escape the unused-option warning and do nothing). The flag given as 0 lets them be: it
   turns off what an options file set up with them. */
PetscErrorCode MSimOptionsRefuseWithout(MPI_Comm comm, const char parent[], PetscInt n, const char *const names[], const PetscBool set[]);

/* Which of the options the user set some code reads: Begin notes the msim_ options set and not
   read yet; End gives those of them read since, one "-name value" line each ("-name" for a flag),
   sorted. An option read before Begin is not seen (it is no longer unread), so a watch covers the
   first reader of its options. */
typedef struct {
  std::vector<std::string> names, values; /* the msim_ options set and unread at Begin */
} MSimOptionsWatch;
PetscErrorCode MSimOptionsWatchBegin(MSimOptionsWatch *watch);
PetscErrorCode MSimOptionsWatchEnd(MSimOptionsWatch *watch, std::string &read);

/* Collective, after PetscInitialize: each plain -options_file of the command line (and each it
   includes) read again on rank 0 for an option given on two of its lines, which PETSc's database
   keeps only the last of: an error for msim's list options (obstacles, vertex ids, ...), a warning
   line for any other; and a list option given twice on the command line, an error
   (options_file_repeats.cpp). */
PetscErrorCode MSimCheckOptionsFileRepeats(MPI_Comm comm);

/* Options set but never read (a misspelled name does nothing otherwise): one warning line each on
   stderr, unless -options_left asked PETSc to list them. */
PetscErrorCode MSimWarnUnusedOptions(MPI_Comm comm);
