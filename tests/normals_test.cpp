// PCA normals. Oracles: the analytic normal of the sampled surface (plane, sphere, cylinder), the
// documented sign conventions, a neighbourhood that is a line, and bitwise equality across thread
// counts; for NormalCache, the normals estimate_normals gives.
#include "align3d/normals.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "align3d/se3.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::kPi;

Eigen::Vector3d gaussian3(Random& rng) {
  const double x = rng.normal(), y = rng.normal(), z = rng.normal();
  return {x, y, z};
}

using test::line_angle_deg;

double rms(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x * x;
  return v.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(v.size()));
}

double max_of(const std::vector<double>& v) {
  return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}

// A square patch of side 2 in the plane through `centre` with unit normal `n`.
PointCloud sample_plane(const Eigen::Vector3d& centre, const Eigen::Vector3d& n, int count,
                        double sigma, Random& rng) {
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  PointCloud cloud;
  for (int i = 0; i < count; ++i) {
    const double a = rng.uniform(-1, 1), b = rng.uniform(-1, 1), e = rng.normal();
    cloud.positions.push_back(centre + a * u + b * v + sigma * e * n);
  }
  return cloud;
}

// Uniform on the sphere (normalised Gaussian vectors), with radial noise.
PointCloud sample_sphere(const Eigen::Vector3d& centre, double radius, int count, double sigma,
                         Random& rng) {
  PointCloud cloud;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d dir = gaussian3(rng).normalized();
    const double e = rng.normal();
    cloud.positions.push_back(centre + (radius + sigma * e) * dir);
  }
  return cloud;
}

const Eigen::Vector3d kTilted = Eigen::Vector3d(0.3, -0.4, 0.85).normalized();

TEST(Normals, TiltedPlaneNoiseFreeIsExact) {
  Random rng(401);
  PointCloud cloud = sample_plane(Eigen::Vector3d(5, -2, 7), kTilted, 2000, 0.0, rng);
  const NormalResult result = estimate_normals(cloud, NormalSettings{});
  EXPECT_EQ(result.undefined, 0u);
  ASSERT_TRUE(cloud.has_normals());
  for (const auto& n : cloud.normals) {
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    // Default orientation: toward +Z, and kTilted.z() > 0, so n = +kTilted (to rounding).
    EXPECT_LT((n - kTilted).norm(), 1e-9);
  }
}

TEST(Normals, TiltedPlaneWithNoiseWithinAFewDegrees) {
  // Noise σ = 0.002 on a patch with spacing ~0.045: 20 neighbours span a disc of radius ~0.11, so
  // the tilt is about σ / (0.11/2) / √20 ~ 0.5° rms, more at the patch border where the
  // neighbourhood is one-sided (measured: rms 0.72°, max 2.4° of 2000 points).
  Random rng(402);
  PointCloud cloud = sample_plane(Eigen::Vector3d(0, 0, 1), kTilted, 2000, 0.002, rng);
  estimate_normals(cloud, NormalSettings{});
  std::vector<double> errors;
  for (const auto& n : cloud.normals) {
    errors.push_back(line_angle_deg(n, kTilted));
    EXPECT_GE(n.z(), 0.0);
  }
  EXPECT_LT(rms(errors), 1.0);
  EXPECT_LT(max_of(errors), 3.5);
}

TEST(Normals, SphereNormalsAreRadialAndFaceUpByDefault) {
  // Radius 1, 20000 points (spacing ~0.025, neighbourhood radius ~0.06). A PCA normal is the radial
  // direction at the neighbourhood's centroid, which sits off the point by up to ~half the
  // neighbourhood radius (~1.5°); σ = 0.001 adds ~0.5° (measured: rms 0.77°, max 3.2°).
  Random rng(403);
  const Eigen::Vector3d centre(1, 2, -3);
  PointCloud cloud = sample_sphere(centre, 1.0, 20000, 0.001, rng);
  EXPECT_EQ(estimate_normals(cloud, NormalSettings{}).undefined, 0u);
  std::vector<double> errors;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d radial = (cloud.positions[i] - centre).normalized();
    const Eigen::Vector3d& n = cloud.normals[i];
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    errors.push_back(line_angle_deg(n, radial));
    EXPECT_GE(n.z(), 0.0) << "default orientation is toward +Z";
    // Away from the equator the sign is unambiguous: outward on the upper half, inward below.
    if (radial.z() > 0.2) {
      EXPECT_GT(n.dot(radial), 0.99);
    }
    if (radial.z() < -0.2) {
      EXPECT_LT(n.dot(radial), -0.99);
    }
  }
  EXPECT_LT(rms(errors), 1.2);
  EXPECT_LT(max_of(errors), 4.5);
}

