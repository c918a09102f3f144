// The simulated depth camera (synth/camera.hpp). Oracles: pixels of known planes by trigonometry,
// the shadow band of a box in front of a wall by similar triangles, the noise's stated σ(z), the
// dropout probability.
#include <gtest/gtest.h>

#include <cmath>

#include "align3d/se3.hpp"
#include "align3d/synth/camera.hpp"
#include "test_util.hpp"

namespace align3d::synth {
namespace {

DepthSensorSettings ideal_sensor() {
  DepthSensorSettings s;
  s.min_depth = 0;
  s.noise_a = s.noise_b = 0;
  s.dropout = 0;
  s.hole_clusters = 0;
  s.projector_offset.setZero();
  return s;
}

PinholeCamera centred_camera() {  // principal point on a pixel centre, for exact central rays
  PinholeCamera c;
  c.cx = 320;
  c.cy = 240;
  return c;
}

using test::same_bits;

// A camera `height` above the floor z = 0, looking down (image up = world +y), then tilted by θ
// about world x, which is the camera's x.
Eigen::Isometry3d tilted_down(double height, double theta_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d down;
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  T.linear() = rigid_transform(theta_deg, Eigen::Vector3d::UnitX()).linear() * down;
  T.translation() = Eigen::Vector3d(0, 0, height);
  return T;
}

// Depth of pixel row v on the floor seen by tilted_down(h, θ): the ray leaves the optical axis by
// α = atan((v − cy)/fy) in the y–z plane, so it leaves the vertical by θ − α and meets the floor at
// distance h / cos(θ − α), whose component along the optical axis is that times cos α.
double floor_depth(const PinholeCamera& c, double h, double theta_deg, int v) {
  const double alpha = std::atan((v - c.cy) / c.fy);
  return h * std::cos(alpha) / std::cos(deg_to_rad(theta_deg) - alpha);
}

TEST(DepthCamera, PixelOfAFrontoParallelPlaneLandsOnItsRay) {
  const PinholeCamera camera;
  const OrganizedCloud cloud = render(camera, {Plane{{0, 0, -1}, {0, 0, 1000}}}, ideal_sensor(), 1);
  ASSERT_EQ(cloud.width, 640);
  ASSERT_EQ(cloud.height, 480);
  ASSERT_EQ(cloud.positions.size(), 640u * 480u);
  EXPECT_EQ(cloud.valid_count(), 640u * 480u);
  for (const auto& [u, v] : {std::pair{0, 0}, {320, 240}, {639, 479}, {100, 400}}) {
    const Eigen::Vector3d expected((u - 319.5) / 525 * 1000, (v - 239.5) / 525 * 1000, 1000);
    EXPECT_LT((cloud.at(u, v) - expected).norm(), 1e-9) << u << "," << v;
    EXPECT_EQ(cloud.shape[static_cast<std::size_t>(v) * 640 + u], 0);
  }
}

TEST(DepthCamera, TiltedFloorMatchesTheTrigonometricDepth) {
  PinholeCamera camera = centred_camera();
  camera.T_world_camera = tilted_down(900, 8);
  const OrganizedCloud cloud = render(camera, {Plane{{0, 0, 1}, {0, 0, 0}}}, ideal_sensor(), 1);
  for (int v : {0, 100, 240, 333, 479})
    for (int u : {0, 320, 639}) {
      const double z = floor_depth(camera, 900, 8, v);
      const Eigen::Vector3d expected(z * (u - 320) / 525, z * (v - 240) / 525, z);
      EXPECT_LT((cloud.at(u, v) - expected).norm(), 1e-9) << u << "," << v;
    }
}

TEST(DepthCamera, RangeLimitsApplyToTheDepth) {
  PinholeCamera camera = centred_camera();
  camera.T_world_camera = tilted_down(900, 20);  // depths from ~790 to ~1100 mm
  DepthSensorSettings s = ideal_sensor();
  s.min_depth = 850;
  s.max_depth = 1000;
  const OrganizedCloud cloud = render(camera, {Plane{{0, 0, 1}, {0, 0, 0}}}, s, 1);
  int near = 0, far = 0;
  for (int v = 0; v < 480; ++v) {
    const double z = floor_depth(camera, 900, 20, v);
    if (std::abs(z - s.min_depth) < 1e-6 || std::abs(z - s.max_depth) < 1e-6) continue;
    const bool expected = z >= s.min_depth && z < s.max_depth;
    near += z < s.min_depth;
    far += z >= s.max_depth;
    for (int u : {0, 320, 639}) EXPECT_EQ(cloud.at(u, v).allFinite(), expected) << v;
  }
  EXPECT_GT(near, 0);  // both limits cut the image
  EXPECT_GT(far, 0);
}

TEST(DepthCamera, GrazingRaysReturnNothing) {
  PinholeCamera camera = centred_camera();
  camera.T_world_camera = tilted_down(900, 60);  // incidence from ~35° to ~85° down the image
  DepthSensorSettings s = ideal_sensor();
  s.max_depth = 1e9;
  const OrganizedCloud cloud = render(camera, {Plane{{0, 0, 1}, {0, 0, 0}}}, s, 1);
  int grazing = 0, seen = 0;
  for (int v = 0; v < 480; v += 7)
    for (int u = 0; u < 640; u += 13) {
      // The incidence angle is the ray's angle from the floor's normal (vertical).
      const Eigen::Vector3d d = camera.T_world_camera.linear() * camera.pixel_direction(u, v);
      const double incidence = rad_to_deg(std::acos(std::abs(d.z()) / d.norm()));
      if (std::abs(incidence - s.max_incidence_deg) < 1e-6) continue;
      const bool expected = incidence < s.max_incidence_deg;
      (expected ? seen : grazing)++;
      EXPECT_EQ(cloud.at(u, v).allFinite(), expected) << u << "," << v;
    }
  EXPECT_GT(grazing, 100);
  EXPECT_GT(seen, 100);
}

// A 100 × 100 × 20 box centred 500 mm in front of a wall at 1000 mm; the projector 75 mm right of
// the camera (+x). Along the centre row (y = 0) the wall point x_w is lit when the segment from it
// to the projector, x(z) = 75 + (x_w − 75)·z/1000, misses the box (|x| > 50 for z in [490, 510]);
// the camera sees the wall where x_w·490/1000 falls outside [−50, 50]. The visible-but-unlit band
// lies on the side away from the projector: x_w from 75 − 125/0.49 ≈ −180 to −50/0.49 ≈ −102.
TEST(DepthCamera, ProjectorShadowMatchesSimilarTriangles) {
  const PinholeCamera camera = centred_camera();
  DepthSensorSettings s = ideal_sensor();
  s.projector_offset = {75, 0, 0};
  const std::vector<Shape> shapes = {
      Plane{{0, 0, -1}, {0, 0, 1000}},
      Box{rigid_transform(0, Eigen::Vector3d::UnitZ(), {0, 0, 500}), {50, 50, 10}}};
  const OrganizedCloud cloud = render(camera, shapes, s, 1);
  int shadowed = 0;
  for (int u = 0; u < 640; ++u) {
    const double x_wall = (u - 320) / 525.0 * 1000;
    const double x_near = 75 + (x_wall - 75) * 0.49, x_far = 75 + (x_wall - 75) * 0.51;
    const bool occluded = std::abs(x_wall * 0.49) <= 50;
    if (occluded) {
      EXPECT_EQ(cloud.shape[240 * 640 + static_cast<std::size_t>(u)], 1) << u;  // the box, lit
      continue;
    }
    const bool unlit = std::min(x_near, x_far) <= 50 && std::max(x_near, x_far) >= -50;
    shadowed += unlit;
    EXPECT_EQ(cloud.at(u, 240).allFinite(), !unlit) << u << " x_wall " << x_wall;
  }
  // (180.1 − 102.0) mm at 1000 mm and 525 px/m: 41 pixels.
  EXPECT_NEAR(shadowed, (180.1 - 102.0) * 0.525, 1.5);
}

TEST(DepthCamera, NoiseIsAlongTheRayWithTheStatedSigma) {
  PinholeCamera camera = centred_camera();
  camera.T_world_camera = tilted_down(900, 30);  // depths ~800..1300 mm
  const std::vector<Shape> floor = {Plane{{0, 0, 1}, {0, 0, 0}}};
  DepthSensorSettings noisy = ideal_sensor();
  noisy.noise_a = 0.5;
  noisy.noise_b = 1.425e-6;
  const OrganizedCloud exact = render(camera, floor, ideal_sensor(), 7);
  const OrganizedCloud cloud = render(camera, floor, noisy, 7);
  // In the near and the far half, the standardised depth error has mean 0 and deviation 1; a wrong
  // σ(z) law would show in at least one half.
  double sum[2] = {0, 0}, sq_sum[2] = {0, 0};
  double n[2] = {0, 0};
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const Eigen::Vector3d &p = cloud.at(u, v), &q = exact.at(u, v);
      ASSERT_EQ(p.allFinite(), q.allFinite());
      if (!p.allFinite()) continue;
      ASSERT_LT((camera.project(p) - Eigen::Vector2d(u, v)).norm(), 1e-6);  // on the pixel's ray
      const double e = (p.z() - q.z()) / noisy.sigma(q.z());
      const int half = q.z() < 1050;
      sum[half] += e;
      sq_sum[half] += e * e;
      n[half] += 1;
    }
  for (int h = 0; h < 2; ++h) {
    ASSERT_GT(n[h], 50000);
    const double mean = sum[h] / n[h], sd = std::sqrt(sq_sum[h] / n[h] - mean * mean);
    EXPECT_LT(std::abs(mean), 5 / std::sqrt(n[h])) << h;
    EXPECT_NEAR(sd, 1.0, 5 / std::sqrt(2 * n[h])) << h;  // the sd's standard error is 1/√(2n)
  }
}

TEST(DepthCamera, DropoutAndHoleClusters) {
  const PinholeCamera camera;
  const std::vector<Shape> wall = {Plane{{0, 0, -1}, {0, 0, 1000}}};
  DepthSensorSettings s = ideal_sensor();
  s.dropout = 0.1;
  const double pixels = 640 * 480;
  const double lost = pixels - static_cast<double>(render(camera, wall, s, 3).valid_count());
  EXPECT_NEAR(lost / pixels, 0.1, 4 * std::sqrt(0.1 * 0.9 / pixels));
  s.dropout = 0;
  s.hole_clusters = 20;
  s.hole_radius_max = 6;
  const OrganizedCloud holes = render(camera, wall, s, 3);
  const double missing = pixels - static_cast<double>(holes.valid_count());
  EXPECT_GE(missing, 20);                              // at least one pixel per disk...
  EXPECT_LE(missing, 20 * (2 * 6 + 1) * (2 * 6 + 1));  // ...at most its bounding square
  // Missing pixels come in clusters: most have a missing neighbour.
  int isolated = 0;
  for (int v = 1; v < 479; ++v)
    for (int u = 1; u < 639; ++u)
      if (!holes.at(u, v).allFinite())
        isolated += holes.at(u - 1, v).allFinite() && holes.at(u + 1, v).allFinite() &&
                    holes.at(u, v - 1).allFinite() && holes.at(u, v + 1).allFinite();
  EXPECT_LT(isolated, 0.05 * missing);
}

TEST(DepthCamera, SameSeedSameBits) {
  PinholeCamera camera;
  camera.T_world_camera = tilted_down(900, 10);
  const std::vector<Shape> shapes = {
      Plane{{0, 0, 1}, {0, 0, 0}}, Sphere{{30, 20, 60}, 60},
      Box{rigid_transform(30, Eigen::Vector3d::UnitZ(), {-150, 0, 40}), {60, 40, 40}}};
  const DepthSensorSettings s;
  const OrganizedCloud a = render(camera, shapes, s, 5), b = render(camera, shapes, s, 5);
  EXPECT_TRUE(same_bits(a, b));
  DepthSensorSettings one_thread = s;
  one_thread.threads = 1;
  EXPECT_TRUE(same_bits(a, render(camera, shapes, one_thread, 5)));
  EXPECT_FALSE(same_bits(a, render(camera, shapes, s, 6)));
  // Every valid point lies on the shape it is labelled with, to within the noise.
  for (std::size_t i = 0; i < a.positions.size(); ++i) {
    if (a.shape[i] < 0) {
      ASSERT_FALSE(a.positions[i].allFinite());
      continue;
    }
    const Eigen::Vector3d world = camera.T_world_camera * a.positions[i];
    ASSERT_LT(surface_distance(shapes[static_cast<std::size_t>(a.shape[i])], world),
              6 * s.sigma(a.positions[i].z()));
  }
}

TEST(DepthCamera, LookAtBuildsTheDepthCameraConvention) {
  // From (0, −1000, 0) towards the origin with up = +z: forward +y, right +x, down −z.
  const Eigen::Isometry3d T = look_at({0, -1000, 0}, {0, 0, 0}, {0, 0, 1});
  EXPECT_LT((T.linear().col(0) - Eigen::Vector3d(1, 0, 0)).norm(), 1e-15);
  EXPECT_LT((T.linear().col(1) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-15);
  EXPECT_LT((T.linear().col(2) - Eigen::Vector3d(0, 1, 0)).norm(), 1e-15);
  EXPECT_LT((T.translation() - Eigen::Vector3d(0, -1000, 0)).norm(), 1e-15);
  EXPECT_THROW(look_at({0, 0, 10}, {0, 0, 0}, {0, 0, 1}), std::invalid_argument);
}

TEST(DepthCamera, BadSettingsThrow) {
  PinholeCamera camera;
  camera.fx = 0;
  EXPECT_THROW(render(camera, {}, {}, 1), std::invalid_argument);
  DepthSensorSettings s;
  s.dropout = 1.5;
  EXPECT_THROW(render(PinholeCamera{}, {}, s, 1), std::invalid_argument);
}

}  // namespace
}  // namespace align3d::synth
