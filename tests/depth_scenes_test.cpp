// Depth-camera scenes (synth/depth_scenes.hpp). Oracles: the shapes' own distance functions (every
// point lies on the surface it came from, to within the stated noise), the camera's pose and tilt
// from the settings, the object's dimensions from its description.
#include "align3d/synth/depth_scenes.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "align3d/kdtree.hpp"
#include "align3d/se3.hpp"
#include "test_util.hpp"

namespace align3d::synth {
namespace {

// Distance from an object-frame point to the test object's outer surface: on some part's surface
// and inside none (a point inside the union is as far as its nearest way out).
double object_surface_distance(const Eigen::Vector3d& p) {
  double d = kInfinity;
  for (const Shape& s : test_object_shapes()) d = std::min(d, surface_distance(s, p));
  return d;
}

using test::same_bits;

TEST(DepthScenes, TestObjectModelCoversItsOuterSurface) {
  const PointCloud model = test_object_model(20000, 1);
  ASSERT_EQ(model.size(), 20000u);
  ASSERT_TRUE(model.has_normals());
  const std::vector<Shape> parts = test_object_shapes();
  Eigen::AlignedBox3d box;
  for (std::size_t i = 0; i < model.size(); ++i) {
    const Eigen::Vector3d& p = model.positions[i];
    box.extend(p);
    ASSERT_LT(object_surface_distance(p), 1e-9);
    for (const Shape& s : parts) {
      ASSERT_FALSE(surface_distance(s, p) > 1e-9 && contains(s, p));  // inside no other part
      ASSERT_FALSE(contains(s, p + 1e-9 * model.normals[i]));         // outward
    }
  }
  // The description in the header: 140 × 80 × 75 mm, the base on z = 0.
  EXPECT_LT((box.min() - Eigen::Vector3d(-70, -40, 0)).norm(), 1.5);
  EXPECT_LT((box.max() - Eigen::Vector3d(70, 40, 75)).norm(), 1.5);
}

class BinSceneTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    BinSceneSettings s;
    s.instances = 2;
    scene_ = new BinScene(make_bin_scene(s));
  }
  static void TearDownTestSuite() { delete scene_; }
  static BinScene* scene_;
};
BinScene* BinSceneTest::scene_ = nullptr;

TEST_F(BinSceneTest, EveryPointLiesOnTheSurfaceItCameFrom) {
  const BinScene& b = *scene_;
  const BinSceneSettings defaults;
  ASSERT_EQ(b.cloud.width, 640);
  ASSERT_EQ(b.cloud.height, 480);
  std::size_t valid = 0;
  for (std::size_t i = 0; i < b.cloud.positions.size(); ++i) {
    const Eigen::Vector3d& p = b.cloud.positions[i];
    if (b.cloud.shape[i] < 0) {
      ASSERT_FALSE(p.allFinite());
      continue;
    }
    ++valid;
    const Shape& shape = b.shapes[static_cast<std::size_t>(b.cloud.shape[i])];
    ASSERT_LT(surface_distance(shape, b.camera.T_world_camera * p),
              6 * defaults.sensor.sigma(p.z()));
  }
  // A real depth image: most pixels valid, some lost (dropout, holes, shadows, grazing walls).
  EXPECT_GT(valid, 0.8 * 640 * 480);
  EXPECT_LT(valid, (1 - defaults.sensor.dropout) * 640 * 480);
}

TEST_F(BinSceneTest, FloorAndCameraMatchTheSettings) {
  const BinScene& b = *scene_;
  const BinSceneSettings s;
  // The camera is camera_height above the floor, its axis tilted by camera_tilt_deg from the
  // floor's normal.
  EXPECT_NEAR(b.floor.signed_distance(Eigen::Vector3d::Zero()), s.camera_height, 1e-9);
  EXPECT_NEAR(rad_to_deg(std::acos(-b.floor.normal.z())), s.camera_tilt_deg, 1e-9);
  // Floor pixels lie on that plane; the optical axis meets the floor at the bin's centre, which
  // lies on the bin's bottom, camera_height − bin_wall below along the vertical.
  int floor_pixels = 0;
  for (std::size_t i = 0; i < b.cloud.positions.size(); ++i)
    if (b.cloud.shape[i] == 0) {
      ++floor_pixels;
      const Eigen::Vector3d& p = b.cloud.positions[i];
      ASSERT_LT(std::abs(b.floor.signed_distance(p)), 6 * s.sensor.sigma(p.z()));
    }
  EXPECT_GT(floor_pixels, 1000);
  const Eigen::Vector3d centre = b.camera.T_world_camera.inverse() * Eigen::Vector3d(0, 0, 0);
  EXPECT_NEAR(centre.x(), 0, 1e-9);
  EXPECT_NEAR(centre.y(), 0, 1e-9);
}

