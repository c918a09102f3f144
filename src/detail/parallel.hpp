// The one place align3d runs loops in parallel (OpenMP). Work is split into fixed chunks whose
// partial results are combined in chunk order, so a reduction gives the same bits whatever the
// thread count: determinism is part of the contract (README, "Determinism").
#pragma once

#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <vector>

namespace align3d {

// Number of threads to use: `requested` if > 0, otherwise OpenMP's default (OMP_NUM_THREADS or the
// number of cores).
inline int thread_count(int requested) { return requested > 0 ? requested : omp_get_max_threads(); }

// Calls body(i) for every i in [0, n); iterations must be independent. Threads take runs of 256
// consecutive i as they become free: runs keep the locality of spatially ordered work, and uneven
// work (dense and sparse regions) still spreads over the threads.
template <class Body>
void parallel_for(std::size_t n, int threads, Body&& body) {
#pragma omp parallel for schedule(dynamic, 256) num_threads(thread_count(threads))
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i)
    body(static_cast<std::size_t>(i));
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
#pragma omp parallel for schedule(dynamic) num_threads(thread_count(threads))
  for (std::ptrdiff_t c = 0; c < static_cast<std::ptrdiff_t>(chunks); ++c) {
    const std::size_t begin = static_cast<std::size_t>(c) * kChunk;
    const std::size_t end = std::min(n, begin + kChunk);
    for (std::size_t i = begin; i < end; ++i) accumulate(partial[c], i);
  }
  Acc total = zero;
  for (const Acc& p : partial) combine(total, p);
  return total;
}

}  // namespace align3d
