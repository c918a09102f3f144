#include "align3d/report/chapter.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/report/figure.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"

namespace align3d::report {
namespace {

constexpr Rgb kBlue{0.13, 0.33, 0.85}, kRed{0.86, 0.16, 0.14}, kGreen{0.10, 0.62, 0.22},
    kGray{0.45, 0.45, 0.45}, kPurple{0.55, 0.2, 0.7};

IcpExperiment run_icp(const ChapterScene& scene, std::string name, const Eigen::Isometry3d& init,
                      const RegistrationSettings& settings) {
  IcpExperiment e{std::move(name), init, register_clouds(scene.scan, scene.model, init, settings)};
  const Eigen::Isometry3d& T = e.result.icp.T_target_source;
  e.rotation_deg = rad_to_deg(rotation_angle(T.linear()));
  e.rotation_error_deg =
      rad_to_deg(rotation_angle(T.linear().transpose() * scene.T_model_scan.linear()));
  e.translation_error = (T.translation() - scene.T_model_scan.translation()).norm();
  return e;
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return rad_to_deg(std::atan2(a.cross(b).norm(), a.dot(b)));
}

struct Row {
  std::string experiment, quantity, chapter;
  double ours;
  int digits;
};

std::vector<Row> table_rows(const ChapterResults& r) {
  auto icp_rows = [](const IcpExperiment& e, const std::string& label, const std::string& its,
                     const std::string& rms, const std::string& rot, const std::string& rerr,
                     const std::string& terr) {
    std::vector<Row> rows = {
        {label, "iterations", its, static_cast<double>(e.result.total_iterations), 0},
        {label, "RMS (mm)", rms, e.result.icp.rms, 4},
    };
    if (!rot.empty()) rows.push_back({label, "rotation angle (deg)", rot, e.rotation_deg, 2});
    rows.push_back({label, "rotation error (deg)", rerr, e.rotation_error_deg, 3});
    rows.push_back({label, "translation error (mm)", terr, e.translation_error, 3});
    return rows;
  };
  std::vector<Row> rows;
  for (auto part :
       {icp_rows(r.p2p_good, "point-to-point, identity init", "58", "0.6443", "10.69", "1.97",
                 "0.233"),
        icp_rows(r.p2p_bad, "point-to-point, bad init (+40° about Z)", "60", "2.0824", "", "29.3",
                 "8.20"),
        icp_rows(r.p2plane, "point-to-plane, identity init", "9", "0.0991", "", "0.016", "0.005"),
        icp_rows(r.robust, "align3d register defaults (auto), identity init", "—", "—", "", "—",
                 "—"),
        icp_rows(r.global, "bad init + global (fpfh) + point-to-plane", "—", "—", "", "—", "—")})
    rows.insert(rows.end(), part.begin(), part.end());
  rows.push_back({"bad init + global (fpfh) + point-to-plane", "coarse stage time (ms)", "—",
                  r.global_coarse.time_ms, 0});
  rows.push_back({"plane correction, tilted plate", "tilt before (deg)", "6.9999",
                  r.plate.tilt_before_deg, 4});
  rows.push_back(
      {"plane correction, tilted plate", "tilt after (deg)", "0.0000", r.plate.tilt_after_deg, 4});
  rows.push_back({"cluttered plate (20 % clutter), plain LSQ fit", "normal error (deg)", "—",
                  r.cluttered_plain_error_deg, 3});
  rows.push_back({"cluttered plate (20 % clutter), --robust", "normal error (deg)", "—",
                  r.cluttered_robust_error_deg, 4});
  rows.push_back({"cluttered plate (20 % clutter), --robust", "tilt after (deg)", "—",
                  r.cluttered_robust.tilt_after_deg, 4});
  return rows;
}

std::string format(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

std::vector<Eigen::Vector2d> view(const PointCloud& cloud, const Eigen::Isometry3d& T, int a,
                                  int b) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(cloud.size());
  for (const auto& p : cloud.positions) {
    const Eigen::Vector3d q = T * p;
    out.emplace_back(q[a], q[b]);
  }
  return out;
}

Figure side_view(std::string title, const std::vector<Series>& series) {
  Figure f;
  f.title = std::move(title);
  f.x_label = "x (mm)";
  f.y_label = "z (mm)";
  f.series = series;
  f.equal_aspect = true;
  f.width = 1100;
  f.height = 520;
  return f;
}

std::vector<Eigen::Vector2d> rms_curve(const IcpExperiment& e) {
  std::vector<Eigen::Vector2d> out;
  for (std::size_t i = 0; i < e.result.history.size(); ++i)
    out.emplace_back(static_cast<double>(i), std::max(e.result.history[i].rms, 1e-6));
  return out;
}

std::string base64(const std::string& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json icp_json(const IcpExperiment& e) {
  nlohmann::json history = nlohmann::json::array();
  for (const auto& h : e.result.history)
    history.push_back({{"rms", h.rms}, {"kept", h.kept}, {"threshold", h.threshold}});
  nlohmann::json T = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    T.push_back(
        {e.result.icp.T_target_source.matrix()(r, 0), e.result.icp.T_target_source.matrix()(r, 1),
         e.result.icp.T_target_source.matrix()(r, 2), e.result.icp.T_target_source.matrix()(r, 3)});
  return {{"name", e.name},
          {"iterations", e.result.total_iterations},
          {"converged", e.result.icp.converged},
          {"stop_reason", to_string(e.result.icp.stop_reason)},
          {"rms", e.result.icp.rms},
          {"fitness", e.result.icp.fitness},
          {"rotation_deg", e.rotation_deg},
          {"rotation_error_deg", e.rotation_error_deg},
          {"translation_error", e.translation_error},
          {"transformation", T},
          {"history", history}};
}

nlohmann::json rectify_summary(const RectifyResult& r) {
  return {{"normal", {r.normal.x(), r.normal.y(), r.normal.z()}},
          {"tilt_before_deg", r.tilt_before_deg},
          {"tilt_after_deg", r.tilt_after_deg},
          {"inliers", r.inliers},
          {"flatness", r.flatness}};
}

}  // namespace

ChapterScene generate_chapter_scene(std::uint64_t seed) {
  synth::ConveyorSettings cs;
  cs.seed = seed;
  const synth::Scene s = synth::make_conveyor_scene(cs);
  const synth::Plate cluttered = synth::make_plate(synth::chapter_plate(seed, true));
  return {s.model,         s.scan,
          s.T_model_scan,  synth::make_plate(synth::chapter_plate(seed, false)).cloud,
          cluttered.cloud, cluttered.true_normal,
          cs.noise_sigma};
}

ChapterScene read_chapter_scene(const std::filesystem::path& dir) {
  ChapterScene scene;
  scene.model = io::read_point_cloud(dir / "model.ply");
  scene.scan = io::read_point_cloud(dir / "scan.ply");
  scene.T_model_scan = io::read_matrix(dir / "ground_truth.txt");
  scene.plate = io::read_point_cloud(dir / "plate.ply");
  scene.plate_cluttered = io::read_point_cloud(dir / "plate_cluttered.ply");
  std::ifstream in(dir / "scene.json");
  const nlohmann::json meta = nlohmann::json::parse(in, nullptr, false);
  if (!meta.is_discarded()) {
    const auto normal = meta.value("/plate_cluttered/true_normal"_json_pointer, nlohmann::json());
    if (normal.is_array() && normal.size() == 3)
      scene.cluttered_true_normal = {normal[0].get<double>(), normal[1].get<double>(),
                                     normal[2].get<double>()};
    scene.noise_sigma = meta.value("/scan/noise_sigma"_json_pointer, scene.noise_sigma);
  }
  return scene;
}

RegistrationSettings chapter_settings(IcpMethod method) {
  RegistrationSettings s;
  s.method = method;
  s.rejection = RejectionRule::median(2.5, 0.5);
  s.max_iterations = 60;
  s.tolerance = 1e-5;
  s.tolerance_relative = false;
  s.transform_criterion = false;
  return s;
}

ChapterResults run_chapter_experiments(const ChapterScene& scene, int threads) {
  auto settings = [&](IcpMethod m) {
    RegistrationSettings s = chapter_settings(m);
    s.threads = threads;
    return s;
  };
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d bad = rigid_transform(40, Eigen::Vector3d::UnitZ());  // 39.3's bad value
  RegistrationSettings defaults;
  defaults.threads = threads;

  ChapterResults r;
  r.p2p_good =
      run_icp(scene, "point-to-point, identity init", identity, settings(IcpMethod::kPointToPoint));
  r.p2p_bad = run_icp(scene, "point-to-point, bad init", bad, settings(IcpMethod::kPointToPoint));
  r.p2plane =
      run_icp(scene, "point-to-plane, identity init", identity, settings(IcpMethod::kPointToPlane));
  r.robust = run_icp(scene, "register defaults (auto), identity init", identity, defaults);
  // The remedy: the scan as the bad initial value leaves it, registered globally, then refined.
  // (The coarse stage ignores the initial value, so it sees the scan moved by the bad pose.)
  GlobalSettings gs;
  gs.threads = threads;
  r.global_coarse = global_register(transformed(scene.scan, bad), scene.model, gs);
  const Eigen::Isometry3d coarse = r.global_coarse.T_target_source * bad;  // back to scan frame
  r.global = run_icp(scene, "bad init + global (fpfh) + point-to-plane",
                     r.global_coarse.success ? coarse : bad, settings(IcpMethod::kPointToPlane));
  r.plate = rectify(scene.plate);
  r.cluttered_plain = rectify(scene.plate_cluttered);
  RectifySettings robust;
  robust.robust = true;
  r.cluttered_robust = rectify(scene.plate_cluttered, robust);
  r.cluttered_plain_error_deg = angle_deg(r.cluttered_plain.normal, scene.cluttered_true_normal);
  r.cluttered_robust_error_deg = angle_deg(r.cluttered_robust.normal, scene.cluttered_true_normal);
  return r;
}

std::string chapter_table(const ChapterResults& results) {
  std::ostringstream out;
  out << "| experiment | quantity | chapter | ours |\n|---|---|---:|---:|\n";
  for (const Row& row : table_rows(results))
    out << "| " << row.experiment << " | " << row.quantity << " | " << row.chapter << " | "
        << format(row.ours, row.digits) << " |\n";
  return out.str();
}

void write_chapter_report(const ChapterScene& scene, const ChapterResults& r,
                          const std::filesystem::path& outdir) {
  std::error_code ec;
  std::filesystem::create_directories(outdir, ec);
  if (ec) throw OutputError(outdir.string() + ": cannot create directory: " + ec.message());
  const std::string table = chapter_table(r);
  io::write_text_atomically(outdir / "table.md", table);

  nlohmann::json rows = nlohmann::json::array();
  for (const Row& row : table_rows(r))
    rows.push_back({{"experiment", row.experiment},
                    {"quantity", row.quantity},
                    {"chapter", row.chapter},
                    {"ours", row.ours}});
  const nlohmann::json results = {
      {"table", rows},
      {"icp",
       {icp_json(r.p2p_good), icp_json(r.p2p_bad), icp_json(r.p2plane), icp_json(r.robust),
        icp_json(r.global)}},
      {"global",
       {{"success", r.global_coarse.success},
        {"time_ms", r.global_coarse.time_ms},
        {"overlap", r.global_coarse.overlap},
        {"candidates", r.global_coarse.candidates},
        {"ambiguous", r.global_coarse.ambiguous},
        {"message", r.global_coarse.message}}},
      {"rectify",
       {{"plate", rectify_summary(r.plate)},
        {"cluttered_plain", rectify_summary(r.cluttered_plain)},
        {"cluttered_robust", rectify_summary(r.cluttered_robust)},
        {"cluttered_plain_normal_error_deg", r.cluttered_plain_error_deg},
        {"cluttered_robust_normal_error_deg", r.cluttered_robust_error_deg}}}};
  io::write_text_atomically(outdir / "results.json", results.dump(2) + "\n");

  // Figures 39.1-39.5 (XZ views for the scene: x right, z up; YZ for the plate).
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  const auto model_xz = view(scene.model, I, 0, 2);
  struct Named {
    std::string stem, caption;
    Figure figure;
  };
  std::vector<Named> figures;
  figures.push_back(
      {"fig39_1",
       "Figure 39.1: initial poses, XZ side view. Model blue, scan red; the isolated red wall on "
       "the right exists only in the scan.",
       side_view("Fig. 39.1  Initial poses (XZ orthographic side view)",
                 {{"model (target)", kBlue, model_xz, false, 1.2, 0.6},
                  {"scan (source)", kRed, view(scene.scan, I, 0, 2), false, 1.2, 0.6}})});
  figures.push_back({"fig39_2",
                     "Figure 39.2: after point-to-point ICP from the identity; the intruder wall "
                     "is rejected and stays where it was.",
                     side_view("Fig. 39.2  After point-to-point ICP, good initial value",
                               {{"model", kBlue, model_xz, false, 1.2, 0.6},
                                {"scan, aligned", kRed,
                                 view(scene.scan, r.p2p_good.result.icp.T_target_source, 0, 2),
                                 false, 1.2, 0.6}})});
  Figure curves;
  curves.title = "Fig. 39.3  RMS per iteration";
  curves.x_label = "iteration (0: the starting pose)";
  curves.y_label = "RMS of kept pairs (mm)";
  curves.log_y = true;
  curves.series = {
      {"point-to-point, good init", kRed, rms_curve(r.p2p_good), true, 2.0, 1.0},
      {"point-to-point, bad init (+40° Z)", kGreen, rms_curve(r.p2p_bad), true, 2.0, 1.0},
      {"point-to-plane, good init", kBlue, rms_curve(r.p2plane), true, 2.0, 1.0},
      {"bad init + global + point-to-plane", kPurple, rms_curve(r.global), true, 2.0, 1.0}};
  std::ostringstream floor_label;
  floor_label << "noise floor σ = " << scene.noise_sigma << " mm";
  curves.lines = {{scene.noise_sigma, floor_label.str(), kGray, true}};
  figures.push_back(
      {"fig39_3",
       "Figure 39.3: RMS convergence. Red: point-to-point, good init; green: point-to-point, bad "
       "init; blue: point-to-plane; purple: bad init + global registration + point-to-plane.",
       curves});
  figures.push_back(
      {"fig39_4",
       "Figure 39.4: point-to-point ICP from the bad initial value (+40° about Z) ends in a wrong "
       "local minimum.",
       side_view(
           "Fig. 39.4  Bad initial value: point-to-point ICP in a wrong minimum",
           {{"model", kBlue, model_xz, false, 1.2, 0.6},
            {"scan, converged (wrong)", kGreen,
             view(scene.scan, r.p2p_bad.result.icp.T_target_source, 0, 2), false, 1.2, 0.6}})});
  Figure plate = side_view(
      "Fig. 39.5  Plane correction (YZ orthographic side view)",
      {{"tilted plate", kRed, view(scene.plate, I, 1, 2), false, 1.2, 0.6},
       {"corrected", kGreen, view(scene.plate, r.plate.transformation, 1, 2), false, 1.2, 0.6}});
  plate.x_label = "y (mm)";
  plate.lines = {{0.0, "z = 0", kGray, false}};
  figures.push_back({"fig39_5",
                     "Figure 39.5: plane correction. Red: the 7° tilted plate; green: levelled "
                     "onto z = 0 (gray).",
                     plate});
  figures.push_back(
      {"fig39_6",
       "Figure 39.6 (beyond the chapter): the remedy of section 39.3. From the same bad initial "
       "value, global registration (FPFH + RANSAC) finds the basin and point-to-plane ICP refines "
       "it.",
       side_view(
           "Fig. 39.6  Bad initial value + global registration + point-to-plane ICP",
           {{"model", kBlue, model_xz, false, 1.2, 0.6},
            {"scan, aligned", kPurple, view(scene.scan, r.global.result.icp.T_target_source, 0, 2),
             false, 1.2, 0.6}})});

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>align3d: chapter 39 "
          "reproduced</title><style>body{font-family:sans-serif;max-width:1150px;margin:2em auto;"
          "color:#222}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px 10px}"
          "td.n{text-align:right;font-family:monospace}figure{margin:2em 0}img{max-width:100%}"
          "</style></head><body>\n<h1>ICP registration and 3D rectification: the chapter "
          "reproduced</h1>\n<p>Generated by <code>align3d demo</code>. Units: mm.</p>\n<table>"
          "<tr><th>experiment</th><th>quantity</th><th>chapter</th><th>ours</th></tr>\n";
  for (const Row& row : table_rows(r))
    html << "<tr><td>" << row.experiment << "</td><td>" << row.quantity << "</td><td class=n>"
         << row.chapter << "</td><td class=n>" << format(row.ours, row.digits) << "</td></tr>\n";
  html << "</table>\n";
  for (const Named& f : figures) {
    write_figure(f.figure, outdir / f.stem);
    html << "<figure><img alt=\"" << f.stem << "\" src=\"data:image/png;base64,"
         << base64(read_bytes(outdir / (f.stem + ".png"))) << "\"><figcaption>" << f.caption
         << "</figcaption></figure>\n";
  }
  html << "</body></html>\n";
  io::write_text_atomically(outdir / "report.html", html.str());
}

}  // namespace align3d::report
