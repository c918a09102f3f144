// Inspection (inspect.hpp) on the generated machined part (synth/part.hpp), whose truth is known:
// the pose the scan was moved by, each point's true deviation (dents, bumps, warp), which points
// belong to the fixture. The recovered pose lies within the noise, every defect's peak is measured
// within 10 % (or 0.02 mm), the fixture is set apart as outliers, and the verdict follows the band.
#include "align3d/inspect.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "align3d/synth/part.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

class InspectPart : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    synth::AsBuiltSettings s;
    s.target_points = 150000;
    settings_ = new synth::AsBuiltSettings(s);
    scan_ = new synth::AsBuiltScan(synth::make_as_built_scan(s));
    cad_ = new TriangleMesh(synth::PartModel(s.part).mesh());
    InspectSettings is;
    is.tolerance = {-0.1, 0.1};
    result_ = new InspectResult(inspect(scan_->scan, *cad_, is));
  }
  static void TearDownTestSuite() {
    delete settings_;
    delete scan_;
    delete cad_;
    delete result_;
  }
  static synth::AsBuiltSettings* settings_;
  static synth::AsBuiltScan* scan_;
  static TriangleMesh* cad_;
  static InspectResult* result_;
};
synth::AsBuiltSettings* InspectPart::settings_ = nullptr;
synth::AsBuiltScan* InspectPart::scan_ = nullptr;
TriangleMesh* InspectPart::cad_ = nullptr;
InspectResult* InspectPart::result_ = nullptr;

