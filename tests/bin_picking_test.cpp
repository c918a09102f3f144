// The bin-picking scene generator (synth/bin_picking.hpp): its meshes against closed-form volumes,
// its scenes against their own ground truth: labelled pixels on the posed model within the
// sensor's noise, instances apart, visible fractions consistent, same seed same bits.
#include "align3d/synth/bin_picking.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "align3d/mesh_index.hpp"
#include "test_util.hpp"

namespace align3d::synth {
namespace {

using test::kPi;

double polygon_factor(int n) { return n / 2.0 * std::sin(2 * kPi / n); }  // area of unit n-gon

void expect_closed_outward(const TriangleMesh& m, double volume, double tolerance) {
  const MeshTopology t = analyse_topology(m);
  EXPECT_TRUE(t.closed());
  EXPECT_EQ(t.inconsistent_edges, 0u);
  EXPECT_NEAR(t.signed_volume, volume, tolerance);
}

TEST(BinPickingMeshes, SolidsAreClosedOutwardWithTheirVolumes) {
  expect_closed_outward(box_mesh({1, 2, 3}), 48, 1e-12);
  expect_closed_outward(cylinder_mesh(2, 3, 12), polygon_factor(12) * 4 * 6, 1e-9);
  // A latitude-longitude sphere is inscribed: its volume lies a little under 4/3·π·r³.
  const double sphere = 4.0 / 3 * kPi * 8;
  const MeshTopology s = analyse_topology(sphere_mesh(2, 16));
  EXPECT_TRUE(s.closed());
  EXPECT_LT(s.signed_volume, sphere);
  EXPECT_GT(s.signed_volume, 0.97 * sphere);
  // The flange: (n/2)·sin(2π/n) · ∫∫ 2r dr dz over its profile = factor · 38 050.
  for (int n : {16, 64})
    expect_closed_outward(bin_part_mesh(BinPart::kFlange, n), polygon_factor(n) * 38050, 1e-6);
  // A clockwise profile gives the same solid, outward too.
  expect_closed_outward(revolve({{1, 0}, {1, 1}, {2, 1}, {2, 0}}, 8), polygon_factor(8) * 3, 1e-9);
  EXPECT_THROW(revolve({{0, 0}, {1, 0}, {1, 1}}, 8), std::invalid_argument);
  // The plate: its block less the chamfers (4 edges' prisms of leg²/2, less the 4 corners' leg³/3
  // counted twice), the slot and the holes' 64-gons, plus the boss's.
  const double chamfers = 1.5 * 1.5 / 2 * 2 * (110 + 70) - 4 * std::pow(1.5, 3) / 3;
  expect_closed_outward(bin_part_mesh(BinPart::kPlate),
                        110 * 70 * 10 - chamfers - 30 * 16 * 4 -
                            polygon_factor(64) * (4 * 4 * 6 + 5 * 5 * 10 - 7 * 7 * 4),
                        1e-6);
  for (const BinPart part : {BinPart::kBracket, BinPart::kFlange, BinPart::kPlate})
    EXPECT_EQ(bin_part_from_string(to_string(part)), part);
  EXPECT_THROW(bin_part_from_string("gear"), std::invalid_argument);
}

class BinPickingScenes : public ::testing::TestWithParam<BinPart> {};

TEST_P(BinPickingScenes, PixelsLieOnTheirInstanceAndInstancesApart) {
  BinPickingSettings s;
  s.part = GetParam();
  s.instances = 8;
  s.distractors = 3;
  s.seed = 5;
  const BinPickingScene scene = make_bin_picking_scene(s);
  ASSERT_EQ(scene.cloud.width, 640);
  ASSERT_EQ(scene.cloud.height, 480);
  ASSERT_EQ(scene.instances.size(), 8u);
  EXPECT_EQ(scene.distractors, 3);
  const MeshIndex model(scene.model);
  std::size_t labelled = 0;
  for (std::size_t k = 0; k < scene.instances.size(); ++k) {
    const BinPickingInstance& in = scene.instances[k];
    EXPECT_NEAR((in.T_camera_model.linear().transpose() * in.T_camera_model.linear() -
                 Eigen::Matrix3d::Identity())
                    .norm(),
                0, 1e-12);
    EXPECT_GE(in.visible_fraction, 0);
    EXPECT_LE(in.visible_fraction, 1);
    if (in.pixels > 0) {
      EXPECT_GT(in.visible_fraction, 0);
    }
    labelled += in.pixels;
    // Every pixel labelled k lies on instance k: within 5σ of the noise along its ray.
    const Eigen::Isometry3d to_model = in.T_camera_model.inverse();
    for (std::size_t i = 0; i < scene.cloud.positions.size(); ++i) {
      if (scene.cloud.shape[i] != static_cast<int>(k)) continue;
      const Eigen::Vector3d& p = scene.cloud.positions[i];
      SurfacePoint c;
      ASSERT_TRUE(model.closest(to_model * p, c));
      EXPECT_LT(std::sqrt(c.sq_distance), 5 * s.sensor.sigma(p.z())) << "instance " << k;
    }
    // No instance reaches into another: the vertices of one lie outside every other.
    for (std::size_t j = 0; j < k; ++j) {
      const Eigen::Isometry3d j_from_k =
          scene.instances[j].T_camera_model.inverse() * in.T_camera_model;
      for (const auto& v : scene.model.vertices) {
        SurfacePoint c;
        ASSERT_TRUE(model.closest(j_from_k * v, c));
        EXPECT_GT(model.signed_distance(j_from_k * v, c), 0) << k << " into " << j;
      }
    }
  }
  EXPECT_GT(labelled, 5000u);
  EXPECT_LT(labelled, scene.cloud.valid_count());  // the bin and the distractors are seen too
}

INSTANTIATE_TEST_SUITE_P(Parts, BinPickingScenes,
                         ::testing::Values(BinPart::kBracket, BinPart::kFlange, BinPart::kPlate),
                         [](const auto& info) { return std::string(to_string(info.param)); });

TEST(BinPickingScene, SameSeedSameBitsAtAnyThreadCount) {
  BinPickingSettings s;
  s.instances = 3;
  s.distractors = 2;
  s.threads = 1;
  const BinPickingScene a = make_bin_picking_scene(s);
  s.threads = 2;
  const BinPickingScene b = make_bin_picking_scene(s);
  ASSERT_EQ(a.cloud.positions.size(), b.cloud.positions.size());
  for (std::size_t i = 0; i < a.cloud.positions.size(); ++i) {
    const auto& p = a.cloud.positions[i];
    const auto& q = b.cloud.positions[i];
    ASSERT_TRUE((p.array() == q.array()).all() || (p.hasNaN() && q.hasNaN())) << i;
  }
  EXPECT_EQ(a.cloud.shape, b.cloud.shape);
  for (std::size_t k = 0; k < a.instances.size(); ++k)
    EXPECT_TRUE(a.instances[k].T_camera_model.isApprox(b.instances[k].T_camera_model, 0));
}

TEST(BinPickingScene, AnEmptyBinAndBadSettings) {
  BinPickingSettings s;
  s.instances = 0;
  s.distractors = 0;
  const BinPickingScene empty = make_bin_picking_scene(s);
  EXPECT_TRUE(empty.instances.empty());
  for (int label : empty.cloud.shape) EXPECT_EQ(label, -1);
  EXPECT_GT(empty.cloud.valid_count(), 200000u);  // the bin fills most of the image
  s.instances = 13;
  EXPECT_THROW(make_bin_picking_scene(s), std::invalid_argument);
  s.instances = 1;
  s.camera_height = 100;
  EXPECT_THROW(make_bin_picking_scene(s), std::invalid_argument);
}

}  // namespace
}  // namespace align3d::synth
