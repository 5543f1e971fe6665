// STREAM-style triad a = b + s c on arrays far larger than cache, on every rank at once: the
// memory bandwidth that many ranks get together, the yardstick for "within 2x of the memory
// traffic" of the force loop run on as many ranks. Ranks on one machine share its memory system:
// here two ranks got 1.2-1.7x what one does, not 2x, so one core's figure would be the wrong
// yardstick for a two-rank run.
#include <mpi.h>
#include <chrono>
#include <cstdio>
#include <vector>
int main(int argc, char **argv)
{
  MPI_Init(&argc, &argv);
  int rank, size;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const size_t n = 1 << 25; // 3 x 256 MiB per rank
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  double best = 1e30;
  for (int rep = 0; rep < 5; rep++) {
    MPI_Barrier(MPI_COMM_WORLD); // all ranks stream at the same time
    auto t0 = std::chrono::steady_clock::now();
    for (size_t i = 0; i < n; i++) a[i] = b[i] + 3.0 * c[i];
    auto t1 = std::chrono::steady_clock::now();
    double s = std::chrono::duration<double>(t1 - t0).count(), slowest;
    MPI_Allreduce(&s, &slowest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    if (slowest < best) best = slowest;
  }
  // 3 arrays move per rank (a is written; write-allocate would add a read: counted as the STREAM
  // convention, 24 B/element); printed: GB/s of all ranks together
  if (!rank) std::printf("%.3f\n", size * 24.0 * n / best / 1e9);
  MPI_Finalize();
  return a[n / 2] == 7.0 ? 0 : 1;
}