TEST_F(BinSceneTest, PosesMapTheModelOntoEachInstance) {
  const BinScene& b = *scene_;
  const BinSceneSettings s;
  ASSERT_EQ(b.T_camera_object.size(), 2u);
  const KdTree model(b.model.positions);
  for (int k = 0; k < 2; ++k) {
    const Eigen::Isometry3d T_object_camera =
        b.T_camera_object[static_cast<std::size_t>(k)].inverse();
    double sum = 0;
    int n = 0;
    for (std::size_t i = 0; i < b.instance.size(); ++i) {
      if (b.instance[i] != k) continue;
      const Eigen::Vector3d& p = b.cloud.positions[i];
      const Eigen::Vector3d q = T_object_camera * p;
      ASSERT_LT(object_surface_distance(q), 6 * s.sensor.sigma(p.z()));
      Neighbor nb;
      ASSERT_TRUE(model.nearest(q, nb));
      sum += std::sqrt(nb.sq_distance);
      ++n;
    }
    // Seen from ~0.7 m the object covers thousands of pixels; their mean distance to the model is
    // the depth noise's mean |ε| (σ·√(2/π) ≈ 1.4 mm at 0.75 m) plus the model's sampling gap
    // (20000 points over ~68000 mm²: ~1.8 mm spacing, ~0.7 mm to the nearest sample).
    EXPECT_GT(n, 2000) << k;
    EXPECT_LT(sum / n, 0.8 * s.sensor.sigma(800) + 1.0) << k;
  }
}

TEST_F(BinSceneTest, InstancesRestInsideTheBin) {
  const BinScene& b = *scene_;
  const BinSceneSettings s;
  const Eigen::Vector2d inner = s.bin_size.head<2>() / 2 - Eigen::Vector2d::Constant(s.bin_wall);
  for (std::size_t i = 6; i < b.shapes.size(); ++i) {  // past the floor and the bin's five boxes
    const Eigen::AlignedBox3d box = bounding_box(b.shapes[i]);
    EXPECT_GE(box.min().z(), s.bin_wall - 1e-9) << i;
    EXPECT_TRUE((box.min().head<2>().array() >= -inner.array()).all()) << i;
    EXPECT_TRUE((box.max().head<2>().array() <= inner.array()).all()) << i;
  }
  // Each instance touches the bin's bottom with its lowest point.
  for (int k = 0; k < 2; ++k) {
    double lowest = kInfinity;
    for (std::size_t i = 0; i < b.shapes.size(); ++i)
      if (b.shape_instance[i] == k) lowest = std::min(lowest, bounding_box(b.shapes[i]).min().z());
    EXPECT_NEAR(lowest, s.bin_wall, 1e-9) << k;
  }
}

TEST(DepthScenes, BinSceneIsDeterministic) {
  BinSceneSettings s;
  s.sensor.threads = 1;
  const BinScene a = make_bin_scene(s);
  s.sensor.threads = 2;
  EXPECT_TRUE(same_bits(a.cloud, make_bin_scene(s).cloud));
  s.seed = 2;
  const BinScene c = make_bin_scene(s);
  EXPECT_FALSE(same_bits(a.cloud, c.cloud));
  EXPECT_FALSE(a.T_camera_object[0].isApprox(c.T_camera_object[0]));
}

