// The chapter's lessons, asserted on the generated scene (issue #3, "Done when").
#include "align3d/chapter.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "align3d/report/chapter_report.hpp"
#include "align3d/synth/scenes.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using report::chapter_table;
using report::write_chapter_report;

class Chapter : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new ChapterScene(generate_chapter_scene());
    results_ = new ChapterResults(run_chapter_experiments(*scene_));
  }
  static void TearDownTestSuite() {
    delete results_;
    delete scene_;
  }
  static ChapterScene* scene_;
  static ChapterResults* results_;
};
ChapterScene* Chapter::scene_ = nullptr;
ChapterResults* Chapter::results_ = nullptr;

constexpr double kSigma = 0.1;

TEST(ChapterScene, CountsAreExact) {
  const synth::Scene s = synth::make_conveyor_scene();
  EXPECT_EQ(s.model.size(), 5678u);
  EXPECT_EQ(s.scan.size(), 6497u);
  EXPECT_EQ(s.scan_corresponding, 4310u);
  EXPECT_EQ(s.scan_outliers, 2187u);
  // Ground truth: 12° about (1,2,2), and it maps the scan into the model frame.
  EXPECT_NEAR(rad_to_deg(rotation_angle(s.T_model_scan.linear())), 12.0, 1e-9);
  const Eigen::Isometry3d T_scan_model = s.T_model_scan.inverse();
  EXPECT_LT((T_scan_model.translation() - Eigen::Vector3d(5, -3, 2)).norm(), 1e-12);
  // The scan's first points are model points moved by the truth plus σ = 0.1 noise.
  double sq = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.scan_corresponding; ++i) {
    const Eigen::Vector3d back = s.T_model_scan * s.scan.positions[i];
    double best = 1e300;
    for (std::size_t k = 0; k < s.model.size(); k += 1)
      best = std::min(best, (back - s.model.positions[k]).squaredNorm());
    sq += best;
    ++n;
    if (n == 200) break;
  }
  EXPECT_LT(std::sqrt(sq / static_cast<double>(n)), 3 * kSigma);  // ~√3 σ for a 3D offset
}

TEST_F(Chapter, PointToPointFromIdentityLandsInTheBasinButAboveTheNoiseFloor) {
  EXPECT_LT(results_->p2p_good.rotation_error_deg, 3.0);
  EXPECT_GT(results_->p2p_good.result.refine.icp.rms, 3 * kSigma);
}

TEST_F(Chapter, PointToPlaneReachesTheNoiseFloorQuickly) {
  const IcpExperiment& e = results_->p2plane;
  EXPECT_LT(e.result.refine.icp.rms, 1.3 * kSigma);
  EXPECT_LE(e.result.refine.total_iterations, 15);
  EXPECT_LT(e.rotation_error_deg, 0.05);
  EXPECT_LT(e.translation_error, 0.02);
}

TEST_F(Chapter, BadInitialValueEndsInAWrongMinimum) {
  EXPECT_GT(results_->p2p_bad.rotation_error_deg, 10.0);
}

// The remedy (issue #4 target): from the same bad initial value, global registration +
// point-to-plane recovers the pose to the chapter's point-to-plane accuracy.
TEST_F(Chapter, GlobalRegistrationRemediesTheBadInitialValue) {
  ASSERT_TRUE(results_->global.result.global.has_value());
  EXPECT_TRUE(results_->global.result.global->success) << results_->global.result.global->message;
  EXPECT_LT(results_->global.rotation_error_deg, 0.05);
  EXPECT_LT(results_->global.translation_error, 0.02);
}

TEST_F(Chapter, RectificationLevelsThePlate) {
  EXPECT_NEAR(results_->plate.tilt_before_deg, 7.0, 0.05);
  EXPECT_LT(results_->plate.tilt_after_deg, 1e-3);
}

TEST_F(Chapter, RobustRectificationResistsClutterWhereThePlainFitDoesNot) {
  EXPECT_LT(results_->cluttered_robust_error_deg, 0.05);
  EXPECT_LT(results_->cluttered_robust.tilt_after_deg, 0.05);
  EXPECT_GT(results_->cluttered_plain_error_deg, 0.5);  // visibly worse
}

TEST_F(Chapter, ReportHasTheTableFiguresAndPage) {
  test::TempDir out("demo");
  write_chapter_report(*scene_, *results_, out.path());
  for (const char* f : {"table.md", "results.json", "report.html"})
    EXPECT_GT(std::filesystem::file_size(out / f), 100u) << f;
  for (int i = 1; i <= 6; ++i)
    for (const char* ext : {".svg", ".png"}) {
      const auto f = out / ("fig39_" + std::to_string(i) + ext);
      ASSERT_TRUE(std::filesystem::exists(f)) << f;
      EXPECT_GT(std::filesystem::file_size(f), 1000u) << f;
    }
  std::ifstream in(out / "report.html");
  const std::string html((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(html.find("http"), std::string::npos);  // opens with no network
  std::size_t images = 0;
  for (std::size_t at = 0; (at = html.find("data:image/png;base64,", at)) != std::string::npos;
       ++at)
    ++images;
  EXPECT_EQ(images, 6u);
  const std::string table = chapter_table(*results_);
  EXPECT_NE(table.find("| point-to-plane, identity init | RMS (mm) | 0.0991 |"), std::string::npos);
}

}  // namespace
}  // namespace align3d
