// The one place align3d runs loops in parallel: a small thread pool of its own (parallel.cpp).
// Work is split into fixed chunks whose partial results are combined in chunk order, so a
// reduction gives the same bits whatever the thread count: determinism is part of the contract
// (README, "Determinism").
//
// Contract of parallel_tasks, parallel_for and parallel_reduce:
// - Threads. `threads` > 0 is the most threads a call uses, the calling thread included; 0 (or
//   less) means one per CPU the process may run on: its affinity mask (sched_getaffinity), read at
//   every call, so `taskset` and container cpusets lower it (a CPU quota such as docker --cpus
//   does not). At most 1024. OMP_NUM_THREADS and the other OpenMP variables have no effect.
// - Work decides the count. A call runs on min(threads, chunks) threads, chunks being the tasks
//   of parallel_tasks, runs of 256 items in parallel_for and of 1024 in parallel_reduce: a loop
//   of one chunk runs on the calling thread alone and pays no hand-off at all.
// - The pool. One per process, made at the first call that needs a second thread; it grows to
//   the largest number of helpers asked for (threads - 1) and lives until the process exits (its
//   threads are detached and never joined). The calling thread always takes part. A helper with
//   nothing to do polls for 50 µs, so that the next loop of the same computation finds it awake,
//   then sleeps on a condition variable: an idle pool uses no CPU, and a busy machine does not
//   lose cores to threads spinning for work (why align3d does not use OpenMP: README,
//   "Performance").
// - Nesting and concurrency. The pool runs one call at a time. A call made while it is busy, from
//   inside a body (nested) or from another thread of the program (two registrations at once, from
//   C++ threads or Python), runs serially on its calling thread: correct, deadlock-free and with
//   the same results, just not parallel. All three functions may be called from any thread.
// - Exceptions. When a body throws, no further chunks are started, the chunks already running
//   finish, and the first exception thrown is rethrown to the caller (the others are dropped).
// - fork(). A child process starts a new pool at its first parallel call; the parent's threads
//   do not exist there.
#pragma once

#include <algorithm>
#include <cstddef>
#include <memory>
#include <type_traits>
#include <vector>

namespace align3d {

// Number of threads a call with `threads` uses at most: `requested` if > 0, else the number of
// CPUs in the process's affinity mask (capped at 1024).
int thread_count(int requested);

namespace detail {
using TaskFn = void (*)(void* context, std::size_t task);
// Calls fn(context, t) for every t in [0, count) (parallel_tasks, type-erased).
void run_tasks(std::size_t count, int threads, TaskFn fn, void* context);
}  // namespace detail

// Calls task(t) for every t in [0, count), each on whichever thread is free; tasks must be
// independent. The building block of the two loops below, and of coarse-grained work (kd-tree
// subtrees) where one task is already worth a thread.
template <class Task>
void parallel_tasks(std::size_t count, int threads, Task&& task) {
  using T = std::remove_reference_t<Task>;
  detail::run_tasks(
      count, threads, [](void* t, std::size_t i) { (*static_cast<T*>(t))(i); },
      const_cast<void*>(static_cast<const void*>(std::addressof(task))));
}

// Calls body(i) for every i in [0, n); iterations must be independent. Threads take runs of 256
// consecutive i as they become free: runs keep the locality of spatially ordered work, and uneven
// work (dense and sparse regions) still spreads over the threads.
template <class Body>
void parallel_for(std::size_t n, int threads, Body&& body) {
  constexpr std::size_t kRun = 256;
  parallel_tasks((n + kRun - 1) / kRun, threads, [&](std::size_t run) {
    const std::size_t end = std::min(n, (run + 1) * kRun);
    for (std::size_t i = run * kRun; i < end; ++i) body(i);
  });
}

// Deterministic reduction: [0, n) is cut into chunks of a size that does not depend on the thread
// count; accumulate(acc, i) folds item i into a chunk's accumulator (started from `zero`), and the
// chunk accumulators are joined left to right with combine(a, b) -> a.
template <class Acc, class Accumulate, class Combine>
Acc parallel_reduce(std::size_t n, int threads, const Acc& zero, Accumulate&& accumulate,
                    Combine&& combine) {
  constexpr std::size_t kChunk = 1024;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<Acc> partial(chunks, zero);
  // Chunks go to whichever thread is free; each chunk's sum does not depend on which one it is.
  parallel_tasks(chunks, threads, [&](std::size_t c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) accumulate(partial[c], i);
  });
  Acc total = zero;
  for (const Acc& p : partial) combine(total, p);
  return total;
}

}  // namespace align3d
