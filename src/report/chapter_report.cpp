#include "align3d/report/chapter_report.hpp"

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
#include "align3d/report/html.hpp"
#include "align3d/report/json.hpp"

namespace align3d::report {
namespace {

constexpr Rgb kBlue{0.13, 0.33, 0.85}, kRed{0.86, 0.16, 0.14}, kGreen{0.10, 0.62, 0.22},
    kGray{0.45, 0.45, 0.45}, kPurple{0.55, 0.2, 0.7};

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
        {label, "iterations", its, static_cast<double>(e.result.refine.total_iterations), 0},
        {label, "RMS (mm)", rms, e.result.refine.icp.rms, 4},
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
        icp_rows(r.defaults, "align3d register defaults, identity init", "—", "—", "", "—", "—"),
        icp_rows(r.global, "bad init + global (fpfh) + point-to-plane", "—", "—", "", "—", "—")})
    rows.insert(rows.end(), part.begin(), part.end());
  rows.push_back({"bad init + global (fpfh) + point-to-plane", "coarse stage time (ms)", "—",
                  r.global.result.timings.global_ms, 0});
  rows.push_back({"plane correction, tilted plate", "tilt before (deg)", "6.9999",
                  r.plate.tilt_before_deg, 4});
  rows.push_back(
      {"plane correction, tilted plate", "tilt after (deg)", "0.0000", r.plate.tilt_after_deg, 4});
  rows.push_back({"cluttered plate (20 % clutter), plain LSQ fit", "normal error (deg)", "—",
                  r.cluttered_plain_error_deg, 3});
  rows.push_back({"cluttered plate (20 % clutter), robust fit (default)", "normal error (deg)", "—",
                  r.cluttered_robust_error_deg, 4});
  rows.push_back({"cluttered plate (20 % clutter), robust fit (default)", "tilt after (deg)", "—",
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
  for (std::size_t i = 0; i < e.result.refine.history.size(); ++i)
    out.emplace_back(static_cast<double>(i), std::max(e.result.refine.history[i].rms, 1e-6));
  return out;
}

// results.json: the table, each experiment's registration report (report/json.hpp) with its name
// and errors, and the plane fits.
nlohmann::json results_json(const ChapterScene& scene, const ChapterResults& r) {
  nlohmann::json rows = nlohmann::json::array();
  for (const Row& row : table_rows(r))
    rows.push_back({{"experiment", row.experiment},
                    {"quantity", row.quantity},
                    {"chapter", row.chapter},
                    {"ours", row.ours}});
  nlohmann::json experiments = nlohmann::json::array();
  for (const IcpExperiment* e : {&r.p2p_good, &r.p2p_bad, &r.p2plane, &r.defaults, &r.global}) {
    nlohmann::json j = registration_report(e->result, e->settings, {"scan", scene.scan.size()},
                                           {"model", scene.model.size()}, scene.T_model_scan);
    j["name"] = e->name;
    experiments.push_back(j);
  }
  const InputInfo plate{"plate", scene.plate.size()};
  const InputInfo cluttered{"plate_cluttered", scene.plate_cluttered.size()};
  RectifySettings plain;
  plain.robust = false;
  return {{"table", rows},
          {"icp", experiments},
          {"rectify",
           {{"plate", rectify_report(r.plate, plain, plate)},
            {"cluttered_plain", rectify_report(r.cluttered_plain, plain, cluttered)},
            {"cluttered_robust", rectify_report(r.cluttered_robust, {}, cluttered)},
            {"cluttered_plain_normal_error_deg", r.cluttered_plain_error_deg},
            {"cluttered_robust_normal_error_deg", r.cluttered_robust_error_deg}}}};
}

// What align3d warns about each experiment: the chapter's failures are not silent.
std::string warnings_html(const ChapterResults& r) {
  std::ostringstream out;
  out << "<h2>Warnings</h2>\n<p>What <code>align3d</code> reports about each result (a result "
         "that may be wrong is never reported silently).</p>\n<ul>\n";
  auto list = [&](const std::string& name, const std::vector<Warning>& warnings) {
    out << "<li>" << html_escape(name) << ": ";
    if (warnings.empty()) out << "none";
    for (std::size_t i = 0; i < warnings.size(); ++i)
      out << (i ? "; " : "") << "<span class=warn>" << html_escape(warnings[i].message)
          << "</span>";
    out << "</li>\n";
  };
  for (const IcpExperiment* e : {&r.p2p_good, &r.p2p_bad, &r.p2plane, &r.defaults, &r.global})
    list(e->name, e->result.warnings);
  list("plane correction, tilted plate", r.plate.warnings);
  list("cluttered plate, plain least-squares fit", r.cluttered_plain.warnings);
  list("cluttered plate, robust fit", r.cluttered_robust.warnings);
  out << "</ul>\n";
  return out.str();
}

// A figure with the file stem it is written to and its caption in the report.
struct NamedFigure {
  std::string stem, caption;
  Figure figure;
};

// Figure 39.3: the RMS per iteration of the ICP runs, over the scan's noise floor.
Figure rms_figure(const ChapterScene& scene, const ChapterResults& r) {
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
  return curves;
}

// Figure 39.5: the tilted plate and the levelled one, YZ side view.
Figure plate_figure(const ChapterScene& scene, const ChapterResults& r) {
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  Figure plate = side_view(
      "Fig. 39.5  Plane correction (YZ orthographic side view)",
      {{"tilted plate", kRed, view(scene.plate, I, 1, 2), false, 1.2, 0.6},
       {"corrected", kGreen, view(scene.plate, r.plate.T_level_cloud, 1, 2), false, 1.2, 0.6}});
  plate.x_label = "y (mm)";
  plate.lines = {{0.0, "z = 0", kGray, false}};
  return plate;
}

// Figures 39.1-39.6 in report order (XZ views for the scene: x right, z up; YZ for the plate).
std::vector<NamedFigure> chapter_figures(const ChapterScene& scene, const ChapterResults& r) {
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  const auto model_xz = view(scene.model, I, 0, 2);
  std::vector<NamedFigure> figures;
  figures.push_back(
      {"fig39_1",
       "Figure 39.1: initial poses, XZ side view. Model blue, scan red; the isolated red wall on "
       "the right exists only in the scan.",
       side_view("Fig. 39.1  Initial poses (XZ orthographic side view)",
                 {{"model (target)", kBlue, model_xz, false, 1.2, 0.6},
                  {"scan (source)", kRed, view(scene.scan, I, 0, 2), false, 1.2, 0.6}})});
  figures.push_back(
      {"fig39_2",
       "Figure 39.2: after point-to-point ICP from the identity; the intruder wall "
       "is rejected and stays where it was.",
       side_view("Fig. 39.2  After point-to-point ICP, good initial value",
                 {{"model", kBlue, model_xz, false, 1.2, 0.6},
                  {"scan, aligned", kRed, view(scene.scan, r.p2p_good.result.transformation, 0, 2),
                   false, 1.2, 0.6}})});
  figures.push_back(
      {"fig39_3",
       "Figure 39.3: RMS convergence. Red: point-to-point, good init; green: point-to-point, bad "
       "init; blue: point-to-plane; purple: bad init + global registration + point-to-plane.",
       rms_figure(scene, r)});
  figures.push_back(
      {"fig39_4",
       "Figure 39.4: point-to-point ICP from the bad initial value (+40° about Z) ends in a wrong "
       "local minimum.",
       side_view("Fig. 39.4  Bad initial value: point-to-point ICP in a wrong minimum",
                 {{"model", kBlue, model_xz, false, 1.2, 0.6},
                  {"scan, converged (wrong)", kGreen,
                   view(scene.scan, r.p2p_bad.result.transformation, 0, 2), false, 1.2, 0.6}})});
  figures.push_back({"fig39_5",
                     "Figure 39.5: plane correction. Red: the 7° tilted plate; green: levelled "
                     "onto z = 0 (gray).",
                     plate_figure(scene, r)});
  figures.push_back(
      {"fig39_6",
       "Figure 39.6 (beyond the chapter): the remedy of section 39.3. From the same bad initial "
       "value, global registration (FPFH + RANSAC) finds the basin and point-to-plane ICP refines "
       "it.",
       side_view("Fig. 39.6  Bad initial value + global registration + point-to-plane ICP",
                 {{"model", kBlue, model_xz, false, 1.2, 0.6},
                  {"scan, aligned", kPurple, view(scene.scan, r.global.result.transformation, 0, 2),
                   false, 1.2, 0.6}})});
  return figures;
}

// The report's heading and the table of our numbers beside the chapter's, as HTML.
std::string table_html(const ChapterResults& r) {
  std::ostringstream out;
  out << "<h1>ICP registration and 3D rectification: the chapter reproduced</h1>\n<p>Generated by "
         "<code>align3d demo</code>. Units: mm.</p>\n<table><tr><th>experiment</th><th>quantity"
         "</th><th>chapter</th><th>ours</th></tr>\n";
  for (const Row& row : table_rows(r))
    out << "<tr><td>" << html_escape(row.experiment) << "</td><td>" << html_escape(row.quantity)
        << "</td><td class=n>" << row.chapter << "</td><td class=n>" << format(row.ours, row.digits)
        << "</td></tr>\n";
  out << "</table>\n";
  return out.str();
}

}  // namespace

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
  if (ec) throw OutputError(outdir, "cannot create directory: " + ec.message());
  const std::string table = chapter_table(r);
  io::write_text_atomically(outdir / "table.md", table);

  io::write_text_atomically(outdir / "results.json", results_json(scene, r).dump(2) + "\n");

  const std::vector<NamedFigure> figures = chapter_figures(scene, r);
  std::ostringstream body;
  body << table_html(r) << warnings_html(r);
  for (const NamedFigure& f : figures) {
    write_figure(f.figure, outdir / f.stem);
    body << html_figure(outdir / (f.stem + ".png"), f.caption);
  }
  io::write_text_atomically(outdir / "report.html",
                            html_page("align3d: chapter 39 reproduced", body.str()));
}

}  // namespace align3d::report
