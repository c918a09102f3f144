// FPFH descriptors. Oracles: a hand-computed pair (θ = π/4, α = 0, φ = −1/√2), a flat patch
// (every pair feature vanishes), invariance under rigid motions up to 180° when the normals are
// estimated afresh on the moved cloud and oriented by orient_normals_consistently, and bitwise
// equality across thread counts.
#include "align3d/coarse/fpfh.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>
#include <vector>

#include "align3d/coarse/global.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "align3d/voxel.hpp"
#include "detail/fast_angle.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

// The pipeline's descriptor stage: PCA normals, local orientation, FPFH with radius 5 voxels.
std::vector<FpfhDescriptor> describe(PointCloud cloud, double voxel, int threads = 1) {
  const KdTree tree(cloud.positions);
  NormalSettings ns;
  ns.threads = threads;
  estimate_normals(cloud, tree, ns);
  orient_normals_consistently(cloud, tree, 5 * voxel, threads);
  FpfhSettings fs;
  fs.radius = 5 * voxel;
  fs.threads = threads;
  return compute_fpfh(cloud, tree, fs);
}

TEST(Fpfh, TwoPointsGiveTheHandComputedBins) {
  // d = (1, 0, 0); n2 is closer to the line, so u = n2, v = (0, 1, 0), w = (−1, 0, 1)/√2:
  // θ = atan2(w·n1, u·n1) = π/4 -> bin 6; α = v·n1 = 0 -> bin 5; φ = −u·d = −1/√2 -> bin 1.
  PointCloud cloud;
  cloud.positions = {{0, 0, 0}, {1, 0, 0}};
  cloud.normals = {{0, 0, 1}, Eigen::Vector3d(1, 0, 1).normalized()};
  const KdTree tree(cloud.positions);
  const auto f = compute_fpfh(cloud, tree, {2.0});
  ASSERT_EQ(f.size(), 2u);
  FpfhDescriptor expected = FpfhDescriptor::Zero();
  expected(6) = expected(11 + 5) = expected(22 + 1) = 200;  // SPFH 100 + neighbour sum 100
  for (const auto& d : f) EXPECT_EQ(d, expected);
}

TEST(Fpfh, FlatPatchHasAllWeightInTheMiddleBins) {
  PointCloud cloud;
  for (int x = 0; x < 20; ++x)
    for (int y = 0; y < 20; ++y) cloud.positions.emplace_back(x, y, 0);
  cloud.normals.assign(cloud.size(), Eigen::Vector3d::UnitZ());
  const KdTree tree(cloud.positions);
  const auto f = compute_fpfh(cloud, tree, {3.0});
  FpfhDescriptor expected = FpfhDescriptor::Zero();
  expected(5) = expected(16) = expected(27) = 200;
  for (const auto& d : f) EXPECT_LT((d - expected).cwiseAbs().maxCoeff(), 1e-3);
}

TEST(Fpfh, IsolatedPointGetsZeroDescriptorAndBlocksSumTo200) {
  auto scene = synth::make_conveyor_scene();
  PointCloud cloud = voxel_downsample(scene.model, 7.0);
  cloud.positions.emplace_back(1000, 1000, 1000);  // far from everything
  const auto f = describe(cloud, 7.0);
  EXPECT_EQ(f.back(), FpfhDescriptor::Zero());
  for (std::size_t i = 0; i + 1 < f.size(); ++i)
    for (int block = 0; block < 3; ++block)
      EXPECT_NEAR(f[i].segment<11>(11 * block).sum(), 200.0f, 1e-3f) << "point " << i;
}

// Share of points whose descriptors agree (L1 difference below 1 of their total 600) between
// `a` and `b`, and the worst L1 difference.
std::pair<double, double> agreement(const std::vector<FpfhDescriptor>& a,
                                    const std::vector<FpfhDescriptor>& b) {
  std::size_t equal = 0;
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double l1 = (a[i] - b[i]).cwiseAbs().sum();
    equal += l1 < 1.0;
    worst = std::max(worst, l1);
  }
  return {static_cast<double>(equal) / static_cast<double>(a.size()), worst};
}

