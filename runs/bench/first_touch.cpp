// The rate at which a process gets fresh memory: the first write to each page of a new 1 GiB
// mapping (the kernel zeroes and maps it, and under a hypervisor the host backs it first) against
// a second write to the same pages. Setup builds every array the run will use, so the memory it
// touches for the first time bounds it from below at this rate: the setup floor in
// runs/scaling. Printed: GB/s of the first touch (4 KiB pages, then transparent huge pages),
// then of the second, each the best of three fresh mappings.
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
  for (int huge = 0; huge < 2; huge++) {
    double first = 1e30, second = 1e30;
    for (int rep = 0; rep < 3; rep++) {
      char *p = (char *)mmap(nullptr, n, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (p == MAP_FAILED) return 1;
      if (huge) madvise(p, n, MADV_HUGEPAGE);
      double a = Seconds(p, n, 1), b = Seconds(p, n, 2);
      first  = a < first ? a : first;
      second = b < second ? b : second;
      munmap(p, n);
    }
    std::printf("%s %.3f %.3f\n", huge ? "thp" : "4k", n / first / 1e9, n / second / 1e9);
  }
  return 0;
}
