// `align3d stitch` (src/cli/stitch_command.cpp) and what it writes: the command line's errors and
// their exit codes; the report (report::stitch_report), the merged PLY and the page on a hand-made
// result; and, on generated scans of an object with known poses (`align3d synth --scene stitch`),
// the whole command.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/report/json.hpp"
#include "align3d/report/stitch_files.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

namespace fs = std::filesystem;
using test::CliRun;
using test::code;
using test::read_text;
using test::run;
using test::write_text;

bool mentions(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

// A small cloud file that reads (the errors below come before any stitching).
std::string cloud_file(const test::TempDir& d, const std::string& name) {
  PointCloud c;
  for (int i = 0; i < 50; ++i) c.positions.emplace_back(i % 7, i / 7, 0.1 * (i % 3));
  io::write_point_cloud(d / name, c);
  return (d / name).string();
}

TEST(StitchCli, FewerThanTwoScansIsAUsageError) {
  test::TempDir d("stitch_cli");
  const std::string a = cloud_file(d, "a.ply");
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"stitch"}, {"stitch", a}, {"stitch", a, "--report", "-"}}) {
    const CliRun r = run(args);
    EXPECT_EQ(r.code, code(ExitCode::kUsage)) << r.err;
    EXPECT_TRUE(mentions(r.err, "at least two scans")) << r.err;
  }
  // A list of comments and blank lines adds nothing.
  write_text(d / "list.txt", "# scans\n\n   \n# none yet\n");
  const CliRun r = run({"stitch", a, "--list", (d / "list.txt").string()});
  EXPECT_EQ(r.code, code(ExitCode::kUsage)) << r.err;
  EXPECT_TRUE(mentions(r.err, "got 1")) << r.err;
}

TEST(StitchCli, BadFlagsAreUsageErrors) {
  test::TempDir d("stitch_cli");
  const std::string a = cloud_file(d, "a.ply"), b = cloud_file(d, "b.ply");
  for (const std::vector<std::string>& extra : {std::vector<std::string>{"--no-such-flag"},
                                                {"--min-overlap", "0"},
                                                {"--min-overlap", "1.5"},
                                                {"--voxel", "-1"},
                                                {"--voxel", "nan"},
                                                {"--threads", "-2"},
                                                {"--method", "plane"},
                                                {"--kernel", "bisquare"},
                                                {"--kernel-scale", "-1"},
                                                {"--kernel-scale", "2"}}) {  // with kernel auto
    std::vector<std::string> args = {"stitch", a, b};
    args.insert(args.end(), extra.begin(), extra.end());
    const CliRun r = run(args);
    EXPECT_EQ(r.code, code(ExitCode::kUsage)) << extra[0] << ": " << r.err;
  }
}

TEST(StitchCli, AMissingScanIsAnInputErrorNamingIt) {
  test::TempDir d("stitch_cli");
  const std::string a = cloud_file(d, "a.ply");
  const std::string missing = (d / "nowhere.pcd").string();
  const CliRun r = run({"stitch", a, missing, "--report", (d / "r.json").string(), "--output",
                        (d / "m.ply").string()});
  EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
  EXPECT_TRUE(mentions(r.err, missing)) << r.err;
  EXPECT_FALSE(fs::exists(d / "r.json"));
  EXPECT_FALSE(fs::exists(d / "m.ply"));
}

TEST(StitchCli, AListNamesScansRelativeToItsFolder) {
  test::TempDir d("stitch_cli");
  fs::create_directories(d / "scans");
  cloud_file(d, "scans/a.ply");
  // The list's second entry is relative to the list's folder, not to the working directory; it
  // is missing, so the error shows how it was resolved.
  write_text(d / "scans" / "list.txt", "# turntable\r\n  a.ply  \r\n\r\nb.ply\r\n");
  const CliRun r = run({"stitch", "--list", (d / "scans" / "list.txt").string()});
  EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
  EXPECT_TRUE(mentions(r.err, (d / "scans" / "b.ply").string())) << r.err;
}

