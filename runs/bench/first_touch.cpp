// The rate at which a process gets fresh memory: the first write to each page of a new 1 GiB
// mapping (the kernel zeroes and maps it, and under a hypervisor the host backs it first) against
// a second write to the same pages. Setup builds every array the run will use, so the memory it
// touches for the first time bounds it from below at this rate: the setup floor in
// runs/scaling. Three fresh mappings in turn: the first gets pages this process never had (cold:
// on this virtual machine the host backs them anew, as for a new msim process), the next two
// reuse the pages the kernel just took back from the unmapped one (warm: as memory a process
// frees and allocates again). Printed per page size (4 KiB, then transparent huge pages): GB/s
// of the cold first touch, of the best warm first touch, and of the best second write.
#include <sys/mman.h>
#include <chrono>
#include <cstdio>
#include <cstring>
static double Seconds(char *p, size_t n, int value)
{
  auto t0 = std::chrono::steady_clock::now();
  std::memset(p, value, n);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
int main()
{
  const size_t n = 1UL << 30;
  for (int huge = 1; huge >= 0; huge--) {
    double cold = 0, warm = 1e30, second = 1e30;
    for (int rep = 0; rep < 3; rep++) {
      char *p = (char *)mmap(nullptr, n, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (p == MAP_FAILED) return 1;
      if (huge) madvise(p, n, MADV_HUGEPAGE);
      double a = Seconds(p, n, 1), b = Seconds(p, n, 2);
      if (rep == 0) cold = a;
      else warm = a < warm ? a : warm;
      second = b < second ? b : second;
      munmap(p, n);
    }
    std::printf("%s %.3f %.3f %.3f\n", huge ? "thp" : "4k", n / cold / 1e9, n / warm / 1e9, n / second / 1e9);
  }
  return 0;
}
