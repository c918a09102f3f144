// The deviation of measured points from a CAD surface: each point's signed distance to the mesh
// (mesh_index.hpp: + outside the material, − inside), the points too far from any surface set
// apart as outliers, and the statistics a quality engineer reads: moments, percentiles, a robust
// Gauss fit and a histogram. The measuring step of `align3d inspect` (inspect.hpp), usable on its
// own when the scan is already in the CAD frame.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "align3d/mesh_index.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

struct DeviationMap {
  // Per point, in the order given: the signed distance, the closest point on the surface (CAD
  // frame) and its triangle (MeshIndex::mesh() numbering); for an outlier NaN, NaN and
  // kNoTriangle (its search stops at max_distance).
  std::vector<double> deviation;
  std::vector<Eigen::Vector3d> closest;
  std::vector<std::uint32_t> triangle;
  std::size_t outliers = 0;  // points farther than max_distance from every surface
  double max_distance = 0;
};

// Measures every T·points[i] (CAD ≈ T·scan) against `cad`: exact distances in double precision,
// signs by the angle-weighted pseudo-normals. Points farther than `max_distance` are outliers.
// Runs on `threads` threads (0: all cores); the result does not depend on it. Memory: the map holds
// 36 bytes a point; while it runs, 20 bytes a point more at most (the spatial order: 4, and 16
// while it is sorted; each answer is written in place); and the index (MeshIndex::memory_bytes(),
// 85 MB for 208 k triangles).
DeviationMap measure_deviations(const std::vector<Eigen::Vector3d>& points, const MeshIndex& cad,
                                const Eigen::Isometry3d& T, double max_distance, int threads = 0);

// The statistics of the finite deviations (outliers, NaN, are left out). Percentiles interpolate
// linearly between order statistics (numpy's default, type 7). All zero when count is 0.
struct DeviationStats {
  std::size_t count = 0;
  double mean = 0, std = 0, rms = 0, min = 0, max = 0;  // std: population (divides by count)
  double p01 = 0, p05 = 0, p50 = 0, p95 = 0, p99 = 0;   // the 1st, 5th, ... percentiles
};
DeviationStats deviation_stats(const std::vector<double>& deviation);

// A Gauss curve fitted to the bulk of the deviations: mean = their median, sigma = 1.4826 × their
// median absolute deviation from it. Robust: the measuring noise of a part with a few dents
// (which least squares, the mean and std, would widen).
struct GaussFit {
  double mean = 0, sigma = 0;
};
GaussFit gauss_fit(const std::vector<double>& deviation);

// Counts of the finite deviations in `bins` equal bins over [lo, hi); those outside are counted in
// below / above.
struct Histogram {
  double lo = 0, hi = 0;
  std::vector<std::size_t> counts;
  std::size_t below = 0, above = 0;
  double width() const {
    return counts.empty() ? 0 : (hi - lo) / static_cast<double>(counts.size());
  }
};
Histogram histogram(const std::vector<double>& deviation, double lo, double hi, int bins);

}  // namespace align3d
