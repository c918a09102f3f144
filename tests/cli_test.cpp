// `align3d` run in-process: the register contract (issue #2), synth, rectify, and the bad-input
// classes with their exit codes, messages and no output left behind.
#include "align3d/cli.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "align3d/error.hpp"
#include "align3d/evaluate.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::CliRun;
using test::code;
using test::read_text;
using test::run;
using test::write_text;

// `align3d batch` runs the Python package's engine (its own tests: python/tests/test_batch.py); a
// Python that cannot be run is a usage error naming ALIGN3D_PYTHON, not a crash.
TEST(CliBatch, APythonThatCannotRunIsAUsageError) {
  ::setenv("ALIGN3D_PYTHON", "/nonexistent/python3", 1);
  const CliRun r = run({"batch", "pairs.csv", "--report-dir", "reports"});
  ::unsetenv("ALIGN3D_PYTHON");
  EXPECT_EQ(r.code, code(ExitCode::kUsage));
  EXPECT_NE(r.err.find("/nonexistent/python3"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("ALIGN3D_PYTHON"), std::string::npos) << r.err;
}

// One scene shared by the tests of this file (written once, read-only afterwards).
class Cli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir("cli");
    ASSERT_EQ(run({"synth", dir_->path().string()}).code, 0);
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string scene(const std::string& name) { return (*dir_ / name).string(); }
  static test::TempDir* dir_;
};
test::TempDir* Cli::dir_ = nullptr;

