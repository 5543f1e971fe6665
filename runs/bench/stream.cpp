// STREAM-style triad a = b + s c on arrays far larger than cache: the sustainable memory bandwidth
// of one core, the yardstick for "within 2x of the memory traffic" of the force loop.
#include <chrono>
#include <cstdio>
#include <vector>
int main()
{
  const size_t n = 1 << 25; // 3 x 256 MiB
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  double best = 1e30;
  for (int rep = 0; rep < 5; rep++) {
    auto t0 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < n; i++) a[i] = b[i] + 3.0 * c[i];
    auto t1 = std::chrono::steady_clock::now();
    double s = std::chrono::duration<double>(t1 - t0).count();
    if (s < best) best = s;
  }
  // 3 arrays move (a is written; write-allocate would add a read: counted as the STREAM convention, 24 B/element)
  std::printf("%.3f\n", 24.0 * n / best / 1e9);
  return a[n / 2] == 7.0 ? 0 : 1;
}
