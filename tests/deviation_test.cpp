// Deviation statistics and maps (deviation.hpp) against independent oracles: percentiles from a
// full sort (numpy's linear interpolation, type 7), moments by their definition, a Gauss fit on
// Gaussian samples, histogram counts by hand, and signed distances to a box in closed form.
#include "align3d/deviation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "detail/random.hpp"
#include "mesh_test_util.hpp"

namespace align3d {
namespace {

double type7(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const double h = p * static_cast<double>(v.size() - 1);
  const auto k = static_cast<std::size_t>(std::floor(h));
  return k + 1 < v.size() ? v[k] + (h - k) * (v[k + 1] - v[k]) : v[k];
}

TEST(Deviation, StatsMatchTheirDefinitionsAndLeaveOutliersOut) {
  Random rng(3);
  std::vector<double> d(10001);
  for (double& x : d) x = 0.05 * rng.normal() + 0.01 + (rng.uniform() < 0.02 ? -0.4 : 0.0);
  std::vector<double> with_nan = d;
  with_nan.insert(with_nan.begin() + 17, std::nan(""));
  with_nan.push_back(std::nan(""));
  const DeviationStats s = deviation_stats(with_nan);
  EXPECT_EQ(s.count, d.size());
  double sum = 0, sq = 0;
  for (double x : d) sum += x, sq += x * x;
  const double mean = sum / d.size();
  double var = 0;
  for (double x : d) var += (x - mean) * (x - mean);
  EXPECT_NEAR(s.mean, mean, 1e-15);
  EXPECT_NEAR(s.rms, std::sqrt(sq / d.size()), 1e-15);
  EXPECT_NEAR(s.std, std::sqrt(var / d.size()), 1e-15);
  EXPECT_EQ(s.min, *std::min_element(d.begin(), d.end()));
  EXPECT_EQ(s.max, *std::max_element(d.begin(), d.end()));
  EXPECT_DOUBLE_EQ(s.p01, type7(d, 0.01));
  EXPECT_DOUBLE_EQ(s.p05, type7(d, 0.05));
  EXPECT_DOUBLE_EQ(s.p50, type7(d, 0.50));
  EXPECT_DOUBLE_EQ(s.p95, type7(d, 0.95));
  EXPECT_DOUBLE_EQ(s.p99, type7(d, 0.99));
  EXPECT_EQ(deviation_stats({std::nan("")}).count, 0u);
  const DeviationStats two = deviation_stats({1.0, 3.0});  // type 7 by hand: 1 + 0.01·2
  EXPECT_DOUBLE_EQ(two.p01, 1.02);
  EXPECT_DOUBLE_EQ(two.p50, 2.0);
}

TEST(Deviation, GaussFitIgnoresAFewDefects) {
  Random rng(4);
  std::vector<double> d(200000);
  for (double& x : d) x = 0.02 + 0.01 * rng.normal();
  for (std::size_t i = 0; i < d.size(); i += 40) d[i] = -0.3;  // 2.5 % on a dent
  const GaussFit g = gauss_fit(d);
  EXPECT_NEAR(g.mean, 0.02, 0.0005);
  EXPECT_NEAR(g.sigma, 0.01, 0.0006);
  EXPECT_GT(deviation_stats(d).std, 0.04);  // what least squares would have said
}

TEST(Deviation, HistogramCountsEveryFiniteValueOnce) {
  const std::vector<double> d = {-1.0, -0.5, -0.25, 0.0, 0.1, 0.49, 0.5, 2.0, std::nan("")};
  const Histogram h = histogram(d, -0.5, 0.5, 4);  // bins [-.5,-.25) [-.25,0) [0,.25) [.25,.5)
  ASSERT_EQ(h.counts.size(), 4u);
  EXPECT_EQ(h.counts, (std::vector<std::size_t>{1, 1, 2, 1}));
  EXPECT_EQ(h.below, 1u);
  EXPECT_EQ(h.above, 2u);
  EXPECT_DOUBLE_EQ(h.width(), 0.25);
}

// A 10 × 6 × 4 box: the signed distance of a point is known in closed form (outside: the distance
// to the box; inside: minus the distance to the nearest face).
double box_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d outside = (p - hi).cwiseMax(-p).cwiseMax(0.0);
  if (outside.squaredNorm() > 0) return outside.norm();
  return -std::min({p.x(), p.y(), p.z(), hi.x() - p.x(), hi.y() - p.y(), hi.z() - p.z()});
}

TEST(Deviation, MapGivesSignedDistancesInInputOrderWhateverTheThreads) {
  const Eigen::Vector3d hi(10, 6, 4);
  const MeshIndex box(test::box_mesh({0, 0, 0}, hi));
  Random rng(5);
  std::vector<Eigen::Vector3d> pts(20000);
  for (auto& p : pts) p = {rng.uniform(-2, 12), rng.uniform(-2, 8), rng.uniform(-2, 6)};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.5, -0.25, 0.125);
  const double max_distance = 1.0;
  const DeviationMap one = measure_deviations(pts, box, T, max_distance, 1);
  const DeviationMap two = measure_deviations(pts, box, T, max_distance, 2);
  std::size_t outliers = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3d q = T * pts[i];
    const double truth = box_distance(q, hi);
    if (std::abs(truth) > max_distance) {
      ++outliers;
      EXPECT_TRUE(std::isnan(one.deviation[i])) << i;
      EXPECT_EQ(one.triangle[i], kNoTriangle);
    } else {
      EXPECT_NEAR(one.deviation[i], truth, 1e-12) << q.transpose();
      EXPECT_NEAR((one.closest[i] - q).norm(), std::abs(truth), 1e-12);
    }
    EXPECT_EQ(std::isnan(one.deviation[i]), std::isnan(two.deviation[i]));
    if (!std::isnan(one.deviation[i])) {
      EXPECT_EQ(one.deviation[i], two.deviation[i]);
    }
  }
  EXPECT_EQ(one.outliers, outliers);
  EXPECT_GT(outliers, 1000u);
  EXPECT_EQ(one.max_distance, max_distance);
}

}  // namespace
}  // namespace align3d
