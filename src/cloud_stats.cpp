#include "align3d/cloud_stats.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "align3d/error.hpp"
#include "detail/parallel.hpp"
#include "detail/pca.hpp"

namespace align3d {
namespace {

// The upper median (the middle value, or the larger of the two middle ones) of the values
// measured, NaN standing for none; reorders v and drops its NaNs. 0 when none was measured.
double upper_median(std::vector<double>& v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

std::size_t sample_step(std::size_t n, std::size_t samples) {
  return std::max<std::size_t>(1, n / std::max<std::size_t>(1, samples));
}

// The RMS residual of point i's k nearest neighbours about a quadric fitted to their heights over
// their tangent plane (surface_noise); NaN for fewer than 7 neighbours.
double quadric_rms(const PointCloud& cloud, const KdTree& tree, std::size_t i, int k,
                   std::vector<Neighbor>& nb) {
  const Eigen::Vector3d& p = cloud.positions[i];
  tree.knn_unsorted(p, static_cast<std::size_t>(k), nb);
  if (nb.size() < 7) return std::numeric_limits<double>::quiet_NaN();
  // Height over the tangent plane of the neighbourhood (its principal axes), fitted by the
  // quadric h = a u² + b uv + c v² + d u + e v + f: its residuals hold the noise and not the
  // curvature, which a plane fit would count as noise on a curved part.
  const auto eig = detail::neighbourhood_pca(cloud.positions, p, nb);
  const Eigen::Matrix3d axes = eig.eigenvectors();
  // The least-squares fit by its normal equations (6 × 6, nothing allocated; a QR of the k × 6
  // design took a third of the estimate's time), in coordinates over the neighbourhood's spread so
  // that u², u and 1 are of one size and the equations stay well conditioned.
  const double scale = std::sqrt(std::max(eig.eigenvalues()(2), 0.0));
  if (!(scale > 0)) return 0.0;  // the neighbours coincide: no spread, no noise
  const Eigen::Matrix3d to_local = axes.transpose() / scale;
  auto monomials = [&](const Eigen::Vector3d& q, double& height) {
    const Eigen::Vector3d d = to_local * (q - p);
    const double u = d(2), v = d(1);  // the two largest axes span the plane, d(0) is the height
    height = d(0);
    return Eigen::Matrix<double, 6, 1>(u * u, u * v, v * v, u, v, 1.0);
  };
  Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  for (const auto& m : nb) {
    double h = 0;
    const Eigen::Matrix<double, 6, 1> a = monomials(cloud.positions[m.index], h);
    normal.noalias() += a * a.transpose();
    rhs += h * a;
  }
  const Eigen::Matrix<double, 6, 1> coeffs = normal.colPivHouseholderQr().solve(rhs);
  double sq = 0;
  for (const auto& m : nb) {
    double h = 0;
    const double r = monomials(cloud.positions[m.index], h).dot(coeffs) - h;
    sq += r * r;
  }
  // Unbiased for the 6 fitted coefficients; back in the data's units.
  return scale * std::sqrt(sq / static_cast<double>(nb.size() - 6));
}

}  // namespace

double point_spacing(const PointCloud& cloud, const KdTree& tree, std::size_t samples,
                     int threads) {
  const std::size_t n = cloud.size();
  if (n < 2) return 0.0;
  const std::size_t step = sample_step(n, samples);
  // Each sample's distance to its nearest distinct point, in place (NaN: none), then the median.
  std::vector<double> d((n + step - 1) / step, std::numeric_limits<double>::quiet_NaN());
  parallel_for(d.size(), threads, [&](std::size_t k) {
    thread_local std::vector<Neighbor> nb;
    const std::size_t i = k * step;
    tree.knn(cloud.positions[i], 2, nb);
    for (const auto& m : nb)
      if (m.index != i && m.sq_distance > 0) {
        d[k] = std::sqrt(m.sq_distance);
        break;
      }
  });
  return upper_median(d);
}

double surface_noise(const PointCloud& cloud, const KdTree& tree, int k, std::size_t samples,
                     int threads) {
  const std::size_t n = cloud.size();
  if (n < 7 || k < 7) return 0.0;
  const std::size_t step = sample_step(n, samples);
  std::vector<double> rms((n + step - 1) / step);
  parallel_for(rms.size(), threads, [&](std::size_t s) {
    thread_local std::vector<Neighbor> nb;
    rms[s] = quadric_rms(cloud, tree, s * step, k, nb);
  });
  return upper_median(rms);
}

double robust_extent(const PointCloud& cloud, int threads) {
  const std::size_t n = cloud.size();
  if (n == 0) return 0.0;
  // Percentiles of at most ~100 000 evenly spaced points (enough for 0.5 % tails), along the
  // cloud's principal axes so that the extent does not change when the cloud turns.
  const std::size_t step = sample_step(n, 100000);
  std::vector<Eigen::Vector3d> sample;
  for (std::size_t i = 0; i < n; i += step) sample.push_back(cloud.positions[i]);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : sample) mean += p;
  mean /= static_cast<double>(sample.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : sample) cov.noalias() += (p - mean) * (p - mean).transpose();
  const Eigen::Matrix3d axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors();
  Eigen::Vector3d low, high;
  parallel_tasks(3, threads, [&](std::size_t axis) {  // each axis its own task (and projections)
    std::vector<double> c(sample.size());
    for (std::size_t i = 0; i < sample.size(); ++i) c[i] = axes.col(axis).dot(sample[i] - mean);
    const auto at = [&](double q) {
      const auto k = static_cast<std::ptrdiff_t>(std::floor(q * static_cast<double>(c.size() - 1)));
      std::nth_element(c.begin(), c.begin() + k, c.end());
      return c[static_cast<std::size_t>(k)];
    };
    low(static_cast<Eigen::Index>(axis)) = at(0.005);
    high(static_cast<Eigen::Index>(axis)) = at(0.995);
  });
  return (high - low).norm();
}

CloudScale measure_scale(const PointCloud& cloud, const KdTree& tree, int threads) {
  return {robust_extent(cloud, threads), point_spacing(cloud, tree, 2000, threads),
          surface_noise(cloud, tree, 20, 2000, threads)};
}

void check_finite(const PointCloud& cloud, const std::string& what) {
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!cloud.positions[i].allFinite())
      throw DataError(what, "point " + std::to_string(i) + " has a NaN or Inf coordinate");
  if (cloud.has_normals())
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (!cloud.normals[i].allFinite())
        throw DataError(what, "normal " + std::to_string(i) + " has a NaN or Inf component");
}

void check_registrable(const PointCloud& cloud, const std::string& what) {
  check_finite(cloud, what);
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
