/* What a user sees when the input is wrong: each error as one line ("msim: error: ...") from rank 0,
   including errors inside SlepcInitialize (an options file that does not open or parse), which
   come before msim's handler exists. */
#include <msim/errors.h>
#include <msim/init.h>
#include <cerrno>
#include <cstdarg>
#include <csignal>
#include <cstring>
#include <sstream>
#include <string>

/* The options whose value is `value` (and whose name ends in `suffix`), as "-a, -b" ("" if none):
   PETSc's conversion and type errors name the value only ("Input string abc has no numeric value",
   "Unable to find requested KSP type abc"); the line should name the option. */
static std::string MSimOptionsWithValue(const std::string &value, const std::string &suffix = "")
{
  char             *all = NULL;
  std::string       names, prev, tok;
  std::stringstream ss;

  /* the whole database, read directly: this runs inside the error handler, after some options
     block failed, to find which option holds the offending value; no object owns that search */
  if (PetscOptionsGetAll(NULL, &all) || !all) return names;
  ss << all;
  while (ss >> tok) {
    const bool ends = prev.size() >= suffix.size() && !prev.compare(prev.size() - suffix.size(), suffix.size(), suffix);
    if (tok == value && prev.size() > 1 && prev[0] == '-' && ends) names += (names.empty() ? "" : ", ") + prev;
    prev = tok;
  }
  (void)PetscFree(all);
  return names;
}

/* A conversion error's text with the option named (*named set), or the text itself */
static std::string MSimNameTheOption(const char *mess, PetscBool *named)
{
  const std::string m(mess);
  const char       *in = "Input string ", *lg = "Unknown logical value: ", *ty = "Unable to find requested ";
  std::string       value, what;

  if (!m.compare(0, strlen(ty), ty) && m.find(" type ") != std::string::npos) {
    /* "Unable to find requested KSP type abc": a solver type chosen with some -..._type option */
    const size_t at    = m.find(" type ");
    const std::string kind = m.substr(strlen(ty), at - strlen(ty)), name = m.substr(at + 6);
    const std::string names = MSimOptionsWithValue(name, "_type");
    *named                  = (PetscBool)!names.empty();
    return names.empty() ? m : names + ": '" + name + "' is not a " + kind + " type (-help lists them)";
  }

  if (!m.compare(0, strlen(in), in) && m.find(" has no ") != std::string::npos) {
    value = m.substr(strlen(in), m.find(" has no ") - strlen(in));
    what  = m.find("integer") != std::string::npos ? "an integer" : "a number";
  } else if (!m.compare(0, strlen(lg), lg)) {
    value = m.substr(strlen(lg));
    what  = "true or false";
  } else return m;
  while (!value.empty() && value.back() == ' ') value.pop_back();
  const std::string names = MSimOptionsWithValue(value);
  *named                  = (PetscBool)!names.empty();
  return names.empty() ? m : names + ": '" + value + "' is not " + what;
}

PetscErrorCode MSimErrorHandler(MPI_Comm comm, int line_no, const char *fun, const char *file, PetscErrorCode n, PetscErrorType p, const char *mess, void *ctx)
{
  PetscMPIInt rank = 0;
  PetscBool   named = PETSC_FALSE;
  const char *text  = NULL;
  std::string say;

  if (p != PETSC_ERROR_INITIAL) return n;
  if (mess && mess[0]) say = MSimNameTheOption(mess, &named);
  else {
    PetscErrorMessage(n, &text, NULL);
    say = text ? text : "unknown error";
  }
  /* an option's value is the same on every rank, and so is its conversion error, raised on each
     rank's PETSC_COMM_SELF: rank 0 of the world says it once */
  if (named) MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  else if (comm != MPI_COMM_NULL) MPI_Comm_rank(comm, &rank);
  if (rank == 0) {
    fprintf(stderr, "msim: error: %s\n", say.c_str());
    fflush(stderr);
  }
  return n;
}

/* PETSc prints an error's trace through PetscErrorPrintf, one call per line: the message is the
   last line before the "See https://petsc.org/..." line. */
static char      init_error[512];
static PetscBool init_error_done;

static PetscErrorCode MSimCaptureErrorPrintf(const char format[], ...)
{
  char    line[1024];
  va_list ap;
  va_start(ap, format);
  vsnprintf(line, sizeof(line), format, ap);
  va_end(ap);
  size_t n = strlen(line);
  while (n && (line[n - 1] == '\n' || line[n - 1] == ' ')) line[--n] = 0;
  if (init_error_done) return PETSC_SUCCESS;
  if (strstr(line, "See https://petsc.org")) init_error_done = PETSC_TRUE;
  else if (n && line[0] != '-') snprintf(init_error, sizeof(init_error), "%s", line);
  return PETSC_SUCCESS;
}

void MSimInitializeBegin(void)
{
  PetscErrorPrintf = MSimCaptureErrorPrintf;
}

/* PETSc reads an options file on rank 0 inside PetscInitialize; one that does not open is an error
   there while the other ranks wait for the broadcast of its contents, so only MPI_Abort could end
   them. Checked first (MPI is up, PETSc not yet), the run ends with one line on every rank count. */
int MSimCheckOptionsFiles(int argc, char **argv)
{
  int rank = 0, bad = -1;

  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0)
    for (int a = 1; a + 1 < argc && bad < 0; a++) {
      if (strcmp(argv[a], "-options_file") && strcmp(argv[a], "-options_file_yaml")) continue;
      FILE *f = fopen(argv[a + 1], "r");
      if (f) fclose(f);
      else {
        fprintf(stderr, "msim: error: %s %s: cannot open it (%s)\n", argv[a], argv[a + 1], strerror(errno));
        fflush(stderr);
        bad = a;
      }
    }
  MPI_Bcast(&bad, 1, MPI_INT, 0, MPI_COMM_WORLD);
  return bad >= 0;
}

int MSimInitializeEnd(PetscErrorCode ierr)
{
  int initialized = 0, finalized = 0, rank = 0;

  PetscErrorPrintf = PetscErrorPrintfDefault;
  if (!ierr) {
    /* a write to a closed standard output fails (EPIPE) instead of PETSc's handler printing a
       signal trace and aborting (stop_signal.cpp stops a run's steps on it) */
    signal(SIGPIPE, SIG_IGN);
    return 0;
  }
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (initialized && !finalized) MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) fprintf(stderr, "msim: error: %s\n", init_error[0] ? init_error : "PETSc did not initialize");
  fflush(stderr);
  if (initialized && !finalized) {
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    /* PETSc reads options files on rank 0: the other ranks wait for its broadcast, so only an
       abort ends them */
    if (size > 1) MPI_Abort(MPI_COMM_WORLD, 1);
    MPI_Finalize();
  }
  return 1;
}
