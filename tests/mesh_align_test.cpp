// Registration onto a mesh's exact surface (icp.hpp, refine.hpp, align.hpp): scans sampled from the
// mesh with noise, moved by a known pose, come back to that pose; a local bump does not pull the
// robust default while it pulls plain least squares; the global stage finds a pose from anywhere.
#include <gtest/gtest.h>

#include <cmath>

#include "align3d/align.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/mesh_index.hpp"
#include "detail/random.hpp"
#include "mesh_test_util.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

// The L block scaled to 100 × 100 × 50 mm: a part with a concave edge and no symmetry.
TriangleMesh l_part() {
  TriangleMesh m = test::l_block();
  for (Eigen::Vector3d& v : m.vertices) v = Eigen::Vector3d(50 * v.x(), 50 * v.y(), 50 * v.z());
  return m;
}

// A view of the part from `view` (unit, pointing from the part to the sensor): surface samples
// facing it, with Gaussian noise σ along the normal and `bump(p)` added along it, then moved into
// the scan frame by truth⁻¹ (so that part ≈ truth·scan).
PointCloud scan_of(const TriangleMesh& part, const Eigen::Isometry3d& truth, double sigma,
                   const Eigen::Vector3d& view, std::uint64_t seed,
                   double (*bump)(const Eigen::Vector3d&) = nullptr) {
  const PointCloud samples = sample_surface(part, 40000, seed);
  Random rng(seed + 100);
  PointCloud scan;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector3d& n = samples.normals[i];
    if (n.dot(view) < 0.2) continue;
    const double h = sigma * rng.normal() + (bump ? bump(samples.positions[i]) : 0.0);
    scan.positions.push_back(truth.inverse() * (samples.positions[i] + h * n));
  }
  return scan;
}

Eigen::Isometry3d pose_deg(double deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()));
  T.pretranslate(t);
  return T;
}

const Eigen::Vector3d kView = Eigen::Vector3d(0.3, -0.4, 1).normalized();

TEST(MeshAlign, IcpOntoTheSurfaceRecoversTheSmallPose) {
  const TriangleMesh part = l_part();
  const auto surface = std::make_shared<const MeshIndex>(part);
  const Eigen::Isometry3d truth = pose_deg(3, {1, 2, 3}, {1.5, -1, 0.5});
  const PointCloud scan = scan_of(part, truth, 0.0, kView, 1);
  for (IcpMethod method : {IcpMethod::kPointToPlane, IcpMethod::kPointToPoint}) {
    IcpSettings s;
    s.method = method;
    s.rejection = RejectionRule::none();
    s.termination.max_iterations = 200;
    const IcpResult r = icp(scan, *surface, Eigen::Isometry3d::Identity(), s);
    // Noise-free samples of the exact surface: the pose comes back to rounding, which a sampled
    // target (nearest vertices) could not give.
    EXPECT_LT(test::rotation_error_deg(r.T_target_source, truth), 1e-4) << to_string(method);
    EXPECT_LT(test::translation_error(r.T_target_source, truth), 1e-4) << to_string(method);
    EXPECT_LT(r.rms, 1e-5);
  }
}

TEST(MeshAlign, AlignOntoAMeshFindsThePoseFromAnyStart) {
  const TriangleMesh part = l_part();
  const Eigen::Isometry3d truth = pose_deg(140, {1, -1, 0.5}, {30, -20, 10});
  const PointCloud scan = scan_of(part, truth, 0.02, kView, 2);
  const AlignResult r = align(scan, part);
  ASSERT_TRUE(r.success) << r.failure;
  EXPECT_EQ(r.path, "global");
  EXPECT_FALSE(r.reversed);
  EXPECT_LT(test::rotation_error_deg(r.transformation, truth), 0.01);
  EXPECT_LT(test::translation_error(r.transformation, truth), 0.005);
  // From this view the faces the scan sees fit the part turned by 180° exactly as well (after ICP
  // from either pose: overlap 0.410 and 0.411, the same RMS): the answer is right and says so.
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings.front().code, "ambiguous") << r.warnings.front().message;
  ASSERT_EQ(r.candidates.size(), 3u);
  EXPECT_NEAR(test::rotation_error_deg(r.candidates[2].transformation, truth), 180.0, 0.1);
  // A prepared mesh target gives the same pose, to the bit.
  const PreparedTarget prepared(part);
  ASSERT_NE(prepared.surface(), nullptr);
  const AlignResult again = align(scan, prepared);
  EXPECT_TRUE(again.transformation.isApprox(r.transformation, 0));
}

