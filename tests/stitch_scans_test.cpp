// Multi-view scans for stitching (synth/stitch_scans.hpp). Oracles: the mesh's exact distance
// (MeshIndex) for every scan point within the sensor's noise, the poses' own algebra, the scans'
// points against each other in scan_00's frame for the leaf's overlap, the flange's revolved
// geometry for the near-symmetry, and the files `align3d synth --scene stitch` writes read back.
#include "align3d/synth/stitch_scans.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/bin_picking.hpp"
#include "test_util.hpp"

namespace align3d::synth {
namespace {

// A quarter of the default camera's pixels, the same field of view: the geometry (and the overlap,
// which does not depend on pixels) stays, the runtime drops.
StitchScanSettings small_settings(StitchObject object, std::uint64_t seed = 1) {
  StitchScanSettings s;
  s.object = object;
  s.seed = seed;
  s.camera =
      PinholeCamera{.width = 320, .height = 240, .fx = 500, .fy = 500, .cx = 159.5, .cy = 119.5};
  s.overlap_samples = 10000;
  return s;
}

bool same_bits(const PointCloud& a, const PointCloud& b) {
  return a.positions.size() == b.positions.size() &&
         std::memcmp(a.positions.data(), b.positions.data(),
                     a.positions.size() * sizeof(Eigen::Vector3d)) == 0;
}

class StitchScansObjects : public ::testing::TestWithParam<StitchObject> {};

// The noise moves a point along its ray by σ(z)·ε·|p|/z, so its distance to the surface is at most
// that: all within 6σ, and no more than 0.1 % beyond 4σ (a Gaussian leaves 0.006 % there).
TEST_P(StitchScansObjects, ScanPointsLieOnTheMeshWithinTheNoise) {
  const StitchScanSettings s = small_settings(GetParam());
  const StitchScans out = make_stitch_scans(s);
  ASSERT_EQ(out.scans.size(), 9u);
  ASSERT_EQ(out.T_camera_object.size(), 9u);
  EXPECT_DOUBLE_EQ(out.diameter, bounding_box_diagonal(out.mesh));
  const MeshIndex index(out.mesh);
  for (std::size_t k = 0; k < out.scans.size(); ++k) {
    const PointCloud& scan = out.scans[k];
    EXPECT_GT(scan.size(), 1500u) << "scan " << k;
    EXPECT_FALSE(scan.has_normals());
    const Eigen::Isometry3d T_object_camera = out.T_camera_object[k].inverse();
    std::size_t beyond_4 = 0;
    for (const Eigen::Vector3d& p : scan.positions) {
      ASSERT_TRUE(p.allFinite());
      SurfacePoint c;
      ASSERT_TRUE(index.closest(T_object_camera * p, c));
      const double sigma = s.sensor.sigma(p.z()) * p.norm() / p.z();
      const double d = std::sqrt(c.sq_distance);
      ASSERT_LT(d, 6 * sigma) << "scan " << k;
      beyond_4 += d > 4 * sigma;
    }
    EXPECT_LE(beyond_4, scan.size() / 1000) << "scan " << k;
  }
}

TEST_P(StitchScansObjects, PosesChainIntoTheFirstScan) {
  const StitchScans out = make_stitch_scans(small_settings(GetParam()));
  ASSERT_EQ(out.T_first_scan.size(), out.scans.size());
  ASSERT_EQ(out.eye.size(), out.scans.size());
  EXPECT_TRUE(out.T_first_scan[0].isApprox(Eigen::Isometry3d::Identity(), 1e-15));
  for (std::size_t k = 0; k < out.scans.size(); ++k) {
    const Eigen::Isometry3d expected = out.T_camera_object[0] * out.T_camera_object[k].inverse();
    EXPECT_LT((out.T_first_scan[k].matrix() - expected.matrix()).norm(), 1e-9) << k;
    EXPECT_LT((out.T_camera_object[k].inverse().translation() - out.eye[k]).norm(), 1e-9);
    // Every camera sits outside the object, ~450 mm (the leaf 400 mm) from its centre.
    const double range = (out.eye[k] - bounding_box(out.mesh).center()).norm();
    EXPECT_GT(range, 380) << k;
    EXPECT_LT(range, 470) << k;
  }
}

INSTANTIATE_TEST_SUITE_P(StitchScans, StitchScansObjects,
                         ::testing::Values(StitchObject::kBracket, StitchObject::kKeyedFlange),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// Share of `a`'s points within 1 mm of one of `b`'s (both in scan_00's frame).
double near_share(const std::vector<Eigen::Vector3d>& a, const KdTree& b) {
  std::size_t near = 0;
  for (const Eigen::Vector3d& p : a) {
    Neighbor n;
    near += b.nearest(p, n, 1.0);
  }
  return static_cast<double>(near) / static_cast<double>(a.size());
}

std::vector<Eigen::Vector3d> in_first_frame(const StitchScans& out, std::size_t k) {
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& p : out.scans[k].positions) points.push_back(out.T_first_scan[k] * p);
  return points;
}

// The leaf overlaps its parent by 0.2 or more and every other view by less than 0.05, by the
// generator's own measure; and the scans agree: most of the parent's points lie within 1 mm of the
// leaf's (in scan_00's frame), hardly any of another view's.
TEST(StitchScans, TheLeafOverlapsExactlyOneView) {
  for (StitchObject object : {StitchObject::kBracket, StitchObject::kKeyedFlange})
    for (std::uint64_t seed : {1, 2, 3}) {
      const StitchScans out = make_stitch_scans(small_settings(object, seed));
      SCOPED_TRACE(std::string(to_string(object)) + " seed " + std::to_string(seed));
      ASSERT_EQ(out.leaf, 8);
      ASSERT_EQ(out.leaf_parent, 5);
      ASSERT_EQ(out.overlap.rows(), 9);
      EXPECT_TRUE(out.overlap.isApprox(out.overlap.transpose()));
      int strong = 0;
      for (int j = 0; j < out.leaf; ++j) {
        const double share = out.overlap(out.leaf, j);
        strong += share >= 0.2;
        if (j == out.leaf_parent)
          EXPECT_GE(share, 0.2);
        else
          EXPECT_LT(share, 0.05) << "view " << j;
      }
      EXPECT_EQ(strong, 1);
      const KdTree leaf(in_first_frame(out, static_cast<std::size_t>(out.leaf)));
      for (int j = 0; j < out.leaf; ++j) {
        const double share = near_share(in_first_frame(out, static_cast<std::size_t>(j)), leaf);
        if (j == out.leaf_parent)
          EXPECT_GT(share, 0.3);
        else
          EXPECT_LT(share, 0.05) << "view " << j;
      }
    }
}

// Rotated about z by 90° (16 of its 64 sides), the flange maps onto itself exactly; the lugs do
// not: their samples land up to 5 mm off the surface.
TEST(StitchScans, KeyedFlangeIsNearSymmetricButNotSymmetric) {
  const TriangleMesh mesh = keyed_flange_mesh();
  const MeshTopology t = analyse_topology(mesh);
  EXPECT_TRUE(t.closed());
  EXPECT_EQ(t.components, 4u);
  const MeshIndex index(mesh);
  const PointCloud samples = sample_surface(mesh, 20000, 7);
  const Eigen::Isometry3d R = rigid_transform(90, Eigen::Vector3d::UnitZ());
  std::size_t close = 0, far = 0;
  for (const Eigen::Vector3d& p : samples.positions) {
    SurfacePoint c;
    ASSERT_TRUE(index.closest(R * p, c));
    const double d = std::sqrt(c.sq_distance);
    close += d < 0.5;
    far += d > 3;
  }
  EXPECT_GT(close, samples.size() * 85 / 100);
  EXPECT_GT(far, samples.size() / 100);
  // The plain flange is symmetric under the same rotation.
  const MeshIndex plain(bin_part_mesh(BinPart::kFlange));
  for (const Eigen::Vector3d& p : sample_surface(plain.mesh(), 2000, 7).positions) {
    SurfacePoint c;
    ASSERT_TRUE(plain.closest(R * p, c));
    ASSERT_LT(c.sq_distance, 1e-16);
  }
}

TEST(StitchScans, SameSeedSameBitsAtAnyThreadCount) {
  StitchScanSettings s = small_settings(StitchObject::kKeyedFlange, 4);
  s.threads = 1;
  const StitchScans one = make_stitch_scans(s);
  s.threads = 4;
  const StitchScans four = make_stitch_scans(s);
  s.threads = 0;
  const StitchScans all = make_stitch_scans(s);
  ASSERT_EQ(one.scans.size(), four.scans.size());
  for (std::size_t k = 0; k < one.scans.size(); ++k) {
    EXPECT_TRUE(same_bits(one.scans[k], four.scans[k])) << k;
    EXPECT_TRUE(same_bits(one.scans[k], all.scans[k])) << k;
    EXPECT_EQ(one.T_first_scan[k].matrix(), four.T_first_scan[k].matrix());
  }
  EXPECT_EQ(one.overlap, four.overlap);
  EXPECT_EQ(one.overlap, all.overlap);
  // Without the leaf, the ring is the same but for the leaf's parent, which looks from the low
  // views' elevation then; another seed moves the cameras.
  s.leaf = false;
  const StitchScans ring = make_stitch_scans(s);
  ASSERT_EQ(ring.scans.size(), 8u);
  EXPECT_EQ(ring.leaf, -1);
  EXPECT_EQ(ring.leaf_parent, -1);
  for (std::size_t k = 0; k < ring.scans.size(); ++k)
    EXPECT_EQ(same_bits(ring.scans[k], one.scans[k]), static_cast<int>(k) != one.leaf_parent) << k;
  s.seed = 5;
  EXPECT_FALSE(same_bits(make_stitch_scans(s).scans[1], one.scans[1]));
}

TEST(StitchScans, BadSettingsThrow) {
  for (int views : {0, 1}) {
    StitchScanSettings s;
    s.views = views;
    EXPECT_THROW(make_stitch_scans(s), std::invalid_argument) << views;
  }
  for (double distance : {0.0, -450.0, 50.0}) {  // 50: inside the bounding sphere
    StitchScanSettings s;
    s.distance = distance;
    EXPECT_THROW(make_stitch_scans(s), std::invalid_argument) << distance;
    s = {};
    s.leaf_distance = distance;
    EXPECT_THROW(make_stitch_scans(s), std::invalid_argument) << distance;
  }
  StitchScanSettings s;
  s.jitter_deg = -1;
  EXPECT_THROW(make_stitch_scans(s), std::invalid_argument);
  EXPECT_THROW(stitch_object_from_string("gear"), std::invalid_argument);
  EXPECT_EQ(stitch_object_from_string("flange"), StitchObject::kKeyedFlange);
}

// The files: scans.txt lists the scans in order, each PLY holds its scan in its sensor frame, and
// truth.json's poses carry them into scan_00's frame onto the model.
TEST(StitchScans, SynthCommandWritesScansAndTruth) {
  test::TempDir d("synth_stitch");
  const test::CliRun r = test::run({"synth", d.path().string(), "--scene", "stitch", "--part",
                                    "flange", "--views", "3", "--seed", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(test::read_text(d / "truth.json"));
  EXPECT_EQ(j["scene"], "stitch");
  EXPECT_EQ(j["part"], "flange");
  ASSERT_EQ(j["scans"].size(), 4u);
  EXPECT_EQ(j["leaf"], 3);
  EXPECT_EQ(j["leaf_parent"], 1);
  EXPECT_EQ(j["overlap"].size(), 4u);
  EXPECT_EQ(test::read_text(d / "scans.txt"),
            "scan_00.ply\nscan_01.ply\nscan_02.ply\nscan_03.ply\n");
  const MeshIndex model(io::read_mesh(d / "model.stl"));
  EXPECT_NEAR(j["diameter"].get<double>(), model.diagonal(), 1e-4);  // STL: float32
  const auto T0 = j["scans"][0]["T_camera_object"].get<std::vector<std::vector<double>>>();
  Eigen::Isometry3d T_camera0_object;
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) T_camera0_object.matrix()(a, b) = T0[a][b];
  const Eigen::Isometry3d T_object_camera0 = T_camera0_object.inverse();
  for (std::size_t k = 0; k < 4; ++k) {
    const auto& scan = j["scans"][k];
    const PointCloud cloud = io::read_point_cloud(d / scan["file"].get<std::string>());
    EXPECT_EQ(cloud.size(), scan["points"].get<std::size_t>());
    const auto m = scan["pose"]["transformation"].get<std::vector<std::vector<double>>>();
    Eigen::Isometry3d T;
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) T.matrix()(a, b) = m[a][b];
    for (std::size_t i = 0; i < cloud.size(); i += 50) {
      SurfacePoint c;
      ASSERT_TRUE(model.closest(T_object_camera0 * (T * cloud.positions[i]), c));
      ASSERT_LT(c.sq_distance, 1.0) << k;  // float32 coordinates and σ ≈ 0.09 mm
    }
  }
}

}  // namespace
}  // namespace align3d::synth