TEST_F(Cli, RegisterWritesTheReportAndTheAlignedCloud) {
  test::TempDir out("register");
  const CliRun r = run({"register", scene("scan.ply"), scene("model.ply"), "--ground-truth",
                        scene("ground_truth.txt"), "--report", (out / "r.json").string(),
                        "--output", (out / "aligned.ply").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("converged: yes"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(read_text(out / "r.json"));
  for (const char* key : {"transformation", "rotation_deg", "translation", "iterations",
                          "converged", "rms", "fitness", "correspondences", "history",
                          "stop_reason", "timing_ms", "rotation_error_deg", "translation_error"})
    EXPECT_TRUE(j.contains(key)) << key;
  ASSERT_EQ(j["transformation"].size(), 4u);
  for (const auto& row : j["transformation"]) EXPECT_EQ(row.size(), 4u);
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_FALSE(j.at("unconfirmed").get<bool>());  // the right pose, RMS at the noise
  EXPECT_LT(j["rotation_error_deg"].get<double>(), 0.05);
  EXPECT_LT(j["translation_error"].get<double>(), 0.02);
  EXPECT_NEAR(j["rotation_deg"].get<double>(), 12.0, 0.05);
  // Each stage evaluates its start pose, then once after every update.
  EXPECT_EQ(j["history"].size(), j["iterations"].get<std::size_t>() + j["stages"].size());
  for (const auto& h : j["history"]) {
    EXPECT_TRUE(h.contains("rms") && h.contains("kept") && h.contains("threshold"));
    EXPECT_LE(h["kept"].get<std::size_t>(), 6497u);
  }
  EXPECT_NEAR(j["fitness"].get<double>(), j["correspondences"].get<double>() / 6497.0, 1e-12);
  EXPECT_GT(j["timing_ms"]["total"].get<double>(), 0.0);
  // The model file has no normals: only those of the target points the pairs used are estimated.
  EXPECT_GT(j["normals"]["estimated"].get<std::size_t>(), 2000u);
  EXPECT_LT(j["normals"]["estimated"].get<std::size_t>(), 5678u);
  EXPECT_EQ(j["normals"]["undefined"].get<std::size_t>(), 0u);

  // The aligned cloud is the scan moved by the reported T (float32 storage: 1e-4 mm at 200 mm).
  Eigen::Matrix4d M;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 4; ++k) M(i, k) = j["transformation"][i][k].get<double>();
  const PointCloud scan = io::read_point_cloud(scene("scan.ply"));
  const PointCloud aligned = io::read_point_cloud(out / "aligned.ply");
  ASSERT_EQ(aligned.size(), scan.size());
  for (std::size_t i = 0; i < scan.size(); i += 97)
    EXPECT_LT((aligned.positions[i] - Eigen::Isometry3d(M) * scan.positions[i]).norm(), 1e-3);
}

TEST_F(Cli, ReportToStdoutIsPureJson) {
  const CliRun r = run({"register", scene("scan.ply"), scene("model.ply"), "--report", "-",
                        "--method", "point-to-point", "--reject", "median:2.5:0.5"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);  // throws if anything else was printed
  EXPECT_EQ(j["method"], "point-to-point");
  EXPECT_EQ(j["rejection"], "median:2.5:0.5");
}

TEST_F(Cli, InitFromAMatrixFile) {
  // Starting at the truth, point-to-plane stays there.
  const CliRun r =
      run({"register", scene("scan.ply"), scene("model.ply"), "--init", scene("ground_truth.txt"),
           "--ground-truth", scene("ground_truth.txt"), "--report", "-"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_LT(nlohmann::json::parse(r.out)["rotation_error_deg"].get<double>(), 0.05);
}

TEST_F(Cli, SynthWritesTheSameBytesForTheSameSeed) {
  test::TempDir again("synth");
  ASSERT_EQ(run({"synth", again.path().string()}).code, 0);
  for (const char* f : {"model.ply", "scan.ply", "ground_truth.txt", "plate.ply",
                        "plate_cluttered.ply", "scene.json"})
    EXPECT_EQ(read_text(again / f), read_text(scene(f))) << f;
  test::TempDir other("synth_other");
  ASSERT_EQ(run({"synth", other.path().string(), "--seed", "40"}).code, 0);
  EXPECT_NE(read_text(other / "scan.ply"), read_text(scene("scan.ply")));
}

TEST_F(Cli, RectifyReportsTheTilt) {
  const CliRun r = run({"rectify", scene("plate.ply"), "--report", "-"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key :
       {"normal", "tilt_before_deg", "tilt_after_deg", "inliers", "flatness", "transformation"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_NEAR(j["tilt_before_deg"].get<double>(), 7.0, 0.05);
  EXPECT_LT(j["tilt_after_deg"].get<double>(), 1e-3);
  EXPECT_GT(j["normal"][2].get<double>(), 0.0);
}

// A flat plate constrains only tilt and height: the report lists the three free directions (two
// translations in the plate, the turn about its normal), stderr warns, and the pose is not moved.
TEST_F(Cli, RegisterReportsTheDirectionsAPlateLeavesFree) {
  const CliRun r = run({"register", scene("plate.ply"), scene("plate.ply"), "--report", "-"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("does not constrain 3 direction(s)"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["degenerate_directions"].size(), 3u);
  for (const auto& w : j["degenerate_directions"]) EXPECT_LT(w["strength"].get<double>(), 0.01);
  EXPECT_LT(j["rotation_deg"].get<double>(), 1e-6);
  // The chapter scene is fully constrained: no free direction, no warning.
  const CliRun full = run({"register", scene("scan.ply"), scene("model.ply"), "--report", "-"});
  ASSERT_EQ(full.code, 0) << full.err;
  EXPECT_TRUE(nlohmann::json::parse(full.out)["degenerate_directions"].empty());
  EXPECT_EQ(full.err.find("does not constrain"), std::string::npos);
}

// --- bad input: one line naming the file, the documented exit code, nothing written -------------

struct BadCase {
  std::string name;
  int expected;
  std::string must_mention;
};

class CliBadInput : public Cli {
 protected:
  // Runs register with `source` and checks the error contract; an existing output must survive.
  void expect_failure(const std::vector<std::string>& args, int expected,
                      const std::string& mention) {
    test::TempDir out("bad");
    write_text(out / "aligned.ply", "previous good content");
    std::vector<std::string> full = args;
    full.insert(full.end(), {"--output", (out / "aligned.ply").string(), "--report",
                             (out / "r.json").string()});
    const CliRun r = run(full);
    EXPECT_EQ(r.code, expected) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(mention), std::string::npos) << r.err;
    EXPECT_EQ(read_text(out / "aligned.ply"), "previous good content");
    EXPECT_FALSE(std::filesystem::exists(out / "r.json"));
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(out.path())) ++files;
    EXPECT_EQ(files, 1u) << "a temporary file was left behind";
  }
};

TEST_F(CliBadInput, MissingFile) {
  expect_failure({"register", "/nonexistent/scan.ply", scene("model.ply")}, code(ExitCode::kInput),
                 "/nonexistent/scan.ply");
}

TEST_F(CliBadInput, UnknownExtension) {
  test::TempDir d("ext");
  write_text(d / "cloud.obj", "v 1 2 3\n");
  expect_failure({"register", (d / "cloud.obj").string(), scene("model.ply")},
                 code(ExitCode::kInput), "cloud.obj");
}

TEST_F(CliBadInput, TruncatedPly) {
  test::TempDir d("trunc");
  const std::string full = read_text(scene("scan.ply"));
  write_text(d / "cut.ply", full.substr(0, full.size() / 2));
  expect_failure({"register", (d / "cut.ply").string(), scene("model.ply")}, code(ExitCode::kInput),
                 "cut.ply");
}

TEST_F(CliBadInput, HeaderLiesAboutTheCount) {
  test::TempDir d("lie");
  write_text(d / "lie.ply",
             "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n"
             "property float y\nproperty float z\nend_header\n1 2 3\n");
  expect_failure({"register", (d / "lie.ply").string(), scene("model.ply")}, code(ExitCode::kInput),
                 "lie.ply");
}

TEST_F(CliBadInput, BadNumberInText) {
  test::TempDir d("num");
  write_text(d / "bad.xyz", "1 2 3\n4 five 6\n7 8 9\n");
  expect_failure({"register", (d / "bad.xyz").string(), scene("model.ply")}, code(ExitCode::kInput),
                 "bad.xyz");
}

TEST_F(CliBadInput, TooFewPoints) {
  test::TempDir d("few");
  write_text(d / "few.xyz", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n");
  expect_failure({"register", (d / "few.xyz").string(), scene("model.ply")}, code(ExitCode::kData),
                 "source");
}

TEST_F(CliBadInput, CollinearPoints) {
  test::TempDir d("line");
  std::string text;
  for (int i = 0; i < 50; ++i) text += std::to_string(i) + " " + std::to_string(2 * i) + " 1\n";
  write_text(d / "line.xyz", text);
  expect_failure({"register", scene("scan.ply"), (d / "line.xyz").string()}, code(ExitCode::kData),
                 "line");
}

TEST_F(CliBadInput, MalformedMatrix) {
  test::TempDir d("mat");
  write_text(d / "init.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  expect_failure(
      {"register", scene("scan.ply"), scene("model.ply"), "--init", (d / "init.txt").string()},
      code(ExitCode::kInput), "init.txt");
}

TEST_F(CliBadInput, WrongFlags) {
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--method", "plane"},
                 code(ExitCode::kUsage), "--method");
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--reject", "median:-1"},
                 code(ExitCode::kUsage), "FACTOR");
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--max-iterations", "0"},
                 code(ExitCode::kUsage), "max-iterations");
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--bogus"},
                 code(ExitCode::kUsage), "--bogus");
  expect_failure({"register", scene("scan.ply")}, code(ExitCode::kUsage), "TARGET");
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--kernel", "gm"},
                 code(ExitCode::kUsage), "--kernel");
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--kernel-scale", "1"},
                 code(ExitCode::kUsage), "needs a kernel");
  expect_failure({"register", scene("scan.ply"), scene("model.ply"), "--kernel", "huber",
                  "--kernel-scale", "nan"},
                 code(ExitCode::kUsage), "--kernel-scale");
  // find's flags of the same names (the scene is never read: the flags fail first)
  expect_failure({"find", scene("model.ply"), scene("scan.ply"), "--method", "plane"},
                 code(ExitCode::kUsage), "--method");
  expect_failure({"find", scene("model.ply"), scene("scan.ply"), "--kernel-scale", "1"},
                 code(ExitCode::kUsage), "needs a kernel");
}

// execute() is run() with the errors let through (the Python binding maps them): the same
// message, as an exception of the class whose exit code run() returns.
TEST_F(CliBadInput, ExecuteThrowsWhatRunReports) {
  std::ostringstream out, err;
  try {
    cli::execute({"register", scene("scan.ply"), "missing.ply"}, out, err);
    FAIL() << "no IoError";
  } catch (const IoError& e) {
    EXPECT_EQ(e.path(), "missing.ply");
    EXPECT_EQ(run({"register", scene("scan.ply"), "missing.ply"}).err,
              std::string("align3d: ") + e.what() + "\n");
  }
  try {
    cli::execute({"register", scene("scan.ply"), scene("model.ply"), "--method", "plane"}, out,
                 err);
    FAIL() << "no UsageError";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("(see align3d --help)"), std::string::npos);
  }
  EXPECT_THROW(cli::execute({}, out, err), UsageError);
  EXPECT_EQ(cli::execute({"--version"}, out, err), 0);
  EXPECT_EQ(err.str(), "");
}

TEST_F(CliBadInput, NoCorrespondencesIsNoSolution) {
  // distance:1e-6 mm admits no pair from the identity: exit 6, and no aligned cloud.
  test::TempDir out("nosol");
  const CliRun r = run({"register", scene("scan.ply"), scene("model.ply"), "--reject",
                        "distance:1e-6", "--output", (out / "aligned.ply").string()});
  EXPECT_EQ(r.code, code(ExitCode::kNoSolution)) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out / "aligned.ply"));
}