// A bump of 0.4 mm (cos² profile, radius 20 mm) on the top face of the part: 7 % of what the
// sensor sees stands off the CAD surface by up to 20 σ.
double bump(const Eigen::Vector3d& p) {
  const double r = (p - Eigen::Vector3d(25, 25, 50)).norm();
  return r < 20 && p.z() > 49.9 ? 0.4 * std::pow(std::cos(0.5 * M_PI * r / 20), 2) : 0.0;
}

TEST(MeshAlign, ALocalBumpDoesNotPullTheRobustFit) {
  const TriangleMesh part = l_part();
  const auto surface = std::make_shared<const MeshIndex>(part);
  RefineTarget target(surface);
  const Eigen::Isometry3d truth = pose_deg(2, {0, 1, 1}, {0.5, 0.3, -0.2});
  const PointCloud scan = scan_of(part, truth, 0.01, kView, 3, &bump);
  const RefineResult robust = refine(scan, target, Eigen::Isometry3d::Identity());
  RefineSettings plain;
  plain.rejection = RejectionRule::none();
  const RefineResult lsq = refine(scan, target, Eigen::Isometry3d::Identity(), plain);
  const double robust_t = test::translation_error(robust.icp.T_target_source, truth);
  const double lsq_t = test::translation_error(lsq.icp.T_target_source, truth);
  const double robust_r = test::rotation_error_deg(robust.icp.T_target_source, truth);
  const double lsq_r = test::rotation_error_deg(lsq.icp.T_target_source, truth);
  // The robust fit stays within half the noise σ (the bump's rim, lower than the noise, still
  // counts); plain least squares is pulled toward the bump by an order of magnitude more (measured:
  // 0.0022 mm and 0.0014° against 0.067 mm and 0.044°; 1e-4 mm without the bump).
  EXPECT_LT(robust_t, 0.005);
  EXPECT_LT(robust_r, 0.005);
  EXPECT_GT(lsq_t, 10 * robust_t);
  EXPECT_GT(lsq_r, 10 * robust_r);
  RecordProperty("robust_translation_mm", std::to_string(robust_t));
  RecordProperty("lsq_translation_mm", std::to_string(lsq_t));
  std::printf("bump: robust %.5f mm %.5f deg, least squares %.5f mm %.5f deg\n", robust_t, robust_r,
              lsq_t, lsq_r);
}

TEST(MeshAlign, SameDataInMetresGivesTheSamePose) {
  const TriangleMesh part = l_part();
  const Eigen::Isometry3d truth = pose_deg(25, {1, 0, 1}, {4, -3, 2});
  const PointCloud scan = scan_of(part, truth, 0.02, kView, 4);
  TriangleMesh part_m = part;
  for (auto& v : part_m.vertices) v *= 1e-3;
  PointCloud scan_m = scan;
  for (auto& p : scan_m.positions) p *= 1e-3;
  const AlignResult mm = align(scan, part), m = align(scan_m, part_m);
  ASSERT_TRUE(mm.success && m.success);
  EXPECT_EQ(mm.path, m.path);
  EXPECT_LT(test::rotation_error_deg(mm.transformation, m.transformation), 1e-6);
  EXPECT_LT((mm.transformation.translation() * 1e-3 - m.transformation.translation()).norm(), 1e-9);
  EXPECT_LT(test::rotation_error_deg(mm.transformation, truth), 0.01);
}

}  // namespace
}  // namespace align3d
