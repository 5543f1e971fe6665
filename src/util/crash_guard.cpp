/* Third-party code that crashes on bad input (TetGen on some faulty surfaces, PETSc's Gmsh reader
   on some malformed files, found by fuzzing) must not take msim down without its one-line error:
   a crash signal inside the call jumps back to it, and the caller reports the input as bad. The
   library's state is abandoned, not reused: msim exits with the error. */
#include <msim/sys.h>
#include <csetjmp>
#include <csignal>
#include <cstring>

static sigjmp_buf msim_crash_return;

static void MSimCrashed(int sig)
{
  siglongjmp(msim_crash_return, sig);
}

int MSimCallGuarded(const std::function<void(void)> &fn)
{
  const int        sigs[] = {SIGSEGV, SIGABRT, SIGFPE, SIGBUS, SIGILL};
  struct sigaction sa, old[5];
  volatile int     crashed = 0;

  memset(&sa, 0, sizeof(sa));
  sa.sa_handler = MSimCrashed;
  sigemptyset(&sa.sa_mask);
  for (int k = 0; k < 5; k++) sigaction(sigs[k], &sa, &old[k]);
  const int sig = sigsetjmp(msim_crash_return, 1);
  if (sig) crashed = sig;
  else fn();
  for (int k = 0; k < 5; k++) sigaction(sigs[k], &old[k], NULL);
  return crashed;
}

/* PETSc's allocations with a cap on the size of any one of them: a reader that trusts a count in
   a malformed file (PETSc's Gmsh reader asked for 4.4 GB on a 17 KB file, found by fuzzing) then
   fails with PETSc's out-of-memory error instead of taking the machine's memory. Delegates to
   the allocator in place (PETSc's, or -malloc_debug's), so frees are unchanged. */
static size_t MSimAllocationCap;
static size_t MSimAllocationRefused;
static PetscErrorCode (*MSimAllocationInner)(size_t, PetscBool, int, const char[], const char[], void **);

static PetscErrorCode MSimCappedMalloc(size_t n, PetscBool clear, int line, const char fn[], const char file[], void **p)
{
  if (n > MSimAllocationCap) {
    *p = NULL;
    if (n > MSimAllocationRefused) MSimAllocationRefused = n;
    return PETSC_ERR_MEM;
  }
  return MSimAllocationInner(n, clear, line, fn, file, p);
}

PetscErrorCode MSimCallWithAllocationCap(size_t cap, size_t *refused, const std::function<PetscErrorCode(void)> &fn)
{
  MSimAllocationCap     = cap;
  MSimAllocationRefused = 0;
  MSimAllocationInner   = PetscTrMalloc;
  PetscTrMalloc         = MSimCappedMalloc;
  const PetscErrorCode ierr = fn();
  PetscTrMalloc = MSimAllocationInner;
  *refused      = MSimAllocationRefused;
  return ierr;
}