TEST(StitchCli, AListThatCannotBeReadIsAnInputErrorNamingIt) {
  test::TempDir d("stitch_cli");
  const std::string a = cloud_file(d, "a.ply");
  const std::string list = (d / "list.txt").string();
  write_text(list, std::string("a.ply\nb\0c.ply\n", 14));
  CliRun r = run({"stitch", a, "--list", list});
  EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
  EXPECT_TRUE(mentions(r.err, list + ": line 2")) << r.err;
  write_text(list, "a.ply\n" + std::string(5000, 'x') + "\n");
  r = run({"stitch", a, "--list", list});
  EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
  EXPECT_TRUE(mentions(r.err, list + ": line 2")) << r.err;
  for (const fs::path& bad : {d / "missing.txt", d.path()}) {
    r = run({"stitch", a, "--list", bad.string()});
    EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
    EXPECT_TRUE(mentions(r.err, bad.string())) << r.err;
  }
}

TEST(StitchCli, HelpExplainsTheConventionsAndTheExitCodes) {
  const CliRun r = run({"stitch", "--help"});
  ASSERT_EQ(r.code, 0);
  for (const char* text : {"first scan's frame", "VIEWPOINT", "10 some scans", "--list",
                           "--no-scan-index", "--figure", "--html"})
    EXPECT_TRUE(mentions(r.out, text)) << text;
  EXPECT_TRUE(mentions(run({"--help"}).out, "10 some scans overlap no other"));
}

// Three scans: 0 and 1 joined by a kept edge, 2 joined only by a pruned one (not connected).
StitchResult made_up_result() {
  StitchResult r;
  r.scans.resize(3);
  for (std::size_t k = 0; k < 3; ++k) {
    StitchScan& s = r.scans[k];
    s.points = 100 * (k + 1);
    s.connected = k < 2;
    s.edges = k < 2 ? 1 : 0;
    s.pairs = k < 2 ? 80 : 0;
    s.rms = k < 2 ? 0.01 * (k + 1) : std::numeric_limits<double>::quiet_NaN();
    s.median = s.rms / 2, s.p95 = 2 * s.rms;
  }
  r.scans[1].transformation =
      Eigen::Translation3d(1, 2, 3) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ());
  StitchEdge kept;
  kept.source = 0, kept.target = 1, kept.kept = true, kept.overlap = 0.6, kept.rms = 0.02;
  kept.transformation = r.scans[1].transformation.inverse();
  kept.information = Matrix6d::Identity() * 4;
  kept.information(0, 5) = kept.information(5, 0) = 0.5;
  StitchEdge pruned = kept;
  pruned.source = 1, pruned.target = 2, pruned.kept = false, pruned.status = "pruned";
  pruned.rotation_residual_deg = 3.5, pruned.translation_residual = 0.7;
  pruned.warnings = {{"high_rms", "the ICP RMS is high"}};
  r.edges = {kept, pruned};
  for (int i = 0; i < 20; ++i) {
    r.merged.positions.emplace_back(i, 0, 0);
    r.merged.normals.emplace_back(0, 0, 1);
    r.merged_scan.push_back(i < 10 ? 0 : 1);
  }
  r.voxel = 0.5, r.diameter = 20, r.multiview_iterations = 7;
  r.warnings = {{"unconnected_scan", "c.ply overlaps no other scan"},
                {"pruned_edge", "edge 1-2 disagrees with the graph"},
                {"single_edge_scan", "scan 1 is held by one edge only"}};
  r.scans[1].warnings = {"single_edge_scan"};
  r.scans[1].viewpoint = {0.5, 0, 2};
  r.scans[1].sensor = SensorSource::kEstimated;
  r.scans[2].warnings = {"unconnected_scan"};
  r.timings = {1, 2, 3, 4, 5, 15};
  return r;
}

const std::vector<report::InputInfo> kInputs = {{"a.ply", 100, 0}, {"b.pcd", 200, 0}, {"", 300, 0}};

