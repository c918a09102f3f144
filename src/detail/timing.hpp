// Wall time of a pipeline's stages, for the *_ms fields of its result (align, find, inspect,
// stitch): a monotonic clock, so a change of the system time never gives a negative duration.
#pragma once

#include <chrono>

namespace align3d::detail {

using Clock = std::chrono::steady_clock;

// Milliseconds from `start` to now.
inline double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace align3d::detail
