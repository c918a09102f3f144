// Plane fitting (chapter 39.5). The chapter fits z = a·x + b·y + c; we fit the total-least-squares
// plane (normal = eigenvector of the smallest eigenvalue of the covariance), which minimises the
// true perpendicular distances and also works for steep or vertical planes.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace align3d {

struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    // a point on the plane (the fitted centroid)
  double signed_distance(const Eigen::Vector3d& p) const { return normal.dot(p - point); }
};

// Least-squares plane through `points` (all of them, or those listed in `indices`). The normal's
// sign is unspecified. Throws DataError when fewer than 3 points, they are collinear/coincident, or
// they form a volume rather than a surface (smallest covariance eigenvalue > kMaxPlaneSpread × the
// middle one).
constexpr double kMaxPlaneSpread = 0.5;
Plane fit_plane(const std::vector<Eigen::Vector3d>& points,
                const std::vector<std::size_t>* indices = nullptr);

struct RansacPlaneSettings {
  // Inlier distance for the consensus; 0: 0.5 % of the bounding-box diagonal (unit-free). The final
  // inliers are re-selected at 3 σ̂ of the refit's residuals (σ̂ = 1.4826 · MAD), see below.
  double threshold = 0.0;
  int iterations = 500;
  std::uint64_t seed = 1;  // same seed, same result (single-threaded)
  // Candidates are counted on at most this many points (every m-th), 0: all; the inliers and the
  // refits take every point. A plane holding a fifth of 2000 points is counted to ±2 % of them:
  // enough to tell the dominant plane at a fraction of the cost on a large cloud.
  std::size_t score_points = 0;
};

struct RansacPlaneResult {
  Plane plane;
  std::vector<std::size_t> inliers;  // ascending
};

// The dominant plane: RANSAC on 3-point samples, then least-squares refits on the inliers, twice,
// each time re-selecting inliers within max(3 σ̂, threshold / 10). Throws DataError when no plane:
// fewer than 3 usable points, or the best consensus holds less than kMinPlaneShare of the points
// (a blob, a sphere, scattered points).
constexpr double kMinPlaneShare = 0.05;
RansacPlaneResult ransac_plane(const std::vector<Eigen::Vector3d>& points,
                               const RansacPlaneSettings& settings = {});

}  // namespace align3d