TEST(DepthScenes, NoiseFreeBinSceneIsExact) {
  BinSceneSettings s;
  s.sensor.noise_a = s.sensor.noise_b = 0;
  s.instances = 3;
  s.clutter = 3;
  const BinScene b = make_bin_scene(s);
  for (std::size_t i = 0; i < b.cloud.positions.size(); ++i) {
    if (b.cloud.shape[i] < 0) continue;
    ASSERT_LT(surface_distance(b.shapes[static_cast<std::size_t>(b.cloud.shape[i])],
                               b.camera.T_world_camera * b.cloud.positions[i]),
              1e-9);
  }
  // Without noise the poses map every instance pixel exactly onto the object's surface.
  ASSERT_EQ(b.T_camera_object.size(), 3u);
  for (std::size_t i = 0; i < b.instance.size(); ++i) {
    if (b.instance[i] < 0) continue;
    const auto& T = b.T_camera_object[static_cast<std::size_t>(b.instance[i])];
    ASSERT_LT(object_surface_distance(T.inverse() * b.cloud.positions[i]), 1e-9);
  }
  // Clutter fills only the room left; instances that do not fit are an error.
  BinSceneSettings crowded;
  crowded.instances = 3;
  crowded.clutter = 30;
  const BinScene full = make_bin_scene(crowded);
  EXPECT_LT(full.clutter, 30);
  EXPECT_EQ(full.shapes.size(), 6 + static_cast<std::size_t>(full.clutter) + 3 * 4);
  crowded.instances = 40;
  EXPECT_THROW(make_bin_scene(crowded), std::invalid_argument);
}

// Views of the object from azimuths `angle` apart share less of it as the angle grows. Overlap:
// of the model points that a view sees (a view point within 2 mm, moved into the object frame by
// the true pose), the share seen by both among those seen by either.
double view_overlap(double angle) {
  ObjectViewsSettings s;
  s.azimuth_deg = {s.azimuth_deg[0], s.azimuth_deg[0] + angle};
  const ObjectViews views = make_object_views(s);
  std::vector<char> seen[2];
  for (std::size_t k = 0; k < 2; ++k) {
    std::vector<Eigen::Vector3d> points;
    for (const auto& p : views.views[k].valid_points().positions)
      points.push_back(views.T_camera_object[k].inverse() * p);
    const KdTree tree(points);
    for (const auto& q : views.model.positions) {
      Neighbor nb;
      seen[k].push_back(tree.nearest(q, nb, 4.0));
    }
  }
  double both = 0, either = 0;
  for (std::size_t i = 0; i < seen[0].size(); ++i) {
    both += seen[0][i] && seen[1][i];
    either += seen[0][i] || seen[1][i];
  }
  return both / either;
}

TEST(DepthScenes, ObjectViewsLieOnTheObjectAndOverlapLessAsTheyPartAlong) {
  ObjectViewsSettings s;
  s.azimuth_deg = {0, 90, 200};
  const ObjectViews views = make_object_views(s);
  ASSERT_EQ(views.views.size(), 3u);
  ASSERT_EQ(views.T_camera_object.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const OrganizedCloud& view = views.views[k];
    const Eigen::Isometry3d T_object_camera = views.T_camera_object[k].inverse();
    std::size_t valid = 0;
    for (int v = 0; v < view.height; ++v)
      for (int u = 0; u < view.width; ++u) {
        const Eigen::Vector3d& p = view.at(u, v);
        if (!p.allFinite()) continue;
        ++valid;
        ASSERT_LT((views.cameras[k].project(p) - Eigen::Vector2d(u, v)).norm(), 1e-6);
        ASSERT_LT(object_surface_distance(T_object_camera * p), 6 * s.sensor.sigma(p.z()));
      }
    EXPECT_GT(valid, 10000u) << k;
    // The camera's distance to the target point is the settings' distance.
    EXPECT_NEAR(
        (views.cameras[k].T_world_camera.translation() - Eigen::Vector3d(0, 0, s.target_height))
            .norm(),
        s.distance, 1e-9);
  }
  const double o10 = view_overlap(10), o60 = view_overlap(60), o120 = view_overlap(120),
               o180 = view_overlap(180);
  EXPECT_GT(o10, o60);
  EXPECT_GT(o60, o120);
  EXPECT_GT(o120, o180);
  EXPECT_GT(o10, 0.7);   // nearly the same side
  EXPECT_LT(o180, 0.2);  // opposite sides share only the top
}

}  // namespace
}  // namespace align3d::synth
