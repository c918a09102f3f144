#pragma once
// Outliers for the generated scenes (scenes.cpp) and the evaluation's range scans (evaluate.cpp).

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "detail/random.hpp"

namespace align3d::synth {

// Appends n points scattered uniformly in the bounding box of `points` (x, y, z drawn in that
// order); returns n.
std::size_t add_outliers(std::vector<Eigen::Vector3d>& points, std::size_t n, Random& rng);

}  // namespace align3d::synth
