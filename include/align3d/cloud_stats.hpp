// Measurements of a cloud that set align3d's data-relative defaults, so that the same data in
// millimetres or metres behaves the same: the point spacing, the surface noise and a robust extent;
// and the check that a cloud can take part in registration.
#pragma once

#include <cstddef>
#include <string>

#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

// Median nearest-neighbour distance between distinct points of `cloud` (on at most `samples`
// evenly spaced points): the point spacing. 0 for fewer than 2 points. `tree` indexes the cloud.
// `threads` (0: all cores) search in parallel; the result does not depend on it.
double point_spacing(const PointCloud& cloud, const KdTree& tree, std::size_t samples = 2000,
                     int threads = 1);

// The surface noise: the median, over at most `samples` evenly spaced points, of the RMS residual
// of each point's k nearest neighbours (k >= 7) about a quadric fitted to their heights over
// their tangent plane (unbiased for its 6 coefficients). A plane fit would count the surface's
// curvature as noise; the quadric absorbs it, so a curved part and a flat plate with the same
// sensor give the same value: ≈ σ for Gaussian noise σ along the normal (measured 1.0-1.15 σ on
// the generated scenes, flat and curved, k = 20); sharp edges do not move the median. 0 for fewer
// than 7 points.
double surface_noise(const PointCloud& cloud, const KdTree& tree, int k = 20,
                     std::size_t samples = 2000, int threads = 1);

// The diagonal of the box spanned, along each of the cloud's principal axes, by the 0.5th and
// 99.5th percentiles of the coordinates: the size of the bulk of the cloud, which a few stray
// points far away (a depth camera's flying pixels) do not inflate and which does not change when
// the cloud turns. 0 for an empty cloud.
double robust_extent(const PointCloud& cloud, int threads = 1);

// The three measures of one cloud, taken once per registration and passed down (align.hpp keeps
// the target's across calls: PreparedTarget).
struct CloudScale {
  double extent = 0;   // robust_extent
  double spacing = 0;  // point_spacing
  double noise = 0;    // surface_noise
};
// `tree` indexes the cloud; `threads` as for point_spacing.
CloudScale measure_scale(const PointCloud& cloud, const KdTree& tree, int threads = 1);

// Throws DataError(what, …) when a position or a normal has a NaN or Inf component (the readers
// drop such points; a cloud built in memory may still hold them).
void check_finite(const PointCloud& cloud, const std::string& what);

// Throws DataError(what, …) when the cloud is not finite (check_finite), has fewer than 6 points,
// all at one spot, or all on one line.
void check_registrable(const PointCloud& cloud, const std::string& what);

}  // namespace align3d
