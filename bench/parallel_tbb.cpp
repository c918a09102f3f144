// The oneTBB alternative to align3d's thread pool, kept for the measurement in bench/README.md
// ("Shared machine") and not built by default: the same run_tasks and thread_count as
// src/detail/parallel.cpp (so the same chunks and the same results), on tbb::parallel_for with
// one tbb::task_arena per thread count. To build align3d with it (Debian's libtbb-dev):
//   cp bench/parallel_tbb.cpp src/detail/parallel.cpp
//   add `find_package(TBB REQUIRED)` and `TBB::tbb` to the library's links in CMakeLists.txt
#include <sched.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "detail/parallel.hpp"

namespace align3d {

int thread_count(int requested) {
  if (requested > 0) return std::min(requested, 1024);
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) == 0) return std::clamp(CPU_COUNT(&set), 1, 1024);
  return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 1024);
}

namespace detail {
namespace {

// One arena per thread count, made once (an arena may be used from any thread).
tbb::task_arena& arena(int threads) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<tbb::task_arena>> arenas;
  std::lock_guard<std::mutex> lock(mutex);
  auto& a = arenas[threads];
  if (!a) a = std::make_unique<tbb::task_arena>(threads);
  return *a;
}

}  // namespace

void run_tasks(std::size_t count, int threads, TaskFn fn, void* context) {
  const auto used = std::min(static_cast<std::size_t>(thread_count(threads)), count);
  if (used <= 1) {
    for (std::size_t t = 0; t < count; ++t) fn(context, t);
    return;
  }
  arena(static_cast<int>(used)).execute([&] {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, count, 1),
        [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t t = r.begin(); t != r.end(); ++t) fn(context, t);
        },
        tbb::simple_partitioner());
  });
}

}  // namespace detail
}  // namespace align3d