// The descriptor itself: the same points and normals moved rigidly give the same histograms, up to
// a pair feature that lands on the other side of a bin edge after round-off.
TEST(Fpfh, InvariantUnderRigidMotionsUpTo180Degrees) {
  synth::ObjectSettings os;
  os.shape = "bracket";
  const auto scene = synth::make_object_scene(os);
  const double voxel = global_voxel(scene.model, scene.model, {});
  PointCloud cloud = voxel_downsample(scene.model, voxel);
  const KdTree tree(cloud.positions);
  estimate_normals(cloud, tree);
  orient_normals_consistently(cloud, tree, 5 * voxel);
  const auto a = compute_fpfh(cloud, tree, {5 * voxel});
  Random rng(11);
  for (double angle : {30.0, 90.0, 150.0, 180.0}) {
    const Eigen::Vector3d axis(rng.normal(), rng.normal(), rng.normal());
    const PointCloud moved = transformed(cloud, rigid_transform(angle, axis, {40, -25, 60}));
    const KdTree moved_tree(moved.positions);
    const auto [share, worst] = agreement(a, compute_fpfh(moved, moved_tree, {5 * voxel}));
    EXPECT_GE(share, 0.995) << angle << " deg; worst L1 difference " << worst;
  }
}

// The whole descriptor stage, normals estimated and oriented afresh on the moved cloud: the
// orientation commutes with the motion except for flat stretches between seeds of opposite sign,
// where the meeting line depends on round-off (documented in fpfh.hpp).
TEST(Fpfh, DescriptorStageInvariantOnTheChapterScan) {
  const auto scene = synth::make_conveyor_scene();
  const double voxel = global_voxel(scene.model, scene.model, {});
  const PointCloud cloud = voxel_downsample(scene.scan, voxel);
  const auto a = describe(cloud, voxel);
  for (double angle : {90.0, 180.0}) {
    const auto b =
        describe(transformed(cloud, rigid_transform(angle, {1, -2, 0.5}, {100, 50, -30})), voxel);
    const auto [share, worst] = agreement(a, b);
    EXPECT_GE(share, 0.97) << angle << " deg; worst L1 difference " << worst;
  }
}

TEST(Fpfh, SameBitsWhateverTheThreadCount) {
  const auto scene = synth::make_conveyor_scene();
  const PointCloud cloud = voxel_downsample(scene.scan, 7.0);
  const auto one = describe(cloud, 7.0, 1);
  const auto two = describe(cloud, 7.0, 2);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) ASSERT_EQ(one[i], two[i]) << "point " << i;
}

// θ's atan2 against libm's around the circle, at several lengths and at the axes: within its
// published 2e-8 bound (Abramowitz & Stegun 4.4.49) and so within the 1e-7 rad margin inside which
// compute_fpfh asks libm for the bin.
TEST(Fpfh, FastAtan2AgreesWithLibmWithinTheBound) {
  double worst = 0;
  for (const double r : {1e-9, 0.3, 1.0, 7.0})
    for (int i = -300000; i <= 300000; ++i) {
      const double a = i * std::numbers::pi / 300000;
      const double y = r * std::sin(a), x = r * std::cos(a);
      worst = std::max(worst, std::abs(detail::fast_atan2(y, x) - std::atan2(y, x)));
    }
  EXPECT_LT(worst, 2.5e-8);
  EXPECT_EQ(detail::fast_atan2(0.0, 1.0), 0.0);
  EXPECT_NEAR(detail::fast_atan2(1.0, 0.0), std::numbers::pi / 2, 1e-15);
  EXPECT_NEAR(detail::fast_atan2(0.0, -1.0), std::numbers::pi, 1e-15);
  EXPECT_NEAR(detail::fast_atan2(-1.0, -1.0), -0.75 * std::numbers::pi, 2.5e-8);
}

TEST(Fpfh, RejectsMissingNormalsAndBadRadius) {
  PointCloud cloud;
  cloud.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const KdTree tree(cloud.positions);
  EXPECT_THROW(compute_fpfh(cloud, tree, {1.0}), std::invalid_argument);
  cloud.normals.assign(3, Eigen::Vector3d::UnitZ());
  EXPECT_THROW(compute_fpfh(cloud, tree, {0.0}), std::invalid_argument);
}

}  // namespace
}  // namespace align3d