TEST_F(Cli, NonFinitePointsAreDroppedWithAWarning) {
  test::TempDir d("nan");
  const PointCloud scan = io::read_point_cloud(scene("scan.ply"));
  std::string text;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const auto& p = scan.positions[i];
    text +=
        std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + "\n";
    if (i % 1000 == 0) text += "nan 1 2\n1 inf 2\n";
  }
  write_text(d / "scan.xyz", text);
  const CliRun r = run({"register", (d / "scan.xyz").string(), scene("model.ply")});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("dropped 14 points"), std::string::npos) << r.err;
}

// --init global: any starting pose. The scan is turned by 150° first; the report carries the coarse
// stage and the refined pose is right.
TEST_F(Cli, GlobalInitFindsAPoseFromFarAway) {
  test::TempDir d("global");
  const PointCloud scan = io::read_point_cloud(scene("scan.ply"));
  Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
  P.linear() =
      Eigen::AngleAxisd(deg_to_rad(150), Eigen::Vector3d(1, -2, 0.5).normalized()).matrix();
  P.translation() = Eigen::Vector3d(40, -70, 25);
  io::write_ply(d / "turned.ply", transformed(scan, P));
  const Eigen::Isometry3d truth = io::read_matrix(scene("ground_truth.txt")) * P.inverse();
  io::write_matrix(d / "truth.txt", truth);
  for (const char* method : {"fpfh", "ppf"}) {
    const CliRun r =
        run({"register", (d / "turned.ply").string(), scene("model.ply"), "--init", "global",
             "--global", method, "--ground-truth", (d / "truth.txt").string(), "--report", "-"});
    ASSERT_EQ(r.code, 0) << method << ": " << r.err;
    const auto j = nlohmann::json::parse(r.out);
    ASSERT_TRUE(j.contains("global")) << method;
    EXPECT_TRUE(j["global"]["success"].get<bool>()) << method;
    EXPECT_EQ(j["global"]["method"], method);
    for (const char* key : {"time_ms", "score", "candidates", "transformation"})
      EXPECT_TRUE(j["global"].contains(key)) << key;
    EXPECT_LT(j["rotation_error_deg"].get<double>(), 0.05) << method;
    // translation_error depends on the frame (rotation error × lever arm); judge it as the issue
    // does, in the scan's own frame: T·P against the ground truth of the unturned scan.
    Eigen::Matrix4d M;
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 4; ++k) M(i, k) = j["transformation"][i][k].get<double>();
    const Eigen::Isometry3d unturned = Eigen::Isometry3d(M) * P;
    EXPECT_LT((unturned.translation() - (truth * P).translation()).norm(), 0.02) << method;
  }
}

// A model saved once gives the pose of a model built on the fly (here from the scan, the smaller
// cloud: the object), to rounding; it feeds the global stage of --init global or auto only.
TEST_F(Cli, SavedPpfModelGivesTheSamePose) {
  test::TempDir d("ppfmodel");
  ASSERT_EQ(run({"ppf-model", scene("model.ply"), (d / "model.ppf").string()}).code, 0);
  const CliRun a = run({"register", scene("scan.ply"), scene("model.ply"), "--init", "global",
                        "--global", "ppf", "--report", "-"});
  const CliRun b =
      run({"register", scene("scan.ply"), scene("model.ply"), "--init", "global", "--global", "ppf",
           "--ppf-model", (d / "model.ppf").string(), "--report", "-"});
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  const auto ja = nlohmann::json::parse(a.out), jb = nlohmann::json::parse(b.out);
  EXPECT_EQ(jb["global"]["object"], "target");  // the saved model describes the target
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR(ja["transformation"][i][k].get<double>(),
                  jb["transformation"][i][k].get<double>(), 1e-9);
  EXPECT_EQ(run({"register", scene("scan.ply"), scene("model.ply"), "--init", "identity",
                 "--ppf-model", (d / "model.ppf").string()})
                .code,
            code(ExitCode::kUsage));
  EXPECT_EQ(run({"register", scene("scan.ply"), scene("model.ply"), "--voxel", "3", "--ppf-model",
                 (d / "model.ppf").string()})
                .code,
            code(ExitCode::kUsage));
}

// Honest failure: a cloud that is not the model at all (sparse noise in a 1 m cube) gets no pose,
// exit 6, success false.
TEST_F(Cli, GlobalSaysSoWhenNothingMatches) {
  test::TempDir d("nomatch");
  std::string text;
  Random rng(5);
  for (int i = 0; i < 3000; ++i)
    text += std::to_string(rng.uniform(0, 1000)) + " " + std::to_string(rng.uniform(0, 1000)) +
            " " + std::to_string(rng.uniform(0, 1000)) + "\n";
  write_text(d / "noise.xyz", text);
  const CliRun r =
      run({"register", (d / "noise.xyz").string(), scene("model.ply"), "--init", "global",
           "--report", (d / "r.json").string(), "--output", (d / "out.ply").string()});
  EXPECT_EQ(r.code, code(ExitCode::kNoSolution)) << r.err;
  EXPECT_NE(r.err.find("noise.xyz"), std::string::npos) << r.err;
  EXPECT_FALSE(nlohmann::json::parse(read_text(d / "r.json"))["success"].get<bool>());
  EXPECT_FALSE(std::filesystem::exists(d / "out.ply"));
}

