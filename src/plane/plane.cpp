#include "align3d/plane/plane.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "align3d/error.hpp"
#include "detail/random.hpp"

namespace align3d {

Plane fit_plane(const std::vector<Eigen::Vector3d>& points,
                const std::vector<std::size_t>* indices) {
  const std::size_t n = indices ? indices->size() : points.size();
  if (n < 3) throw DataError(std::to_string(n) + " points define no plane (need at least 3)");
  auto at = [&](std::size_t i) -> const Eigen::Vector3d& {
    return points[indices ? (*indices)[i] : i];
  };
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) mean += at(i);
  mean /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) cov.noalias() += (at(i) - mean) * (at(i) - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
  if (!(ev(2) > 0)) throw DataError("all points are at one spot: no plane");
  if (ev(1) <= 1e-12 * ev(2)) throw DataError("all points lie on one line: no plane");
  // A volume (a blob, a sphere) spreads across any plane about as much as along it; a plate with a
  // part standing on it (20 % of the points) stays near 0.1.
  if (ev(0) > kMaxPlaneSpread * ev(1))
    throw DataError("no plane: the points spread across the best plane as much as along it");
  return {eig.eigenvectors().col(0).normalized(), mean};
}

namespace {

double median_abs(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

std::vector<std::size_t> within(const std::vector<Eigen::Vector3d>& points, const Plane& plane,
                                double threshold) {
  std::vector<std::size_t> inliers;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (std::abs(plane.signed_distance(points[i])) <= threshold) inliers.push_back(i);
  return inliers;
}

}  // namespace

RansacPlaneResult ransac_plane(const std::vector<Eigen::Vector3d>& points,
                               const RansacPlaneSettings& settings) {
  const std::size_t n = points.size();
  if (n < 3) throw DataError(std::to_string(n) + " points define no plane (need at least 3)");
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  const double diagonal = box.diagonal().norm();
  if (!(diagonal > 0)) throw DataError("all points are at one spot: no plane");
  const double threshold = settings.threshold > 0 ? settings.threshold : 0.005 * diagonal;

  // The points candidates are counted on: all, or every m-th (settings.score_points).
  const std::size_t stride = settings.score_points > 0 && n > settings.score_points
                                 ? (n + settings.score_points - 1) / settings.score_points
                                 : 1;
  Random rng(settings.seed);
  std::size_t best_count = 0;
  Plane best;
  for (int it = 0; it < settings.iterations; ++it) {
    const Eigen::Vector3d& a = points[rng.below(n)];
    const Eigen::Vector3d& b = points[rng.below(n)];
    const Eigen::Vector3d& c = points[rng.below(n)];
    const Eigen::Vector3d normal = (b - a).cross(c - a);
    if (normal.norm() <= 1e-12 * diagonal * diagonal) continue;  // collinear sample
    const Plane candidate{normal.normalized(), a};
    std::size_t count = 0;
    for (std::size_t i = 0; i < n; i += stride)
      count += std::abs(candidate.signed_distance(points[i])) <= threshold;
    if (count > best_count) {
      best_count = count;
      best = candidate;
    }
  }
  if (stride > 1 && best_count > 0) best_count = within(points, best, threshold).size();
  if (best_count < 3)
    throw DataError("all points lie on one line: no plane (no 3-point sample spanned one)");
  // A blob, a sphere or scattered points: any slab holds a small share of them.
  if (static_cast<double>(best_count) < kMinPlaneShare * static_cast<double>(n)) {
    std::ostringstream msg;
    msg << "no plane: the best plane holds only " << std::setprecision(2)
        << 100.0 * static_cast<double>(best_count) / static_cast<double>(n)
        << " % of the points within " << threshold << " (at least " << 100 * kMinPlaneShare
        << " % needed)";
    throw DataError(msg.str());
  }

  RansacPlaneResult result{best, within(points, best, threshold)};
  for (int refit = 0; refit < 2; ++refit) {
    result.plane = fit_plane(points, &result.inliers);
    std::vector<double> residuals;
    residuals.reserve(result.inliers.size());
    for (std::size_t i : result.inliers)
      residuals.push_back(std::abs(result.plane.signed_distance(points[i])));
    const double sigma = 1.4826 * median_abs(residuals);
    auto next = within(points, result.plane, std::max(3 * sigma, threshold / 10));
    if (next.size() < 3) break;
    result.inliers = std::move(next);
  }
  result.plane = fit_plane(points, &result.inliers);
  return result;
}

}  // namespace align3d
