// Doubles rounded to float outwards: the float boxes of the kd-tree's nodes (kdtree.cpp) and of
// the mesh hierarchy (bvh_build.hpp) still contain what they bound, so every lower bound computed
// from them stays a lower bound.
#pragma once

#include <cmath>
#include <limits>

namespace align3d::detail {

// The largest float ≤ v (v itself when it is one).
inline float round_down(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) <= v ? f : std::nextafter(f, -std::numeric_limits<float>::max());
}
// The smallest float ≥ v.
inline float round_up(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) >= v ? f : std::nextafter(f, std::numeric_limits<float>::max());
}

}  // namespace align3d::detail