// The quick evaluation on two of the four built-in scenes (the animal's alone took 95 of the 120 s
// that all four took in CI's Release stage; python/tests/test_commands.py runs chapter, and the
// bracket's files as a directory of one's own): every method's row, the basin figures of those
// scenes only, and the outcome the README reports: from the random starts, the global stage and
// the default place the source at the truth every time on these scenes.
TEST(CliEvaluate, QuickRunWritesTheTableAndTheBasin) {
  test::TempDir d("evaluate");
  const CliRun r =
      run({"evaluate", d.path().string(), "--quick", "--scenes", "chapter,bumpy-sphere"});
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"evaluation.md", "evaluation.json", "basin_chapter.png",
                        "basin_chapter.svg", "basin_bumpy-sphere.png"})
    EXPECT_TRUE(std::filesystem::exists(d / f)) << f;
  for (const char* f : {"basin_bracket.png", "basin_animal.png"})
    EXPECT_FALSE(std::filesystem::exists(d / f)) << f;
  const auto j = nlohmann::json::parse(read_text(d / "evaluation.json"));
  ASSERT_EQ(j["success"].size(), 12u);  // 2 scenes × 6 methods
  EXPECT_EQ(j["basin"].size(), 12u);
  int checked = 0;
  for (const auto& row : j["success"]) {
    const std::string method = row["method"];
    if (method != to_string(EvalMethod::kGlobal) && method != to_string(EvalMethod::kAuto))
      continue;
    ++checked;
    EXPECT_GT(row["trials"].get<int>(), 0);
    EXPECT_EQ(row["successes"], row["trials"]) << row["scene"] << " " << method;
  }
  EXPECT_EQ(checked, 4);
}

