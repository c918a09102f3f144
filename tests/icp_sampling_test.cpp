// icp/sampling.hpp: geometrically stable sampling by leverage, against a turned part whose only
// hold on the turn about its axis is known by construction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "align3d/icp/sampling.hpp"
#include "align3d/se3.hpp"

namespace align3d {
namespace {

// A cylinder's side (radius 40, 50 high, axis z, normals outward; 360 × 50 points) with one lug on
// it at +x: a box from x = 40 to 50, |y| ≤ 4, 10 ≤ z ≤ 40, whose two side faces (normals ±y) are
// the only surfaces that hold the turn about z. Their points come last: indices ≥ first_side.
struct LuggedCylinder {
  PointCloud cloud;
  std::size_t first_side = 0;
};
LuggedCylinder lugged_cylinder() {
  LuggedCylinder out;
  PointCloud& c = out.cloud;
  for (int a = 0; a < 360; ++a)
    for (int k = 0; k < 50; ++k) {
      const double t = deg_to_rad(a + 0.5);
      if (std::abs(40 * std::sin(t)) <= 4 && std::cos(t) > 0 && k >= 10 && k <= 40) continue;
      c.positions.emplace_back(40 * std::cos(t), 40 * std::sin(t), k + 0.5);
      c.normals.emplace_back(std::cos(t), std::sin(t), 0);
    }
  for (int i = 0; i < 10; ++i)  // the lug's outer face, x = 50
    for (int k = 0; k < 30; ++k) {
      c.positions.emplace_back(50, -4 + 0.8 * (i + 0.5), 10 + k + 0.5);
      c.normals.emplace_back(1, 0, 0);
    }
  out.first_side = c.size();
  for (const double side : {-4.0, 4.0})
    for (int i = 0; i < 10; ++i)
      for (int k = 0; k < 30; ++k) {
        c.positions.emplace_back(40 + i + 0.5, side, 10 + k + 0.5);
        c.normals.emplace_back(0, side > 0 ? 1 : -1, 0);
      }
  return out;
}

// The information about the turn about z that `indices` hold: Σ (((p − c) × n)_z)², c the whole
// cloud's centroid.
double turn_information(const PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  const Eigen::Vector3d c = centroid(cloud);
  double sum = 0;
  for (std::uint32_t i : indices) {
    const double j = (cloud.positions[i] - c).cross(cloud.normals[i]).z();
    sum += j * j;
  }
  return sum;
}

TEST(StableSample, KeepsEveryPointThatHoldsTheWeakDirection) {
  const LuggedCylinder part = lugged_cylinder();
  const std::size_t n = part.cloud.size();
  const std::vector<std::uint32_t> s = stable_sample(part.cloud, 0.5, 0.25);
  ASSERT_TRUE(std::is_sorted(s.begin(), s.end()));
  EXPECT_EQ(std::set<std::uint32_t>(s.begin(), s.end()).size(), s.size());
  EXPECT_NEAR(static_cast<double>(s.size()), 0.5 * static_cast<double>(n), 2.0);
  for (std::size_t i = part.first_side; i < n; ++i)
    EXPECT_TRUE(std::binary_search(s.begin(), s.end(), static_cast<std::uint32_t>(i))) << i;
  std::vector<std::uint32_t> all(n), every_second;
  for (std::uint32_t i = 0; i < n; ++i) all[i] = i;
  for (std::uint32_t i = 0; i < n; i += 2) every_second.push_back(i);
  const double full = turn_information(part.cloud, all);
  // Half the points, nearly all the hold on the turn; an every-2nd sample keeps about half of it.
  EXPECT_GT(turn_information(part.cloud, s), 0.99 * full);
  EXPECT_NEAR(turn_information(part.cloud, every_second) / full, 0.5, 0.05);
}

TEST(StableSample, SharesAndDegenerateClouds) {
  const LuggedCylinder part = lugged_cylinder();
  const std::size_t n = part.cloud.size();
  EXPECT_EQ(stable_sample(part.cloud, 1, 0.25).size(), n);
  EXPECT_EQ(stable_sample(part.cloud, 0, 0).size(), 0u);
  EXPECT_NEAR(static_cast<double>(stable_sample(part.cloud, 0.1, 0.3).size()),
              0.3 * static_cast<double>(n), 1.0);  // share below top: the top ones
  EXPECT_EQ(stable_sample(PointCloud{}, 0.5, 0.25).size(), 0u);
  // A plane leaves three directions free (H singular): still the share asked for.
  PointCloud plane;
  for (int i = 0; i < 40; ++i)
    for (int k = 0; k < 40; ++k) {
      plane.positions.emplace_back(i, k, 0);
      plane.normals.emplace_back(0, 0, 1);
    }
  EXPECT_NEAR(static_cast<double>(stable_sample(plane, 0.5, 0.25).size()), 800.0, 2.0);
  PointCloud no_normals;
  no_normals.positions = part.cloud.positions;
  EXPECT_THROW(stable_sample(no_normals, 0.5, 0.25), std::invalid_argument);
  EXPECT_THROW(stable_sample(part.cloud, 1.5, 0.25), std::invalid_argument);
  EXPECT_THROW(stable_sample(part.cloud, 0.5, std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace align3d