TEST(StitchReport, HasEveryKeyInItsShape) {
  StitchSettings s;
  s.viewpoints = {std::nullopt, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 0, 5)};
  // Through text, as a reader sees it: NaN becomes null.
  const auto j = nlohmann::json::parse(
      report::stitch_report(made_up_result(), s, kInputs, "merged.ply", true).dump());
  for (const char* key : {"poses", "edges", "merged", "diameter", "multiview_iterations",
                          "warnings", "timings", "settings"})
    EXPECT_TRUE(j.contains(key)) << key;
  ASSERT_EQ(j["poses"].size(), 3u);
  for (const auto& p : j["poses"]) {
    for (const char* key :
         {"file", "transformation", "connected", "points", "edges", "sensor", "residual"})
      EXPECT_TRUE(p.contains(key)) << key;
    EXPECT_EQ(p["sensor"]["position"].size(), 3u);
    ASSERT_EQ(p["transformation"].size(), 4u);
    for (const auto& row : p["transformation"]) EXPECT_EQ(row.size(), 4u);
    for (const char* key : {"pairs", "rms", "median", "p95"})
      EXPECT_TRUE(p["residual"].contains(key)) << key;
  }
  EXPECT_EQ(j["poses"][1]["file"], "b.pcd");
  EXPECT_EQ(j["poses"][2]["file"], "");
  EXPECT_DOUBLE_EQ(j["poses"][1]["transformation"][0][3].get<double>(), 1.0);
  EXPECT_FALSE(j["poses"][2]["connected"].get<bool>());
  EXPECT_TRUE(j["poses"][2]["residual"]["rms"].is_null());
  ASSERT_EQ(j["edges"].size(), 2u);
  for (const auto& e : j["edges"]) {
    for (const char* key :
         {"source", "target", "source_file", "target_file", "transformation", "overlap", "rms",
          "pairs", "free_space", "kept", "status", "rotation_residual_deg", "translation_residual",
          "information", "warnings"})
      EXPECT_TRUE(e.contains(key)) << key;
    ASSERT_EQ(e["information"].size(), 6u);
    for (const auto& row : e["information"]) EXPECT_EQ(row.size(), 6u);
  }
  EXPECT_EQ(j["edges"][0]["target_file"], "b.pcd");
  EXPECT_DOUBLE_EQ(j["edges"][0]["information"][5][0].get<double>(), 0.5);
  EXPECT_EQ(j["edges"][1]["status"], "pruned");
  EXPECT_EQ(j["edges"][1]["warnings"][0]["code"], "high_rms");
  EXPECT_EQ(j["merged"],
            nlohmann::json(
                {{"file", "merged.ply"}, {"points", 20}, {"voxel", 0.5}, {"scan_index", true}}));
  EXPECT_EQ(j["warnings"][0]["code"], "unconnected_scan");
  EXPECT_EQ(j["timings"]["total_ms"].get<double>(), 15.0);
  for (const char* key : {"min_overlap", "prune_rotation_deg", "prune_translation",
                          "multiview_iterations", "voxel", "viewpoints", "threads"})
    EXPECT_TRUE(j["settings"].contains(key)) << key;
  EXPECT_TRUE(j["settings"]["viewpoints"][0].is_null());  // not known
  EXPECT_EQ(j["settings"]["viewpoints"][2], nlohmann::json({0.0, 0.0, 5.0}));
  EXPECT_EQ(j["poses"][1]["sensor"]["source"], "estimated");
  EXPECT_EQ(j["poses"][1]["sensor"]["position"], nlohmann::json({0.5, 0.0, 2.0}));
  EXPECT_EQ(
      j["settings"]["icp"],
      nlohmann::json({{"method", "point-to-plane"}, {"kernel", "auto"}, {"kernel_scale", 0}}));
  EXPECT_THROW(report::stitch_report(made_up_result(), s, {kInputs[0]}, "", true),
               std::invalid_argument);
}

TEST(StitchFiles, TheMergedPlyCarriesNormalsAndTheScanIndexUnlessTold) {
  test::TempDir d("stitch_files");
  const StitchResult r = made_up_result();
  report::write_merged_ply(d / "with.ply", r, true);
  report::write_merged_ply(d / "without.ply", r, false);
  for (const char* name : {"with.ply", "without.ply"}) {
    const PointCloud back = io::read_point_cloud(d / name);
    ASSERT_EQ(back.size(), 20u) << name;
    ASSERT_TRUE(back.has_normals()) << name;
    EXPECT_EQ(back.normals[3], Eigen::Vector3d(0, 0, 1));
    EXPECT_EQ(back.positions[12], Eigen::Vector3d(12, 0, 0));
  }
  EXPECT_TRUE(mentions(read_text(d / "with.ply"), "property int scan\n"));
  EXPECT_FALSE(mentions(read_text(d / "without.ply"), "scan"));
  StitchResult bad = r;
  bad.merged_scan.pop_back();
  EXPECT_THROW(report::write_merged_ply(d / "bad.ply", bad), std::invalid_argument);
}