TEST(Normals, OrientedTowardTheViewpoint) {
  Random rng(404);
  const Eigen::Vector3d centre(0, 0, 0);
  PointCloud cloud = sample_sphere(centre, 1.0, 3000, 0.0, rng);
  NormalSettings settings;
  settings.viewpoint = centre;  // inside: every normal must point inward
  estimate_normals(cloud, settings);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    EXPECT_LT(cloud.normals[i].dot(cloud.positions[i] - centre), -0.99);

  // A viewpoint below a tilted plane: every normal points down, to the −kTilted side.
  PointCloud plane = sample_plane(Eigen::Vector3d::Zero(), kTilted, 1000, 0.0, rng);
  settings.viewpoint = Eigen::Vector3d(1, 1, -20);
  estimate_normals(plane, settings);
  for (std::size_t i = 0; i < plane.size(); ++i) {
    EXPECT_GE(plane.normals[i].dot(*settings.viewpoint - plane.positions[i]), 0.0);
    EXPECT_LT((plane.normals[i] + kTilted).norm(), 1e-9);
  }
}

TEST(Normals, TurnedTowardAnotherViewpointAsIfEstimatedFromThere) {
  // orient_normals after estimating toward A gives the bits estimating toward B gives (the
  // neighbourhoods all have a plane: a noisy sphere).
  Random rng(405);
  PointCloud from_a = sample_sphere(Eigen::Vector3d(0, 0, 0), 1.0, 3000, 0.01, rng);
  PointCloud from_b = from_a;
  NormalSettings a, b;
  a.viewpoint = Eigen::Vector3d(0, 0, 5);
  b.viewpoint = Eigen::Vector3d(4, -3, 0.5);
  ASSERT_EQ(estimate_normals(from_a, a).undefined, 0u);
  estimate_normals(from_b, b);
  orient_normals(from_a, *b.viewpoint, 2);
  std::size_t turned = 0;
  for (std::size_t i = 0; i < from_a.size(); ++i) {
    EXPECT_EQ(from_a.normals[i], from_b.normals[i]) << i;
    turned += from_a.normals[i].dot(*a.viewpoint - from_a.positions[i]) < 0;
  }
  EXPECT_GT(turned, from_a.size() / 10);  // the two viewpoints disagree on many points
  PointCloud bare;
  bare.positions.push_back(Eigen::Vector3d::Zero());
  EXPECT_THROW(orient_normals(bare, Eigen::Vector3d::Zero()), std::invalid_argument);
}
TEST(Normals, CylinderNormalsAreRadial) {
  // Radius 1, length 6, axis tilted; 20000 points on the side (spacing ~0.04), σ = 0.001. As for
  // the sphere, the centroid offset across the axis biases a normal by up to ~2° (measured:
  // rms 0.78°, max 3.5°).
  Random rng(405);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 0.5, 1).normalized();
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  const Eigen::Vector3d base(-1, 4, 2);
  PointCloud cloud;
  std::vector<Eigen::Vector3d> radial;
  for (int i = 0; i < 20000; ++i) {
    const double phi = rng.uniform(0, 2 * kPi), s = rng.uniform(-3, 3), e = rng.normal();
    const Eigen::Vector3d dir = std::cos(phi) * u + std::sin(phi) * v;
    cloud.positions.push_back(base + s * axis + (1 + 0.001 * e) * dir);
    radial.push_back(dir);
  }
  estimate_normals(cloud, NormalSettings{});
  std::vector<double> errors;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    errors.push_back(line_angle_deg(cloud.normals[i], radial[i]));
    EXPECT_GE(cloud.normals[i].z(), 0.0);
  }
  EXPECT_LT(rms(errors), 1.2);
  EXPECT_LT(max_of(errors), 5.0);
}

TEST(Normals, CollinearNeighbourhoodsAreUndefined) {
  // A plane patch and, far from it, a line of 40 points along an oblique direction: with k = 10
  // every line point's neighbourhood is on the line and has no normal; plane points are fine.
  Random rng(406);
  PointCloud cloud = sample_plane(Eigen::Vector3d::Zero(), kTilted, 500, 0.0, rng);
  const std::size_t plane_points = cloud.size();
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 2, 3).normalized();
  for (int i = 0; i < 40; ++i)
    cloud.positions.push_back(Eigen::Vector3d(50, 50, 50) + 0.1 * i * dir);
  NormalSettings settings;
  settings.k = 10;
  const NormalResult result = estimate_normals(cloud, settings);
  EXPECT_EQ(result.undefined, 40u);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (i < plane_points) {
      EXPECT_LT((cloud.normals[i] - kTilted).norm(), 1e-9);
    } else {
      EXPECT_EQ(cloud.normals[i], Eigen::Vector3d::UnitZ()) << "undefined normals are +Z";
    }
  }
  // With a viewpoint, an undefined normal is the unit direction toward it.
  settings.viewpoint = Eigen::Vector3d(50, 50, 0);
  EXPECT_EQ(estimate_normals(cloud, settings).undefined, 40u);
  for (std::size_t i = plane_points; i < cloud.size(); ++i) {
    const Eigen::Vector3d toward = (*settings.viewpoint - cloud.positions[i]).normalized();
    EXPECT_LT((cloud.normals[i] - toward).norm(), 1e-12);
  }
}

