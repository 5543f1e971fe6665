/* Third-party code that crashes on bad input (TetGen on some faulty surfaces, found by fuzzing)
   must not take msim down without its one-line error: a crash signal inside the call jumps back
   to it, and the caller reports the input as bad. The library's state is abandoned, not reused:
   msim exits with the error. */
#include <msim/crash_guard.h>
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
