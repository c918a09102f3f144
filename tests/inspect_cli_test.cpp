// `align3d inspect` and mesh targets of `align3d register`, run in-process on a generated part:
// the report's keys and values, the coloured PLY, the CSV files, the exit codes (9 for a part out
// of tolerance, after writing everything) and the usage and input errors.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::CliRun;
using test::read_text;
using test::run;

std::size_t lines(const std::string& text) { return std::count(text.begin(), text.end(), '\n'); }

class InspectCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir("inspect_cli");
    const CliRun r =
        run({"synth", (*dir_ / "part").string(), "--scene", "part", "--points", "40000"});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string path(const std::string& name) { return (*dir_ / "part" / name).string(); }
  static std::string out(const std::string& name) { return (*dir_ / name).string(); }
  static test::TempDir* dir_;
};
test::TempDir* InspectCli::dir_ = nullptr;

TEST_F(InspectCli, WritesTheReportAndEveryFileThenFailsThePartWithCode9) {
  const CliRun r = run({"inspect", path("scan.ply"), path("part.stl"), "--tolerance", "0.1",
                        "--report", out("r.json"), "--output", out("dev.ply"), "--csv",
                        out("pts.csv"), "--histogram", out("hist.csv")});
  EXPECT_EQ(r.code, static_cast<int>(ExitCode::kRejected)) << r.err;
  EXPECT_NE(r.out.find("verdict: FAIL"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(read_text(out("r.json")));
  EXPECT_EQ(j["verdict"], "fail");
  for (const char* key :
       {"count", "mean", "std", "rms", "min", "max", "p01", "p05", "p50", "p95", "p99"})
    EXPECT_TRUE(j["deviation"].contains(key)) << key;
  EXPECT_EQ(j["tolerance"]["lower"], -0.1);
  EXPECT_EQ(j["tolerance"]["upper"], 0.1);
  EXPECT_EQ(j["transformation"].size(), 4u);
  EXPECT_GT(j["outliers"].get<std::size_t>(), 0u);
  EXPECT_LT(j["within_tolerance"].get<double>(), 1.0);
  EXPECT_GT(j["within_tolerance"].get<double>(), 0.9);
  EXPECT_EQ(j["target"]["triangles"], 812);
  EXPECT_TRUE(j["mesh"]["closed"].get<bool>());
  EXPECT_TRUE(j["warnings"].empty());
  // The pose against the generator's truth.
  Eigen::Matrix4d T, G;
  std::ifstream truth(path("ground_truth.txt"));
  for (int i = 0; i < 16; ++i)
    truth >> G(i / 4, i % 4), T(i / 4, i % 4) = j["transformation"][i / 4][i % 4];
  EXPECT_LT((T.topRightCorner<3, 1>() - G.topRightCorner<3, 1>()).norm(), 0.02);

  const std::size_t points = j["source"]["points"];
  // The deviation PLY: every scan point, with the property and the colours.
  const std::string ply = read_text(out("dev.ply"));
  EXPECT_NE(ply.find("element vertex " + std::to_string(points)), std::string::npos);
  EXPECT_NE(ply.find("property float deviation"), std::string::npos);
  EXPECT_NE(ply.find("property uchar red"), std::string::npos);
  EXPECT_EQ(io::read_point_cloud(out("dev.ply")).size(), points);
  EXPECT_EQ(lines(read_text(out("pts.csv"))), points + 1);
  EXPECT_EQ(lines(read_text(out("hist.csv"))), 80u + 1);
}

TEST_F(InspectCli, APartWithinAWideBandPasses) {
  const CliRun r = run({"inspect", path("scan.ply"), path("part.stl"), "--tolerance", "-0.4,+0.4",
                        "--report", "-", "--quiet"});
  EXPECT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["verdict"], "pass");
  EXPECT_EQ(j["within_tolerance"], 1.0);
}

TEST_F(InspectCli, RegisterTakesAMeshAsItsTarget) {
  const CliRun r = run({"register", path("scan.ply"), path("part.stl"), "--report", "-"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["target"]["triangles"], 812);
  EXPECT_EQ(j["icp_direction"], "source onto target");
}

TEST_F(InspectCli, APpfModelOfTheMeshFeedsTheGlobalStage) {
  const CliRun m = run({"ppf-model", path("part.stl"), out("part.ppf")});
  ASSERT_EQ(m.code, 0) << m.err;
  const CliRun r =
      run({"register", path("scan.ply"), path("part.stl"), "--init", "global", "--ppf-model",
           out("part.ppf"), "--ground-truth", path("ground_truth.txt"), "--report", "-"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["global"]["method"], "ppf");
  EXPECT_LT(j["rotation_error_deg"].get<double>(), 0.02);
  EXPECT_LT(j["translation_error"].get<double>(), 0.02);
}

TEST_F(InspectCli, BadBandsAreUsageErrorsAndBadFilesInputErrors) {
  const std::string scan = path("scan.ply"), cad = path("part.stl");
  for (const char* band : {"0", "-0.1", "nan", "0.1,0.2", "-0.2,-0.1", "0.1,", "abc"}) {
    const CliRun r = run({"inspect", scan, cad, "--tolerance", band});
    EXPECT_EQ(r.code, static_cast<int>(ExitCode::kUsage)) << band;
    EXPECT_NE(r.err.find("--tolerance"), std::string::npos) << r.err;
  }
  EXPECT_EQ(run({"inspect", scan, cad}).code, static_cast<int>(ExitCode::kUsage));
  const CliRun missing = run({"inspect", scan, out("none.stl"), "--tolerance", "0.1"});
  EXPECT_EQ(missing.code, static_cast<int>(ExitCode::kInput));
  EXPECT_NE(missing.err.find("none.stl"), std::string::npos);
  const CliRun cloud = run({"inspect", scan, scan, "--tolerance", "0.1"});  // no faces
  EXPECT_EQ(cloud.code, static_cast<int>(ExitCode::kInput)) << cloud.err;
  EXPECT_NE(cloud.err.find("scan.ply"), std::string::npos);
  EXPECT_EQ(lines(cloud.err), 1u);
}

}  // namespace
}  // namespace align3d
