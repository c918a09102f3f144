#include "align3d/cloud_stats.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

#include "align3d/error.hpp"
#include "detail/pca.hpp"

namespace align3d {
namespace {

double median(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

std::size_t sample_step(std::size_t n, std::size_t samples) {
  return std::max<std::size_t>(1, n / std::max<std::size_t>(1, samples));
}

}  // namespace

double point_spacing(const PointCloud& cloud, const KdTree& tree, std::size_t samples) {
  const std::size_t n = cloud.size();
  if (n < 2) return 0.0;
  std::vector<double> d;
  std::vector<Neighbor> nb;
  for (std::size_t i = 0; i < n; i += sample_step(n, samples)) {
    tree.knn(cloud.positions[i], 2, nb);
    for (const auto& m : nb)
      if (m.index != i && m.sq_distance > 0) {
        d.push_back(std::sqrt(m.sq_distance));
        break;
      }
  }
  return median(d);
}

double surface_noise(const PointCloud& cloud, const KdTree& tree, int k, std::size_t samples) {
  const std::size_t n = cloud.size();
  if (n < 3 || k < 3) return 0.0;
  std::vector<double> rms;
  std::vector<Neighbor> nb;
  for (std::size_t i = 0; i < n; i += sample_step(n, samples)) {
    tree.knn_unsorted(cloud.positions[i], static_cast<std::size_t>(k), nb);
    const auto eig = detail::neighbourhood_pca(cloud.positions, cloud.positions[i], nb);
    rms.push_back(std::sqrt(std::max(0.0, eig.eigenvalues()(0))));
  }
  return median(rms);
}

double robust_extent(const PointCloud& cloud) {
  const std::size_t n = cloud.size();
  if (n == 0) return 0.0;
  // Percentiles of at most ~100 000 evenly spaced points: enough for 0.5 % tails.
  const std::size_t step = sample_step(n, 100000);
  Eigen::Vector3d low, high;
  std::vector<double> c;
  for (int axis = 0; axis < 3; ++axis) {
    c.clear();
    for (std::size_t i = 0; i < n; i += step) c.push_back(cloud.positions[i](axis));
    const auto at = [&](double q) {
      const auto k = static_cast<std::ptrdiff_t>(std::floor(q * static_cast<double>(c.size() - 1)));
      std::nth_element(c.begin(), c.begin() + k, c.end());
      return c[static_cast<std::size_t>(k)];
    };
    low(axis) = at(0.005);
    high(axis) = at(0.995);
  }
  return (high - low).norm();
}

void check_registrable(const PointCloud& cloud, const std::string& what) {
  if (cloud.size() < 6)
    throw DataError(what, std::to_string(cloud.size()) + " points; registration needs at least 6");
  const Eigen::Vector3d c = centroid(cloud);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : cloud.positions) cov.noalias() += (p - c) * (p - c).transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();
  if (!(ev(2) > 0)) throw DataError(what, "all points are at one spot");
  if (ev(1) <= 1e-12 * ev(2)) throw DataError(what, "all points lie on one line");
}

}  // namespace align3d