TEST(StitchFiles, ThePageIsSelfContainedAndListsPosesEdgesAndWarnings) {
  test::TempDir d("stitch_files");
  report::StitchOutputs o;
  o.html = (d / "page.html").string();
  o.figure = (d / "figure.png").string();
  o.info.files = {"scans/a.ply", "scans/b.pcd", ""};
  report::write_stitch_outputs(o, made_up_result());
  EXPECT_TRUE(fs::exists(d / "figure.png"));
  const std::string page = read_text(d / "page.html");
  EXPECT_TRUE(mentions(page, "data:image/png;base64,"));
  EXPECT_FALSE(mentions(page, "://"));  // no link, no network
  EXPECT_FALSE(mentions(page, "<script"));
  for (const char* text : {"scans/a.ply", "scans/b.pcd", "scan 2", "unconnected_scan",
                           "pruned_edge", "pruned", "high_rms", "28.648", "60.0"})
    EXPECT_TRUE(mentions(page, text)) << text;
  // Each pose's row ends with the codes of the warnings that name its scan.
  EXPECT_TRUE(mentions(page, "<td class=warn>single_edge_scan</td></tr>"));
  EXPECT_TRUE(mentions(page, "<td class=warn>unconnected_scan</td></tr>"));
  // A row per pose and per edge, plus their headers and the timings'.
  std::size_t rows = 0;
  for (std::size_t at = page.find("<tr>"); at != std::string::npos; at = page.find("<tr>", at + 1))
    ++rows;
  EXPECT_EQ(rows, 3u + 1 + 2 + 1 + 6);
  // Same result, same bytes.
  report::write_stitch_page(d / "again.html", made_up_result(), o.info);
  EXPECT_EQ(read_text(d / "again.html"), page);
}

TEST(StitchFiles, AnErrorAboutAScanNamesItsFile) {
  const std::vector<std::string> files = {"a.ply", "", "c.pcd"};
  const DataError named = report::naming_scan_file(DataError("scan 2", "8 points"), files);
  EXPECT_EQ(named.subject(), "c.pcd");
  EXPECT_EQ(std::string(named.what()), "c.pcd: 8 points");
  for (const DataError& e :
       {DataError("scan 1", "NaN"), DataError("scan 3", "NaN"), DataError("scan 1x", "NaN"),
        DataError("scans", "NaN"), DataError("no subject")})
    EXPECT_EQ(std::string(report::naming_scan_file(e, files).what()), e.what());
}

// The whole command on the generated stitch scene (`align3d synth --scene stitch`: a ring of 8
// range scans of the bracket 45° apart and a leaf view of its underside, each in its own sensor
// frame; truth.json holds each scan's pose in scan_00's frame, scan_00 ≈ T·scan_k), read through
// its list file scans.txt.
class StitchScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir("stitch_scene");
    ASSERT_EQ(run({"synth", "--scene", "stitch", dir_->path().string()}).code, 0);
    truth_ = new nlohmann::json(nlohmann::json::parse(read_text(*dir_ / "truth.json")));
  }
  static void TearDownTestSuite() {
    delete run_;
    run_ = nullptr;
    delete truth_;
    delete dir_;
  }
  // The whole set through its list file, run once, by the first test that asks (each test is a
  // process of its own under ctest: only the one that needs it pays for it).
  static const CliRun& full_run() {
    if (!run_) {
      std::vector<std::string> args = {"stitch", "--list", (*dir_ / "scans.txt").string()};
      for (const char* f : {"--report", "r.json", "--output", "merged.ply", "--figure", "f.png",
                            "--html", "page.html", "--threads", "2"})
        args.push_back(f[0] == '-' || f[0] == '2' ? std::string(f) : (*dir_ / f).string());
      run_ = new CliRun(run(args));
    }
    return *run_;
  }
  static std::string scan(std::size_t k) {
    return (*dir_ / (*truth_)["scans"][k]["file"].get<std::string>()).string();
  }
  static Eigen::Isometry3d matrix(const nlohmann::json& rows) {
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = rows[r][c].get<double>();
    return Eigen::Isometry3d(M);
  }
  static Eigen::Isometry3d truth(std::size_t k) {  // scan_00 ≈ T·scan_k
    return matrix((*truth_)["scans"][k]["pose"]["transformation"]);
  }
  // Rotation within 0.5°, translation within 0.5 % of the object's diameter.
  static void expect_near(const Eigen::Isometry3d& pose, const Eigen::Isometry3d& truth,
                          std::size_t k) {
    const double diameter = (*truth_)["diameter"].get<double>();
    EXPECT_LT(test::rotation_error_deg(pose, truth), 0.5) << k;
    EXPECT_LT((pose.translation() - truth.translation()).norm(), 0.005 * diameter) << k;
  }
  static test::TempDir* dir_;
  static nlohmann::json* truth_;
  static CliRun* run_;
};
test::TempDir* StitchScene::dir_ = nullptr;
nlohmann::json* StitchScene::truth_ = nullptr;
CliRun* StitchScene::run_ = nullptr;

