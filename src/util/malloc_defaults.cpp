/* Memory allocation defaults msim sets for itself: glibc's malloc with transparent huge pages
   (hugetlb=1) and without returning freed memory to the system (mmap_max=0: large blocks come from
   the heap too; trim_threshold: the heap is not shrunk). Setup at scale moves records of
   every spring through large transient arrays; each fresh 4 KB page costs a fault, and faults are
   expensive on virtual machines: on a 6-million-tet box the distribution stage took 5.7 s with
   glibc's defaults, 2.3 s with huge pages and 1.3 s with reuse as well, at the same peak memory
   (runs/scaling/README.md). glibc reads these tunables when a process starts, so msim sets
   GLIBC_TUNABLES and runs itself once more, before MPI starts; a GLIBC_TUNABLES the user set
   stays, MSIM_MALLOC_DEFAULTS=0 keeps glibc's own, and nothing is done under valgrind. */
#include <msim/init.h>
#include <cstdlib>
#include <cstring>
#include <gnu/libc-version.h>
#include <unistd.h>

void MSimSetMallocDefaults(int argc, char **argv)
{
  const char *off = getenv("MSIM_MALLOC_DEFAULTS"), *preload = getenv("LD_PRELOAD");
  int         major = 0, minor = 0;

  (void)argc;
  if (getenv("GLIBC_TUNABLES") || (off && !strcmp(off, "0")) || getenv("MSIM_MALLOC_DEFAULTS_SET")) return;
  if (preload && strstr(preload, "vgpreload")) return; /* valgrind: /proc/self/exe is valgrind's */
  /* the hugetlb tunable came with glibc 2.35; older ones ignore what they do not know, but the
     run would be repeated for nothing */
  if (sscanf(gnu_get_libc_version(), "%d.%d", &major, &minor) != 2 || major < 2 || (major == 2 && minor < 35)) return;
  setenv("GLIBC_TUNABLES", "glibc.malloc.hugetlb=1:glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=1099511627776", 1);
  setenv("MSIM_MALLOC_DEFAULTS_SET", "1", 1);
  execv("/proc/self/exe", argv);
  /* the exec failed: go on with glibc's defaults */
}
