// ThreadSanitizer self-check, built only with ALIGN3D_SANITIZE_THREAD: it proves that the TSan
// stage (scripts/tsan.sh) both sees the pool's synchronisation and reports a race, on align3d's
// own parallel helper (src/detail/parallel.hpp). Every run is the same, whatever the scheduling:
// - Each region is parallel_tasks(2, 2) whose two tasks first meet at a rendezvous, so two
//   distinct threads of the pool (the caller and a helper) are certain to run one task each, at
//   the same time; a thread cannot take both tasks, it would wait for itself. If the pool ever ran
//   them on one thread, the rendezvous times out and the check fails (exit 2), never hangs.
// - "clean": region 1 writes one half of an array per task; region 2 has each task read every
//   half that another thread wrote (at least one, as the two writers were distinct). Those reads
//   are ordered after the writes only by the pool's join and hand-off, so TSan stays silent only
//   if it sees them (it sees std::atomic, std::mutex and std::thread natively).
// - "race": after the rendezvous, both tasks of region 1 also write one shared variable without
//   synchronisation. Both writes happen (the region joins both tasks) and nothing orders them, so
//   TSan reports the race every time; ctest passes only on that report
//   (PASS_REGULAR_EXPRESSION in tests/CMakeLists.txt, which needs a symbolised file name).
#include <atomic>
#include <cstdio>
#include <cstring>
#include <thread>
#include <vector>

#include "detail/parallel.hpp"
#include "rendezvous.hpp"

int main(int argc, char** argv) {
  const bool race = argc > 1 && std::strcmp(argv[1], "race") == 0;
  constexpr std::size_t kHalf = 4096;
  std::vector<double> values(2 * kHalf, 0.0);
  std::thread::id writer[2];
  long shared = 0;  // written by both threads in "race" mode
  std::atomic<bool> alone{false};

  align3d::Rendezvous first(2);
  align3d::parallel_tasks(2, 2, [&](std::size_t half) {
    if (!first.arrive_and_wait()) alone = true;
    writer[half] = std::this_thread::get_id();
    for (std::size_t i = half * kHalf; i < (half + 1) * kHalf; ++i) values[i] = 1.0;
    if (race) shared = static_cast<long>(half) + 1;
  });

  align3d::Rendezvous second(2);
  std::atomic<long> read_elsewhere{0};  // items read by a thread that did not write them
  double sums[2] = {0, 0};
  align3d::parallel_tasks(2, 2, [&](std::size_t task) {
    if (!second.arrive_and_wait()) alone = true;
    for (int half = 0; half < 2; ++half) {
      if (writer[half] == std::this_thread::get_id()) continue;
      for (std::size_t i = half * kHalf; i < (half + 1) * kHalf; ++i) sums[task] += values[i];
      read_elsewhere += kHalf;
    }
  });

  if (alone || writer[0] == writer[1]) {
    std::fprintf(stderr, "the pool did not run the two tasks on two threads at once\n");
    return 2;
  }
  std::printf("read %ld items written by the other thread, shared %ld\n", read_elsewhere.load(),
              shared);
  return sums[0] + sums[1] == static_cast<double>(read_elsewhere.load()) ? 0 : 1;
}