// The poses' accuracy is the engine's (tests/stitch_test.cpp); on this generated set the engine
// does not yet connect every scan rightly (issue 17's note), so exit 0 or 10 (some scan left out),
// and every output written either way.
TEST_F(StitchScene, EveryOutputIsWritten) {
  const CliRun& r = full_run();
  ASSERT_TRUE(r.code == 0 || r.code == code(ExitCode::kUnconnected)) << r.err;
  const auto j = nlohmann::json::parse(read_text(*dir_ / "r.json"));
  ASSERT_EQ(j["poses"].size(), 9u);
  for (std::size_t k = 0; k < 9; ++k) EXPECT_EQ(j["poses"][k]["file"], scan(k));
  EXPECT_TRUE(j["poses"][0]["connected"].get<bool>());
  EXPECT_GE(j["edges"].size(), 8u);
  EXPECT_EQ(j["merged"]["file"], (*dir_ / "merged.ply").string());
  EXPECT_TRUE(j["merged"]["scan_index"].get<bool>());
  const PointCloud merged = io::read_point_cloud(*dir_ / "merged.ply");
  EXPECT_EQ(merged.size(), j["merged"]["points"].get<std::size_t>());
  EXPECT_TRUE(merged.has_normals());
  EXPECT_TRUE(mentions(read_text(*dir_ / "merged.ply"), "property int scan\n"));
  EXPECT_TRUE(fs::exists(*dir_ / "f.png"));
  EXPECT_TRUE(mentions(read_text(*dir_ / "page.html"), "data:image/png;base64,"));
}

// Never silently wrong: a connected scan placed more than 1° or 1 % of the diameter from the truth
// (on this set the leaf's parent, when joined: issue 17) carries a warning that says its pose may
// be wrong (its pose's `warnings` in the report, and stderr names it).
TEST_F(StitchScene, AWrongPoseIsNeverReportedSilently) {
  const CliRun& r = full_run();
  ASSERT_TRUE(r.code == 0 || r.code == code(ExitCode::kUnconnected)) << r.err;
  const auto j = nlohmann::json::parse(read_text(*dir_ / "r.json"));
  const double diameter = (*truth_)["diameter"].get<double>();
  for (std::size_t k = 0; k < j["poses"].size(); ++k) {
    const auto& p = j["poses"][k];
    if (!p["connected"].get<bool>()) continue;
    const Eigen::Isometry3d pose = matrix(p["transformation"]);
    if (test::rotation_error_deg(pose, truth(k)) <= 1 &&
        (pose.translation() - truth(k).translation()).norm() <= 0.01 * diameter)
      continue;
    bool doubted = false;
    for (const auto& w : p["warnings"])
      doubted =
          doubted || w == "single_edge_scan" || w == "ambiguous_scans" || w == "inconsistent_scans";
    EXPECT_TRUE(doubted) << "scan " << k << " is wrong: " << p["warnings"];
    EXPECT_TRUE(mentions(r.err, "scan " + std::to_string(k)) ||
                mentions(r.err, "scan(s) " + std::to_string(k)))
        << r.err;
  }
}

