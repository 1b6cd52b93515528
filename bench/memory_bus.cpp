// What a second thread can gain on this machine where a loop waits on memory: a streaming
// triad (c = a + 1.5 b over three 128 MB arrays, the shape of the momentum step, the residual
// and the contact list's passes) and a random gather over the same arrays (the shape of a
// sweep's reads of v), each on 1 thread and on N, alternated, the best of 5.
//
//   ./build/bench/memory_bus [N]      (N: 2 unless given)
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

template <class Loop>
double bestSeconds(Loop&& loop) {
  double best = 1e300;
  for (int repeat = 0; repeat < 5; ++repeat) {
    const auto start = std::chrono::steady_clock::now();
    loop();
    best = std::min(
        best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  const int threads = argc > 1 ? std::atoi(argv[1]) : 2;
  if (threads < 1 || threads > 1024) {
    std::fprintf(stderr, "memory_bus: the thread count must be in [1, 1024], got %s\n", argv[1]);
    return 2;
  }
  const long n = 1L << 24;
  std::vector<double> a(n, 1.0), b(n, 2.0), c(n, 0.0);
  std::vector<int> index(n);
  for (long i = 0; i < n; ++i) index[i] = static_cast<int>((i * 2654435761UL) % n);
  double sink = 0.0;
  std::printf("| loop | 1 thread | %d threads | ratio |\n|---|---|---|---|\n", threads);
  double triad[2] = {1e300, 1e300}, gather[2] = {1e300, 1e300};
  for (int round = 0; round < 2; ++round)
    for (int k = 0; k < 2; ++k) {
      const int count = k == 0 ? 1 : threads;
      triad[k] = std::min(triad[k], bestSeconds([&] {
#pragma omp parallel for schedule(static) num_threads(count)
                            for (long i = 0; i < n; ++i) c[i] = a[i] + 1.5 * b[i];
                          }));
      gather[k] = std::min(gather[k], bestSeconds([&] {
                             double sum = 0.0;
#pragma omp parallel for schedule(static) num_threads(count) reduction(+ : sum)
                             for (long i = 0; i < n; ++i) sum += a[index[i]];
                             sink += sum;
                           }));
    }
  const double bytes = 3.0 * sizeof(double) * static_cast<double>(n);
  std::printf("| streaming triad (GB/s) | %.1f | %.1f | %.2f |\n", bytes / triad[0] / 1e9,
              bytes / triad[1] / 1e9, triad[0] / triad[1]);
  std::printf("| random gather (s) | %.3f | %.3f | %.2f |\n", gather[0], gather[1],
              gather[0] / gather[1]);
  return sink == 0.0 ? 1 : 0;  // keeps the gathers
}