TEST(Normals, AxisAlignedLineAndCoincidentPointsAreUndefined) {
  PointCloud line;
  for (int i = 0; i < 30; ++i) line.positions.emplace_back(0.25 * i, 0, 0);
  EXPECT_EQ(estimate_normals(line, NormalSettings{}).undefined, 30u);
  PointCloud spot;
  spot.positions.assign(12, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_EQ(estimate_normals(spot, NormalSettings{}).undefined, 12u);
  for (const auto& n : spot.normals) EXPECT_EQ(n, Eigen::Vector3d::UnitZ());
}

TEST(Normals, KIsClampedToTheCloudSize) {
  // Three points, k = 20: each neighbourhood is the whole triangle, whose normal is exact.
  PointCloud cloud;
  cloud.positions = {{0, 0, 1}, {1, 0, 2}, {0, 1, 3}};
  const Eigen::Vector3d want =
      Eigen::Vector3d(1, 0, 1).cross(Eigen::Vector3d(0, 1, 2)).normalized();
  ASSERT_GT(want.z(), 0);
  EXPECT_EQ(estimate_normals(cloud, NormalSettings{}).undefined, 0u);
  for (const auto& n : cloud.normals) EXPECT_LT((n - want).norm(), 1e-12);
}

TEST(Normals, RejectsKBelowThree) {
  PointCloud cloud;
  cloud.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  NormalSettings settings;
  settings.k = 2;
  EXPECT_THROW(estimate_normals(cloud, settings), std::invalid_argument);
}

TEST(Normals, EmptyCloudGetsNoNormals) {
  PointCloud cloud;
  EXPECT_EQ(estimate_normals(cloud, NormalSettings{}).undefined, 0u);
  EXPECT_TRUE(cloud.normals.empty());
}

TEST(Normals, SameBitsWithOneAndTwoThreads) {
  Random rng(407);
  PointCloud one = sample_sphere(Eigen::Vector3d(0.5, 0, 0), 2.0, 4000, 0.01, rng);
  PointCloud two = one;
  NormalSettings settings;
  settings.threads = 1;
  const NormalResult r1 = estimate_normals(one, settings);
  settings.threads = 2;
  const NormalResult r2 = estimate_normals(two, settings);
  EXPECT_EQ(r1.undefined, r2.undefined);
  ASSERT_EQ(one.normals.size(), two.normals.size());
  std::size_t differing = 0;
  for (std::size_t i = 0; i < one.normals.size(); ++i)
    differing += !(one.normals[i].array() == two.normals[i].array()).all();
  EXPECT_EQ(differing, 0u);
}

TEST(NormalCache, EstimatesOnlyWhatIsRequiredWithTheSameBits) {
  // Oracle: estimate_normals on the whole cloud. The cache estimates exactly the required points
  // (repeats counted once), each to the same bits, and counts the undefined ones among them.
  Random rng(408);
  PointCloud cloud = sample_plane(Eigen::Vector3d::Zero(), kTilted, 500, 0.01, rng);
  const Eigen::Vector3d dir = Eigen::Vector3d(1, 2, 3).normalized();
  for (int i = 0; i < 40; ++i)  // a line: no normal with k = 10
    cloud.positions.push_back(Eigen::Vector3d(50, 50, 50) + 0.1 * i * dir);
  NormalSettings settings;
  settings.k = 10;
  PointCloud whole = cloud;
  estimate_normals(whole, settings);

  const KdTree tree(cloud.positions);
  NormalCache cache(cloud, tree, settings);
  EXPECT_EQ(cache.estimated(), 0u);
  const std::vector<std::uint32_t> first = {7, 3, 7, 510, 499, 3};
  cache.require(first);
  EXPECT_EQ(cache.estimated(), 4u);
  EXPECT_EQ(cache.undefined(), 1u);  // 510 is on the line
  cache.require({3, 520, 2});
  EXPECT_EQ(cache.estimated(), 6u);
  EXPECT_EQ(cache.undefined(), 2u);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const bool wanted = i == 2 || i == 3 || i == 7 || i == 499 || i == 510 || i == 520;
    EXPECT_EQ(cache.known(i), wanted) << i;
    if (wanted) {
      EXPECT_TRUE((cache.normals()[i].array() == whole.normals[i].array()).all()) << i;
    }
  }
  EXPECT_TRUE(cloud.normals.empty()) << "the cloud itself is not changed";
  EXPECT_THROW(cache.require({540}), std::out_of_range);
  settings.k = 2;
  EXPECT_THROW(NormalCache(cloud, tree, settings), std::invalid_argument);
  const KdTree other(std::vector<Eigen::Vector3d>(10, Eigen::Vector3d::Zero()));
  EXPECT_THROW(NormalCache(cloud, other, NormalSettings{}), std::invalid_argument);
}

}  // namespace
}  // namespace align3d