TEST_F(StitchScene, NoScanIndexLeavesThePropertyOutAndTheFirstScanGivesTheFrame) {
  // Three neighbours of the ring, the third first: the poses map into its frame.
  const CliRun r = run({"stitch", scan(2), scan(0), scan(1), "--no-scan-index", "--output",
                        (*dir_ / "plain.ply").string(), "--report", "-", "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);  // pure JSON with --report -
  EXPECT_FALSE(j["merged"]["scan_index"].get<bool>());
  EXPECT_FALSE(mentions(read_text(*dir_ / "plain.ply"), "scan"));
  // scan_02 ≈ T₂⁻¹·T_k·scan_k
  for (std::size_t i = 1; i < 3; ++i)
    expect_near(matrix(j["poses"][i]["transformation"]), truth(2).inverse() * truth(i - 1), i);
}

TEST_F(StitchScene, APcdsViewpointIsItsScansSensor) {
  // Two neighbours as PCD files, the second with its sensor recorded away from its origin.
  for (std::size_t k = 0; k < 2; ++k) {
    io::WriteSettings w;
    w.pcd_layout.viewpoint.position = k == 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(5, 6, 7);
    io::write_point_cloud(*dir_ / ("v" + std::to_string(k) + ".pcd"), io::read_point_cloud(scan(k)),
                          w);
  }
  const CliRun r = run({"stitch", (*dir_ / "v0.pcd").string(), (*dir_ / "v1.pcd").string(),
                        "--report", "-", "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  // A VIEWPOINT at the origin is no evidence: the first scan's sensor is placed by the engine (its
  // own origin: the generated view was seen from there).
  EXPECT_EQ(j["settings"]["viewpoints"], nlohmann::json({nullptr, {5.0, 6.0, 7.0}}));
  EXPECT_EQ(j["poses"][0]["sensor"]["source"], "origin");
  EXPECT_EQ(j["poses"][1]["sensor"]["source"], "given");
  EXPECT_EQ(j["poses"][1]["sensor"]["position"], nlohmann::json({5.0, 6.0, 7.0}));
}

TEST_F(StitchScene, SensorsGivenOnTheCommandLineAreTheScansSensors) {
  const std::string a = scan(0), b = scan(1);
  CliRun r = run({"stitch", a, b, "--viewpoint", "0,0,0", "--report", "-", "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out);
  for (std::size_t k = 0; k < 2; ++k) EXPECT_EQ(j["poses"][k]["sensor"]["source"], "given");
  // A file: one line a scan in input order, auto where not known.
  const fs::path eyes = *dir_ / "eyes.txt";
  write_text(eyes, "# sensors\n0 0 0\n\nauto\n");
  r = run({"stitch", a, b, "--viewpoints", eyes.string(), "--report", "-", "--threads", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["poses"][0]["sensor"]["source"], "given");
  EXPECT_EQ(j["poses"][1]["sensor"]["source"], "origin");  // generated views: seen from there
  // What cannot be used: exit 3 naming the file and the line, or exit 2 for the flag.
  write_text(eyes, "0 0\nauto\n");
  r = run({"stitch", a, b, "--viewpoints", eyes.string()});
  EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
  EXPECT_NE(r.err.find("eyes.txt: line 1: expected 3 finite numbers"), std::string::npos) << r.err;
  write_text(eyes, "auto\n");
  r = run({"stitch", a, b, "--viewpoints", eyes.string()});
  EXPECT_EQ(r.code, code(ExitCode::kInput)) << r.err;
  EXPECT_NE(r.err.find("1 viewpoints for 2 scans"), std::string::npos) << r.err;
  r = run({"stitch", a, b, "--viewpoint", "1,nan,2"});
  EXPECT_EQ(r.code, code(ExitCode::kUsage)) << r.err;
  EXPECT_NE(r.err.find("--viewpoint"), std::string::npos) << r.err;
}

TEST_F(StitchScene, AScanThatOverlapsNoOtherIsExitCodeTenWithEveryOutput) {
  // A wavy sheet much larger than the object: no pose lays a fifth of a view on it.
  PointCloud sheet;
  for (int i = 0; i < 80; ++i)
    for (int j = 0; j < 80; ++j)
      sheet.positions.emplace_back(5 * i, 5 * j, 40 * std::sin(i / 6.0) * std::cos(j / 5.0));
  io::write_point_cloud(*dir_ / "sheet.ply", sheet);
  const CliRun r =
      run({"stitch", scan(0), scan(1), (*dir_ / "sheet.ply").string(), "--report",
           (*dir_ / "u.json").string(), "--output", (*dir_ / "u.ply").string(), "--threads", "2"});
  EXPECT_EQ(r.code, code(ExitCode::kUnconnected)) << r.err;
  const auto j = nlohmann::json::parse(read_text(*dir_ / "u.json"));
  EXPECT_TRUE(j["poses"][1]["connected"].get<bool>());
  EXPECT_FALSE(j["poses"][2]["connected"].get<bool>());
  bool warned = false;
  for (const auto& w : j["warnings"]) warned = warned || w["code"] == "unconnected_scan";
  EXPECT_TRUE(warned);
  EXPECT_TRUE(fs::exists(*dir_ / "u.ply"));
  EXPECT_TRUE(mentions(r.err, "warning")) << r.err;
}

}  // namespace
}  // namespace align3d