// How far the pose moves the part's points from where the truth puts them, at worst: over the
// corners of its bounding box.
double worst_displacement(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                          const TriangleMesh& cad) {
  Eigen::Vector3d lo = cad.vertices[0], hi = lo;
  for (const auto& v : cad.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  double worst = 0;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d c((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(),
                            (k & 4) ? hi.z() : lo.z());
    worst = std::max(worst, (a.inverse() * c - b.inverse() * c).norm());
  }
  return worst;
}

TEST_F(InspectPart, PoseIsRecoveredWithinTheNoise) {
  const InspectResult& r = *result_;
  ASSERT_TRUE(r.registration.success) << r.registration.failure;
  // The warp (±0.015 mm) is not rigid: the best fit may tilt by a part of it, so no point of the
  // part moves farther from its true place than the warp's amplitude (measured: 0.012 mm at the
  // farthest corner of the box).
  const double moved = worst_displacement(r.registration.transformation, scan_->T_cad_scan, *cad_);
  EXPECT_LT(moved, settings_->warp_amplitude);
  RecordProperty("worst_displacement_mm", std::to_string(moved));
  // Without the warp the best fit is the generating pose, to a third of the noise σ = 0.01 mm.
  synth::AsBuiltSettings flat = *settings_;
  flat.warp_amplitude = 0;
  const synth::AsBuiltScan straight = synth::make_as_built_scan(flat);
  InspectSettings s;
  s.tolerance = {-0.1, 0.1};
  const InspectResult f = inspect(straight.scan, *cad_, s);
  EXPECT_LT(worst_displacement(f.registration.transformation, straight.T_cad_scan, *cad_), 0.003);
}

TEST_F(InspectPart, FixtureIsSetApartAndThePartIsMeasured) {
  const InspectResult& r = *result_;
  std::size_t fixture_kept = 0, part_lost = 0;
  for (std::size_t i = 0; i < scan_->scan.size(); ++i) {
    const bool outlier = std::isnan(r.map.deviation[i]);
    if (scan_->label[i] == synth::ScanLabel::kFixture) fixture_kept += outlier ? 0 : 1;
    if (scan_->label[i] == synth::ScanLabel::kPart) part_lost += outlier ? 1 : 0;
  }
  EXPECT_EQ(fixture_kept, 0u);
  EXPECT_EQ(part_lost, 0u);
  EXPECT_EQ(r.map.outliers, scan_->fixture_points);
  EXPECT_EQ(r.stats.count, scan_->part_points);
  // Each part point's deviation is its true one plus noise (σ = 0.01 along the ray).
  double sq = 0;
  for (std::size_t i = 0; i < scan_->scan.size(); ++i)
    if (scan_->label[i] == synth::ScanLabel::kPart) {
      const double e = r.map.deviation[i] - scan_->deviation[i];
      sq += e * e;
    }
  EXPECT_LT(std::sqrt(sq / scan_->part_points), 0.0125);
  EXPECT_NEAR(r.gauss.sigma, 0.01, 0.003);
}

// The peak of each defect, measured: the amplitude A of A·cos²(πr / 2R) + c fitted by least
// squares to the measured deviations of the points within its radius R on its face (c takes the
// warp's local offset), against the defect's stated peak.
TEST_F(InspectPart, EveryDentAndBumpPeakIsMeasuredWithinTenPercent) {
  const InspectResult& r = *result_;
  for (const synth::SurfaceDefect& d : settings_->defects) {
    Eigen::Matrix2d AtA = Eigen::Matrix2d::Zero();
    Eigen::Vector2d Atb = Eigen::Vector2d::Zero();
    int n = 0;
    for (std::size_t i = 0; i < scan_->scan.size(); ++i) {
      if (scan_->label[i] != synth::ScanLabel::kPart) continue;
      const Eigen::Vector3d p = scan_->T_cad_scan * scan_->scan.positions[i];
      const Eigen::Vector3d off = p - d.centre;
      const double radial = (off - off.dot(d.normal) * d.normal).norm();
      if (radial >= d.radius || std::abs(off.dot(d.normal)) > 1) continue;
      const Eigen::Vector2d a(std::pow(std::cos(0.5 * M_PI * radial / d.radius), 2), 1.0);
      AtA += a * a.transpose();
      Atb += a * r.map.deviation[i];
      ++n;
    }
    ASSERT_GT(n, 50) << d.centre.transpose();
    const double peak = AtA.ldlt().solve(Atb)(0);
    EXPECT_NEAR(peak, d.peak, std::max(0.1 * std::abs(d.peak), 0.02))
        << "defect at " << d.centre.transpose() << " (" << n << " points)";
    RecordProperty("peak_" + std::to_string(d.peak), std::to_string(peak));
  }
}

TEST_F(InspectPart, VerdictFollowsTheBand) {
  const InspectResult& r = *result_;
  // Dents of 0.3 mm and bumps of 0.3 mm against ±0.1: out.
  EXPECT_FALSE(r.pass);
  EXPECT_GT(r.below, 0u);
  EXPECT_GT(r.above, 0u);
  EXPECT_EQ(r.below + r.within + r.above, r.stats.count);
  EXPECT_DOUBLE_EQ(r.within_tolerance, static_cast<double>(r.within) / r.stats.count);
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front().message;
  // The same scan against ±0.4 passes (no defect reaches it; the noise is 0.01).
  InspectSettings wide;
  wide.tolerance = {-0.4, 0.4};
  const InspectResult w = inspect(scan_->scan, *cad_, wide);
  EXPECT_TRUE(w.pass);
  EXPECT_EQ(w.within, w.stats.count);
  // An asymmetric band that takes the bumps but not the dents: only "below" remains.
  InspectSettings bumps;
  bumps.tolerance = {-0.1, 0.4};
  const InspectResult b = inspect(scan_->scan, *cad_, bumps);
  EXPECT_EQ(b.above, 0u);
  EXPECT_EQ(b.below, r.below);
  EXPECT_FALSE(b.pass);
  bumps.pass_fraction = 1.0 - 1.2 * static_cast<double>(b.below) / b.stats.count;
  EXPECT_TRUE(inspect(scan_->scan, *cad_, bumps).pass);
}

TEST_F(InspectPart, InconsistentWindingIsRepairedAndReported) {
  TriangleMesh bad = *cad_;
  for (std::size_t t = 0; t < bad.triangles.size(); t += 7)
    std::swap(bad.triangles[t][1], bad.triangles[t][2]);
  InspectSettings s;
  s.tolerance = {-0.1, 0.1};
  s.align.init = InitPolicy::kPose;
  s.align.initial_pose = result_->registration.transformation;
  const InspectResult r = inspect(scan_->scan, bad, s);
  bool reported = false;
  for (const Warning& w : r.warnings) reported |= w.code == "mesh_winding";
  EXPECT_TRUE(reported);
  EXPECT_GT(r.repair.flipped_triangles, 0u);
  // Signs are those of the clean mesh.
  for (std::size_t i = 0; i < scan_->scan.size(); i += 97)
    if (!std::isnan(r.map.deviation[i]) && std::abs(r.map.deviation[i]) > 1e-3) {
      EXPECT_EQ(r.map.deviation[i] > 0, result_->map.deviation[i] > 0) << i;
    }
}

TEST_F(InspectPart, SameScanInMetresGivesTheSameVerdictAndCounts) {
  PointCloud scan_m = scan_->scan;
  for (auto& p : scan_m.positions) p *= 1e-3;
  TriangleMesh cad_m = *cad_;
  for (auto& v : cad_m.vertices) v *= 1e-3;
  InspectSettings s;
  s.tolerance = {-0.1e-3, 0.1e-3};
  const InspectResult m = inspect(scan_m, cad_m, s);
  EXPECT_EQ(m.pass, result_->pass);
  EXPECT_EQ(m.map.outliers, result_->map.outliers);
  EXPECT_NEAR(static_cast<double>(m.below), static_cast<double>(result_->below), 3);
  EXPECT_NEAR(static_cast<double>(m.above), static_cast<double>(result_->above), 3);
  EXPECT_NEAR(m.stats.p50 * 1e3, result_->stats.p50, 1e-4);
}

TEST(Inspect, RefusesBandsAndSettingsNoRunCanUse) {
  const PointCloud scan;
  const TriangleMesh cad;
  InspectSettings s;
  for (Tolerance t : {Tolerance{0, 0}, Tolerance{0.1, 0.2}, Tolerance{-0.2, -0.1},
                      Tolerance{0.1, -0.1}, Tolerance{-NAN, 0.1}}) {
    s.tolerance = t;
    EXPECT_THROW(inspect(scan, cad, s), std::invalid_argument);
  }
  s.tolerance = {-0.1, 0.1};
  s.pass_fraction = 0;
  EXPECT_THROW(inspect(scan, cad, s), std::invalid_argument);
  s.pass_fraction = 1;
  s.max_distance = -1;
  EXPECT_THROW(inspect(scan, cad, s), std::invalid_argument);
}

TEST(Inspect, OutlierDistanceFollowsTheBandAndThePart) {
  InspectSettings s;
  s.tolerance = {-0.05, 0.2};
  EXPECT_DOUBLE_EQ(outlier_distance(s, 10.0), 5 * 0.2);      // the band decides
  EXPECT_DOUBLE_EQ(outlier_distance(s, 500.0), 0.01 * 500);  // the part decides
  s.max_distance = 0.7;
  EXPECT_DOUBLE_EQ(outlier_distance(s, 500.0), 0.7);
}

}  // namespace
}  // namespace align3d
