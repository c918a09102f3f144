// ThreadSanitizer self-check of the OpenMP configuration, built only with ALIGN3D_SANITIZE_THREAD.
// It checks soundness both ways on align3d's own parallel helper (parallel.hpp):
// - "clean": one parallel_for writes, the following parallel_reduce reads what the other thread
//   wrote. Race-free only through the runtime's join barrier, so it is silent only if TSan sees
//   OpenMP's synchronisation (Archer loaded); without Archer TSan reports a race here.
// - "race": parallel_for increments a shared counter unsynchronised; ctest passes only if TSan
//   reports it (PASS_REGULAR_EXPRESSION in tests/CMakeLists.txt).
// Both need a team of more than one thread (2 requested) in which both threads run items, and
// fail otherwise. parallel_for hands out runs of items dynamically, so each item first waits
// ~20 µs: without that, the first thread could take every run before the second one starts, and
// the "race" mode would have no second writer to report.
#include <omp.h>

#include <cstdio>
#include <cstring>
#include <vector>

#include "detail/parallel.hpp"

int main(int argc, char** argv) {
  const bool race = argc > 1 && std::strcmp(argv[1], "race") == 0;
  constexpr std::size_t kN = 4096;
  std::vector<double> values(kN, 1.0);
  std::vector<int> team(kN, 0), worker(kN, -1);
  long shared_counter = 0;  // written by every thread in "race" mode
  align3d::parallel_for(kN, 2, [&](std::size_t i) {
    for (const double start = omp_get_wtime(); omp_get_wtime() - start < 20e-6;) {
    }
    values[i] = 2.0 * static_cast<double>(i);
    team[i] = omp_get_num_threads();
    worker[i] = omp_get_thread_num();
    if (race) ++shared_counter;
  });
  // Chunk c of the reduction reads the mirrored chunk, written by the other thread above.
  const double sum = align3d::parallel_reduce(
      kN, 2, 0.0, [&](double& acc, std::size_t i) { acc += values[kN - 1 - i]; },
      [](double& a, double b) { a += b; });
  if (team[0] < 2 || team[kN - 1] < 2) {
    std::fprintf(stderr, "parallel_for ran with %d thread(s); the check needs 2\n", team[0]);
    return 1;
  }
  bool ran[2] = {false, false};
  for (int w : worker)
    if (w == 0 || w == 1) ran[w] = true;
  if (!ran[0] || !ran[1]) {
    std::fprintf(stderr, "only one thread of the team ran items; the check needs both\n");
    return 1;
  }
  std::printf("team %d, sum %.0f, counter %ld\n", team[0], sum, shared_counter);
  return sum == static_cast<double>(kN) * static_cast<double>(kN - 1) ? 0 : 1;
}