// The scenes a peer runs on: each truth puts the source onto the target (brute-force nearest
// neighbours of a sample, outliers aside), and the chapter's is the one `synth` writes.
TEST(CliEvaluate, ScenesOnlyWritesEachSceneWithItsTruth) {
  test::TempDir d("evaluate_scenes");
  const CliRun r = run({"evaluate", d.path().string(), "--scenes-only"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(std::filesystem::exists(d / "evaluation.md"));  // measures nothing
  const auto j = nlohmann::json::parse(read_text(d / "evaluation.json"));
  ASSERT_EQ(j["scenes"].size(), 4u);
  for (const auto& scene : j["scenes"]) {
    const PointCloud source = io::read_point_cloud(d / scene["source"].get<std::string>());
    const PointCloud target = io::read_point_cloud(d / scene["target"].get<std::string>());
    const Eigen::Isometry3d T = io::read_matrix(d / scene["truth"].get<std::string>());
    const double L = bounding_box_diagonal(target);  // of the file: PLY stores float32
    EXPECT_NEAR(scene["diagonal"].get<double>(), L, 1e-6 * L);
    std::vector<double> nearest;
    for (std::size_t i = 0; i < source.size(); i += source.size() / 200) {
      const Eigen::Vector3d p = T * source.positions[i];
      double best = 1e300;
      for (const auto& q : target.positions) best = std::min(best, (q - p).norm());
      nearest.push_back(best);
    }
    std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
    EXPECT_LT(nearest[nearest.size() / 2], 0.01 * bounding_box_diagonal(target)) << scene["name"];
  }
  test::TempDir chapter("evaluate_chapter");
  ASSERT_EQ(run({"synth", chapter.path().string()}).code, 0);
  const Eigen::Isometry3d synth_truth = io::read_matrix(chapter / "ground_truth.txt");
  const Eigen::Isometry3d written = io::read_matrix(d / "scenes/chapter/truth.txt");
  EXPECT_TRUE(written.matrix().isApprox(synth_truth.matrix(), 1e-12));
}

// --scenes: a built-in scene by name (only its files are written), and a directory of one's own in
// --scenes-only's layout (the chapter's files, moved): only it is measured, and from the truth (the
// basin's 0°, 0 shift cell) the default registers it. Bad names and files get their exit codes.
TEST(CliEvaluate, ScenesPicksBuiltInOnesAndDirectoriesOfYourOwn) {
  test::TempDir d("evaluate_pick");
  ASSERT_EQ(run({"evaluate", (d / "files").string(), "--scenes-only", "--scenes", "chapter"}).code,
            0);
  const auto written = nlohmann::json::parse(read_text(d / "files/evaluation.json"));
  ASSERT_EQ(written["scenes"].size(), 1u);
  EXPECT_EQ(written["scenes"][0]["name"], "chapter");
  const std::filesystem::path mine = d / "mine";
  std::filesystem::rename(d / "files/scenes/chapter", mine);
  const CliRun r = run({"evaluate", (d / "eval").string(), "--quick", "--scenes", mine.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_text(d / "eval/evaluation.json"));
  ASSERT_EQ(j["success"].size(), 6u);  // 1 scene × 6 methods
  for (const auto& row : j["success"]) EXPECT_EQ(row["scene"], "mine");
  EXPECT_TRUE(std::filesystem::exists(d / "eval/basin_mine.png"));
  EXPECT_FALSE(std::filesystem::exists(d / "eval/basin_chapter.png"));
  const auto& cell = j["basin"][5];  // the default
  ASSERT_EQ(cell["method"], to_string(EvalMethod::kAuto));
  ASSERT_EQ(cell["angles_deg"][0].get<double>(), 0.0);
  ASSERT_EQ(cell["translation_fractions"][0].get<double>(), 0.0);
  EXPECT_EQ(cell["success"][0][0].get<double>(), 1.0);

  const CliRun unknown = run({"evaluate", (d / "x").string(), "--quick", "--scenes", "sphere"});
  EXPECT_EQ(unknown.code, code(ExitCode::kUsage));
  EXPECT_NE(unknown.err.find("'sphere'"), std::string::npos) << unknown.err;
  const CliRun twice =
      run({"evaluate", (d / "x").string(), "--quick", "--scenes", "chapter,chapter"});
  EXPECT_EQ(twice.code, code(ExitCode::kUsage));
  const CliRun empty = run({"evaluate", (d / "x").string(), "--quick", "--scenes", "chapter,"});
  EXPECT_EQ(empty.code, code(ExitCode::kUsage));
  // One value: OUTDIR after it is not taken for a scene.
  ASSERT_EQ(run({"evaluate", "--scenes", "chapter", (d / "y").string(), "--scenes-only"}).code, 0);
  EXPECT_TRUE(std::filesystem::exists(d / "y/scenes/chapter/truth.txt"));
  test::write_text(mine / "truth.txt", "1 0 0 0\n0 1 0\n");
  const CliRun truncated =
      run({"evaluate", (d / "x").string(), "--quick", "--scenes", mine.string()});
  EXPECT_EQ(truncated.code, code(ExitCode::kInput));
  EXPECT_NE(truncated.err.find("truth.txt"), std::string::npos) << truncated.err;
  std::filesystem::remove(mine / "target.ply");
  const CliRun missing =
      run({"evaluate", (d / "x").string(), "--quick", "--scenes", mine.string()});
  EXPECT_EQ(missing.code, code(ExitCode::kInput));
  EXPECT_NE(missing.err.find("no target.<ext>"), std::string::npos) << missing.err;
  test::write_text(mine / "target.xyz", "0 0 0\n1 1 1\n");
  const CliRun tiny = run({"evaluate", (d / "x").string(), "--quick", "--scenes", mine.string()});
  EXPECT_EQ(tiny.code, code(ExitCode::kData));
  EXPECT_NE(tiny.err.find("target.xyz (target)"), std::string::npos) << tiny.err;
  EXPECT_FALSE(std::filesystem::exists(d / "x"));  // nothing written
}

// ---- convert ----

struct CloudFile {
  std::string name, extension, encoding;  // encoding: the --encoding value, "" for text
  bool normals;                           // the format stores normals
  io::WriteSettings settings;             // the library's writer settings for the same file
};

std::vector<CloudFile> cloud_files() {
  const auto ply = [](io::PlyEncoding e) {
    io::WriteSettings s;
    s.ply = e;
    return s;
  };
  const auto pcd = [](io::PcdEncoding e) {
    io::WriteSettings s;
    s.pcd = e;
    return s;
  };
  return {{"ply_ascii", ".ply", "ascii", true, ply(io::PlyEncoding::kAscii)},
          {"ply_le", ".ply", "binary", true, ply(io::PlyEncoding::kBinaryLittleEndian)},
          {"ply_be", ".PLY", "binary_big_endian", true, ply(io::PlyEncoding::kBinaryBigEndian)},
          {"pcd_ascii", ".pcd", "ascii", true, pcd(io::PcdEncoding::kAscii)},
          {"pcd_binary", ".pcd", "binary", true, pcd(io::PcdEncoding::kBinary)},
          {"pcd_lzf", ".pcd", "binary_compressed", true, pcd(io::PcdEncoding::kBinaryCompressed)},
          {"xyz", ".xyz", "", false, {}},
          {"txt", ".txt", "", false, {}},
          {"csv", ".csv", "", false, {}}};
}

// What the writers store: float32 (through a volatile float: GCC 12 at -O3 folded the round trip
// away), or printf's %.9g in the C locale for text.
Eigen::Vector3d as_written(const Eigen::Vector3d& v, bool float32) {
  Eigen::Vector3d out;
  for (int k = 0; k < 3; ++k) {
    if (float32) {
      volatile float f = static_cast<float>(v[k]);
      out[k] = f;
    } else {
      char text[40];
      std::snprintf(text, sizeof text, "%.9g", v[k]);
      out[k] = std::strtod(text, nullptr);
    }
  }
  return out;
}

// Every source format and encoding into every target: the target holds the source's points as read
// by the library, as float32 or as %.9g text, and its normals when both formats store them.
TEST(CliConvert, RoundTripsBetweenEveryPairOfFormats) {
  test::TempDir d("convert");
  Random rng(11);
  PointCloud cloud;
  for (int i = 0; i < 200; ++i) {
    cloud.positions.emplace_back(rng.uniform(-500, 500), rng.uniform(-1, 1), rng.uniform(0, 1e4));
    cloud.normals.push_back(Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized());
  }
  const auto files = cloud_files();
  for (const CloudFile& from : files) {
    const auto source = d / ("source_" + from.name + from.extension);
    io::write_point_cloud(source, cloud, from.settings);
    const PointCloud original = io::read_point_cloud(source);
    for (const CloudFile& to : files) {
      SCOPED_TRACE(from.name + " -> " + to.name);
      const auto target = d / ("target_" + to.name + to.extension);
      std::vector<std::string> args = {"convert", source.string(), target.string()};
      if (!to.encoding.empty()) args.insert(args.end(), {"--encoding", to.encoding});
      const CliRun r = run(args);
      ASSERT_EQ(r.code, 0) << r.err;
      EXPECT_EQ(r.err.empty(), from.normals == to.normals || !from.normals) << r.err;
      const PointCloud read = io::read_point_cloud(target);
      ASSERT_EQ(read.size(), original.size());
      for (std::size_t i = 0; i < read.size(); ++i) {
        const Eigen::Vector3d& p = original.positions[i];
        ASSERT_EQ(read.positions[i], as_written(p, to.normals)) << "point " << i;
      }
      ASSERT_EQ(read.has_normals(), from.normals && to.normals);
      for (std::size_t i = 0; i < read.normals.size(); ++i) {
        ASSERT_LT((read.normals[i] - original.normals[i]).norm(), 1e-7) << "normal " << i;
      }
    }
  }
}

TEST(CliConvert, KeepsAPcdsViewpointAndWarnsAboutDroppedPoints) {
  test::TempDir d("convert_vp");
  write_text(d / "in.pcd",
             "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 2\n"
             "VIEWPOINT 1 2 3 0 1 0 0\nPOINTS 4\nDATA ascii\n1 2 3\nnan nan nan\n4 5 6\n7 inf 9\n");
  const CliRun r = run({"convert", (d / "in.pcd").string(), (d / "out.pcd").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: " + (d / "in.pcd").string() + ": dropped 2 points"),
            std::string::npos)
      << r.err;
  io::ReadInfo info;
  EXPECT_EQ(io::read_point_cloud(d / "out.pcd", &info).positions,
            (std::vector<Eigen::Vector3d>{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_EQ(info.viewpoint.position, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(info.viewpoint.orientation.coeffs(), Eigen::Vector4d(1, 0, 0, 0));
  EXPECT_EQ(info.height, 1u);  // the NaN points are gone: no longer organized
}

TEST(CliConvert, HelpExplainsTheFormatsAndEncodings) {
  const CliRun help = run({"convert", "--help"});
  EXPECT_EQ(help.code, 0);
  for (const char* word : {"binary_compressed", "binary_big_endian", ".xyz", "Normals", "NaN"}) {
    EXPECT_NE(help.out.find(word), std::string::npos) << word;
  }
}

// Each failure: its exit code, one line naming the culprit, and no file at the destination (an
// existing one untouched, no temporary left).
class CliConvertError : public ::testing::Test {
 protected:
  void SetUp() override {
    write_text(d_ / "in.ply",
               "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
               "property float y\nproperty float z\nend_header\n1 2 3\n");
    write_text(d_ / "old.pcd", "previous content");
  }
  void expect_error(const std::string& in, const std::string& out,
                    const std::vector<std::string>& flags, ExitCode expected,
                    const std::string& mention) {
    std::vector<std::string> args = {"convert", in, out};
    args.insert(args.end(), flags.begin(), flags.end());
    const CliRun r = run(args);
    EXPECT_EQ(r.code, code(expected)) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(mention), std::string::npos) << r.err;
    EXPECT_EQ(read_text(d_ / "old.pcd"), "previous content");
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(d_.path())) ++files;
    EXPECT_EQ(files, expected_files_) << "a file was written or left behind";
  }
  test::TempDir d_{"convert_error"};
  std::size_t expected_files_ = 2;
};

TEST_F(CliConvertError, UnknownExtensions) {
  write_text(d_ / "in.3ds", "v 1 2 3\n");
  expected_files_ = 3;
  expect_error((d_ / "in.3ds").string(), (d_ / "out.ply").string(), {}, ExitCode::kInput,
               "in.3ds: unknown format '.3ds'");
  write_text(d_ / "in.obj", "v 1 2 3\n");  // read as a mesh: vertices but no face
  expected_files_ = 4;
  expect_error((d_ / "in.obj").string(), (d_ / "out.ply").string(), {}, ExitCode::kInput,
               "in.obj: contains no triangles");
  expect_error((d_ / "in.ply").string(), (d_ / "out.obj").string(), {}, ExitCode::kOutput,
               "out.obj: cannot write: unknown point cloud format");
}

TEST_F(CliConvertError, EncodingsTheFormatLacks) {
  const std::string in = (d_ / "in.ply").string();
  expect_error(in, (d_ / "out.pcd").string(), {"--encoding", "binary_big_endian"}, ExitCode::kUsage,
               "--encoding: PCD has no encoding 'binary_big_endian'");
  expect_error(in, (d_ / "out.ply").string(), {"--encoding", "binary_compressed"}, ExitCode::kUsage,
               "--encoding: PLY has no encoding 'binary_compressed'");
  expect_error(in, (d_ / "out.csv").string(), {"--encoding", "ascii"}, ExitCode::kUsage,
               "--encoding: .xyz, .txt and .csv files are text");
}

TEST_F(CliConvertError, UnreadableInputWritesNothing) {
  expect_error((d_ / "missing.ply").string(), (d_ / "old.pcd").string(), {}, ExitCode::kInput,
               "missing.ply: file not found");
  std::filesystem::create_directory(d_ / "folder.xyz");
  expected_files_ = 3;
  expect_error((d_ / "folder.xyz").string(), (d_ / "old.pcd").string(), {}, ExitCode::kInput,
               "folder.xyz: not a regular file");
  write_text(d_ / "cut.ply",
             "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
             "property float x\nproperty float y\nproperty float z\nend_header\n" +
                 std::string(20, '\0'));
  expected_files_ = 4;
  expect_error((d_ / "cut.ply").string(), (d_ / "old.pcd").string(), {}, ExitCode::kInput,
               "cut.ply: element 'vertex' announces 2 records of 12 bytes");
}

TEST_F(CliConvertError, UnwritableOutputLeavesNothing) {
  const std::string in = (d_ / "in.ply").string();
  expect_error(in, (d_ / "no_such_folder" / "out.ply").string(), {}, ExitCode::kOutput,
               "out.ply: cannot write");
  std::filesystem::create_directory(d_ / "taken.xyz");  // a folder where the file should go
  expected_files_ = 3;
  expect_error(in, (d_ / "taken.xyz").string(), {}, ExitCode::kOutput, "taken.xyz: cannot write");
  EXPECT_TRUE(std::filesystem::is_empty(d_ / "taken.xyz"));
}

// ---- vector and number flags ----

TEST_F(CliBadInput, VectorAndNumberFlags) {
  const auto rectify = [&](const std::string& up) {
    return run({"rectify", scene("plate.ply"), "--up", up});
  };
  for (const char* up :
       {"0,0,0", "-0,0,0", "0,0,1,", "1,2", "1,,2", "0,0,nan", "0,0,1e999", "a,b,c", "1;2;3", ""}) {
    const CliRun r = rectify(up);
    EXPECT_EQ(r.code, code(ExitCode::kUsage)) << up << ": " << r.err;
    EXPECT_NE(r.err.find("--up"), std::string::npos) << r.err;
  }
  // Any non-zero length is a direction, however small; spaces around numbers are fine.
  for (const char* up : {"0, 0, 1e-320", "+0,0,2.5"}) {
    const CliRun r = rectify(up);
    EXPECT_EQ(r.code, 0) << up << ": " << r.err;
    EXPECT_NE(r.out.find("tilt 7.00"), std::string::npos) << r.out;
  }
  // The plate seen from below: up = -Z turns it over (the tilt is measured from +Z).
  const CliRun down = rectify("0,0,-1");
  EXPECT_EQ(down.code, 0) << down.err;
  EXPECT_NE(down.out.find("tilt 172.99"), std::string::npos) << down.out;  // 180 - 7.00

  // Seeds are unsigned: CLI11 alone would take -1 as 2^64 - 1.
  test::TempDir d("voxel");
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"rectify", scene("plate.ply"), "--robust", "--seed", "-1"},
           {"synth", (d / "scene").string(), "--seed", "-2"}}) {
    const CliRun r = run(args);
    EXPECT_EQ(r.code, code(ExitCode::kUsage)) << args[0] << ": " << r.err;
    EXPECT_NE(r.err.find("--seed"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(std::filesystem::exists(d / "scene"));
  for (const char* voxel : {"nan", "inf", "-1", "1e-300"}) {
    const CliRun r =
        run({"ppf-model", scene("model.ply"), (d / "m.ppf").string(), "--voxel", voxel});
    EXPECT_EQ(r.code, code(ExitCode::kUsage)) << voxel << ": " << r.err;
    EXPECT_NE(r.err.find("--voxel"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(d / "m.ppf"));
  }
}

TEST(CliHelp, HelpAndVersionSucceed) {
  EXPECT_EQ(run({"--help"}).code, 0);
  const CliRun help = run({"register", "--help"});
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("--reject"), std::string::npos);
  EXPECT_EQ(run({"--version"}).code, 0);
  EXPECT_EQ(run({}).code, code(ExitCode::kUsage));
}

// Distance of an object-frame point to the test object's surface (the parts' own distances).
double test_object_distance(const Eigen::Vector3d& p) {
  double d = synth::kInfinity;
  for (const synth::Shape& s : synth::test_object_shapes())
    d = std::min(d, synth::surface_distance(s, p));
  return d;
}

Eigen::Isometry3d json_matrix(const nlohmann::json& j) {
  Eigen::Matrix4d M;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 4; ++k) M(i, k) = j[i][k].get<double>();
  return Eigen::Isometry3d(M);
}

// The bin scene read back: an organized 640 × 480 PCD with its NaN, whose labelled pixels the
// instance files map onto the part's mesh (float32 storage adds ~1e-4 mm at 1 m).
TEST(CliSynth, BinSceneReadsBackOrganizedWithItsGroundTruth) {
  test::TempDir d("synth_bin");
  const CliRun r = run({"synth", "--scene", "bin", d.path().string(), "--instances", "3"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_text(d / "scene.json"));
  const std::string pcd = read_text(d / "scene.pcd");
  const std::string layout =
      "WIDTH 640\nHEIGHT 480\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 307200\nDATA binary\n";
  const std::size_t data = pcd.find(layout);
  ASSERT_NE(data, std::string::npos);
  ASSERT_EQ(pcd.size(), data + layout.size() + 307200 * 12);
  io::ReadInfo info;
  const PointCloud cloud = io::read_point_cloud(d / "scene.pcd", &info);
  EXPECT_EQ(cloud.size() + info.dropped_non_finite, 307200u);
  EXPECT_EQ(cloud.size(), j["cloud"]["valid_points"].get<std::size_t>());
  EXPECT_GT(info.dropped_non_finite, 3000u);  // at least the 1 % dropout
  const MeshIndex model(io::read_mesh(d / "model.stl"));
  EXPECT_EQ(j["model"]["part"], "bracket");
  EXPECT_EQ(j["model"]["triangles"].get<std::size_t>(), model.mesh().triangles.size());

  const std::string labels = read_text(d / "instances.pgm");
  ASSERT_EQ(labels.substr(0, 15), "P5\n640 480\n255\n");
  ASSERT_EQ(labels.size(), 15 + 307200u);
  ASSERT_EQ(j["instances"].size(), 3u);
  const synth::DepthSensorSettings sensor;
  for (int k = 0; k < 3; ++k) {
    const auto& inst = j["instances"][static_cast<std::size_t>(k)];
    const Eigen::Isometry3d T = io::read_matrix(d / inst["file"].get<std::string>());
    EXPECT_TRUE(T.isApprox(json_matrix(inst["transformation"]), 1e-12));
    std::size_t pixels = 0;
    for (std::size_t i = 0; i < 307200; ++i) {
      if (static_cast<unsigned char>(labels[15 + i]) != k + 1) continue;
      ++pixels;
      float xyz[3];
      std::memcpy(xyz, pcd.data() + data + layout.size() + 12 * i, 12);  // little-endian host
      const Eigen::Vector3d p(xyz[0], xyz[1], xyz[2]);
      ASSERT_TRUE(p.allFinite());
      SurfacePoint c;
      ASSERT_TRUE(model.closest(T.inverse() * p, c));
      ASSERT_LT(std::sqrt(c.sq_distance), 6 * sensor.sigma(p.z()) + 1e-3);
    }
    EXPECT_EQ(pixels, inst["pixels"].get<std::size_t>());
    const double visible = inst["visible_fraction"].get<double>();
    EXPECT_TRUE(visible >= 0 && visible <= 1) << visible;
    if (visible > 0.5) {
      EXPECT_GT(pixels, 1000u);
    }
  }
  // The bin's inside bottom in the camera frame: the camera 1000 mm above the floor, 12 mm below.
  const Eigen::Vector3d n(j["floor"]["normal"][0], j["floor"]["normal"][1],
                          j["floor"]["normal"][2]);
  const Eigen::Vector3d q(j["floor"]["point"][0], j["floor"]["point"][1], j["floor"]["point"][2]);
  EXPECT_NEAR(n.dot(-q), 988, 1e-9);

  test::TempDir again("synth_bin_again");
  ASSERT_EQ(run({"synth", "--scene", "bin", again.path().string(), "--instances", "3"}).code, 0);
  for (const char* f : {"scene.pcd", "model.stl", "instance_0.txt", "instance_1.txt",
                        "instances.pgm", "scene.json"})
    EXPECT_EQ(read_text(again / f), read_text(d / f)) << f;
}

// A bin with no part in it (the plate's, among distractors): `align3d find` exits with 0, says
// so, and its report lists no instance (issue 16: an empty result is an answer, not an error).
TEST(CliFind, AnEmptyBinIsExitCodeZeroAndAnEmptyList) {
  test::TempDir d("find_empty");
  ASSERT_EQ(run({"synth", "--scene", "bin", d.path().string(), "--part", "plate", "--instances",
                 "0", "--distractors", "4"})
                .code,
            0);
  const CliRun r = run({"find", (d / "model.stl").string(), (d / "scene.pcd").string(), "--report",
                        (d / "found.json").string(), "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("found 0 instance"), std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(read_text(d / "found.json"));
  EXPECT_TRUE(j["instances"].is_array());
  EXPECT_TRUE(j["instances"].empty());
}

TEST(CliSynth, ViewsWritePosesAndPairsThatAgree) {
  test::TempDir d("synth_views");
  const CliRun r =
      run({"synth", "--scene", "views", d.path().string(), "--angle", "90", "--views", "3"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(read_text(d / "scene.json"));
  ASSERT_EQ(j["views"].size(), 3u);
  ASSERT_EQ(j["pairs"].size(), 2u);
  const Eigen::Isometry3d T0 = io::read_matrix(d / "view_0.txt");
  const synth::DepthSensorSettings scanner = synth::ObjectViewsSettings{}.sensor;
  for (int k = 1; k < 3; ++k) {
    const std::string view = "view_" + std::to_string(k);
    EXPECT_DOUBLE_EQ(j["views"][static_cast<std::size_t>(k)]["azimuth_deg"].get<double>(),
                     30 + 90 * k);
    const Eigen::Isometry3d Tk = io::read_matrix(d / (view + ".txt"));
    const Eigen::Isometry3d pair = io::read_matrix(d / ("pair_0_" + std::to_string(k) + ".txt"));
    EXPECT_TRUE(pair.isApprox(T0 * Tk.inverse(), 1e-12));  // view_0 ≈ pair·view_k
    const PointCloud cloud = io::read_point_cloud(d / (view + ".pcd"));
    EXPECT_GT(cloud.size(), 10000u);
    for (const auto& p : cloud.positions)
      ASSERT_LT(test_object_distance(Tk.inverse() * p), 6 * scanner.sigma(p.z()) + 1e-3);
  }
}

}  // namespace
}  // namespace align3d

namespace align3d {
namespace {

// The report always holds the pipeline's account: which answer was kept, its support, warnings
// (an empty list when clean).
TEST_F(Cli, CleanRegistrationReportsItsSupportAndNoWarnings) {
  const CliRun r = run({"register", scene("scan.ply"), scene("model.ply"), "--report", "-"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j["warnings"].is_array());
  EXPECT_TRUE(j["warnings"].empty()) << j["warnings"];
  EXPECT_EQ(j["init"]["policy"], "auto");
  EXPECT_EQ(j["init"]["path"], "initial");
  EXPECT_EQ(j["init"]["candidates"].size(), 1u);
  for (const char* key : {"overlap", "object", "noise", "spacing", "structured", "reach", "band"})
    EXPECT_TRUE(j["support"].contains(key)) << key;
  for (const char* key : {"ratio", "rms", "expected", "structured", "pairs"})
    EXPECT_TRUE(j["fit"].contains(key)) << key;
  EXPECT_LT(j["fit"]["ratio"].get<double>(), kConfirmedFit);  // the right pose fits at the noise
  EXPECT_GT(j["support"]["overlap"].get<double>(), 0.6);
}

// The chapter's point-to-point ICP stops at its iteration cap, still creeping, 0.7° off: warnings
// on stderr and in the report, exit 0; --strict makes them exit 7, outputs written all the same.
TEST_F(Cli, WarningsAreReportedAndStrictMakesThemAnExitCode) {
  test::TempDir out("strict");
  const std::vector<std::string> chapter = {"register",
                                            scene("scan.ply"),
                                            scene("model.ply"),
                                            "--init",
                                            "identity",
                                            "--method",
                                            "point-to-point",
                                            "--reject",
                                            "median:2.5:0.5",
                                            "--output",
                                            (out / "aligned.ply").string()};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = chapter;
    args.insert(args.end(), extra.begin(), extra.end());
    return run(args);
  };
  const CliRun lenient = with({"--report", (out / "r.json").string()});
  EXPECT_EQ(lenient.code, 0) << lenient.err;
  EXPECT_NE(lenient.err.find("align3d: warning: ICP did not converge"), std::string::npos)
      << lenient.err;
  const auto j = nlohmann::json::parse(read_text(out / "r.json"));
  std::vector<std::string> codes;
  for (const auto& w : j["warnings"]) codes.push_back(w["code"]);
  EXPECT_NE(std::find(codes.begin(), codes.end(), "not_converged"), codes.end()) << j["warnings"];
  EXPECT_NE(std::find(codes.begin(), codes.end(), "stopped_short"), codes.end()) << j["warnings"];
  std::filesystem::remove(out / "aligned.ply");
  const CliRun strict = with({"--strict"});
  EXPECT_EQ(strict.code, code(ExitCode::kWarnings)) << strict.err;
  EXPECT_TRUE(std::filesystem::exists(out / "aligned.ply"));
}

// Errors on the global path name the file at fault, whatever stage raises them.
TEST_F(Cli, GlobalPathErrorsNameTheFile) {
  test::TempDir d("eight");
  std::string text;
  for (int i = 0; i < 8; ++i)
    text +=
        std::to_string(i) + " " + std::to_string(i * i % 5) + " " + std::to_string(i % 3) + "\n";
  write_text(d / "eight.xyz", text);
  const CliRun r =
      run({"register", (d / "eight.xyz").string(), scene("model.ply"), "--init", "global"});
  EXPECT_EQ(r.code, code(ExitCode::kData)) << r.err;
  EXPECT_NE(r.err.find("eight.xyz (source): 8 points"), std::string::npos) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// A depth camera's view of a bin (floor tilted 4° to the camera, walls, parts, NaN holes): the
// default (robust) fit levels the floor; a least-squares fit through everything is off and says
// so, and --strict makes that an exit code.
TEST_F(Cli, RectifyFindsTheFloorOfABinAndWarnsAboutAPlainFit) {
  test::TempDir d("bin");
  ASSERT_EQ(run({"synth", "--scene", "bin", d.path().string()}).code, 0);
  const auto meta = nlohmann::json::parse(read_text(d / "scene.json"));
  Eigen::Vector3d floor;
  for (int k = 0; k < 3; ++k) floor(k) = meta["floor"]["normal"][k].get<double>();
  const auto fitted_error_deg = [&](const nlohmann::json& report) {
    Eigen::Vector3d n;
    for (int k = 0; k < 3; ++k) n(k) = report["normal"][k].get<double>();
    return rad_to_deg(std::acos(std::min(1.0, std::abs(n.dot(floor)))));
  };
  const CliRun robust = run({"rectify", (d / "scene.pcd").string(), "--report", "-"});
  ASSERT_EQ(robust.code, 0) << robust.err;
  const auto rj = nlohmann::json::parse(robust.out);
  EXPECT_LT(fitted_error_deg(rj), 0.2);
  EXPECT_TRUE(rj["warnings"].empty()) << rj["warnings"];
  const CliRun plain =
      run({"rectify", (d / "scene.pcd").string(), "--fit", "lsq", "--report", "-"});
  ASSERT_EQ(plain.code, 0) << plain.err;
  const auto pj = nlohmann::json::parse(plain.out);
  EXPECT_GT(fitted_error_deg(pj), 1.0);
  ASSERT_EQ(pj["warnings"].size(), 1u);
  EXPECT_EQ(pj["warnings"][0]["code"], "not_flat");
  EXPECT_NE(plain.err.find("align3d: warning: "), std::string::npos);
  EXPECT_EQ(run({"rectify", (d / "scene.pcd").string(), "--fit", "lsq", "--strict"}).code,
            code(ExitCode::kWarnings));
}

}  // namespace
}  // namespace align3d
