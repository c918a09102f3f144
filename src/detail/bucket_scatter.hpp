// One stable counting-sort pass, in parallel: the first pass of spatial_order's radix sort
// (kdtree.cpp). Written by hand: the standard library and TBB sort by comparison (O(n log n)),
// and neither groups items by a small key in one pass.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "detail/parallel.hpp"

namespace align3d::detail {

// Writes in[0, n) to out grouped by bucket_of(item) (a number below `buckets`), each group in
// input order, and returns each group's first place (buckets + 1 entries, the last n). Fixed
// chunks of items count their buckets, then each chunk scatters to the places its counts give it,
// so the result does not depend on which thread takes which chunk. Memory: 4 bytes a bucket a
// chunk of 16 384 items.
template <class T, class BucketOf>
std::vector<std::size_t> scatter_by_bucket(const T* in, T* out, std::size_t n, std::size_t buckets,
                                           int threads, BucketOf&& bucket_of) {
  constexpr std::size_t kChunk = std::size_t{1} << 14;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::size_t> next(chunks * buckets, 0);  // [chunk][bucket]: counts, then places
  parallel_tasks(chunks, threads, [&](std::size_t c) {
    for (std::size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i)
      ++next[c * buckets + bucket_of(in[i])];
  });
  std::vector<std::size_t> first(buckets + 1);
  std::size_t place = 0;
  for (std::size_t b = 0; b < buckets; ++b) {
    first[b] = place;
    for (std::size_t c = 0; c < chunks; ++c) place += std::exchange(next[c * buckets + b], place);
  }
  first[buckets] = n;
  parallel_tasks(chunks, threads, [&](std::size_t c) {
    std::size_t* to = &next[c * buckets];
    for (std::size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i)
      out[to[bucket_of(in[i])]++] = in[i];
  });
  return first;
}

}  // namespace align3d::detail
