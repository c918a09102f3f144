// align3d evaluate [OUTDIR]: success rates from random poses and the convergence basin (issue #4).
#include <chrono>
#include <iomanip>
#include <sstream>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/report/evaluation.hpp"
#include "align3d/report/figure.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct EvaluateOptions {
  std::string outdir = "align3d_evaluation";
  int trials = 100;
  int cell_trials = 4;
  std::uint64_t seed = 1;
  bool quick = false;
};

constexpr report::EvalMethod kMethods[] = {report::EvalMethod::kPointToPoint,
                                           report::EvalMethod::kPointToPlane,
                                           report::EvalMethod::kGlobal};

std::string percent(double x) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(x == 1.0 || x == 0.0 ? 0 : 1) << 100 * x << " %";
  return s.str();
}

int run_evaluate(const EvaluateOptions& o, Streams io) {
  const auto start = std::chrono::steady_clock::now();
  const int trials = o.quick ? 3 : o.trials;
  const int cell_trials = o.quick ? 1 : o.cell_trials;
  const std::vector<double> angles = o.quick
                                         ? std::vector<double>{0, 90}
                                         : std::vector<double>{0, 10, 20, 30, 45, 60, 90, 135, 180};
  const std::vector<double> shifts =
      o.quick ? std::vector<double>{0, 0.25} : std::vector<double>{0, 0.05, 0.1, 0.2, 0.35, 0.5};
  std::error_code ec;
  std::filesystem::create_directories(o.outdir, ec);
  if (ec) throw OutputError(o.outdir + ": cannot create directory: " + ec.message());

  const auto scenes = report::evaluation_scenes();
  std::ostringstream md;
  md << "## Success from random initial poses\n\n"
     << trials
     << " seeded trials per row: rotation uniform in [0°, 180°] about a uniform random axis, "
        "translation uniform in [0, ½ diagonal] in a uniform random direction. Success: rotation "
        "error < 1° and translation error < 0.5 % of the model's bounding-box diagonal.\n\n"
        "| scene | method | successes | rate | median time (ms) |\n|---|---|---:|---:|---:|\n";
  nlohmann::json json = {
      {"trials", trials}, {"seed", o.seed}, {"success", nlohmann::json::array()}};
  for (const auto& scene : scenes)
    for (const auto method : kMethods) {
      io.out << "success rate: " << scene.name << ", " << report::to_string(method) << " ... "
             << std::flush;
      const report::SuccessRow row = report::success_rate(scene, method, trials, o.seed);
      const double rate = static_cast<double>(row.successes) / std::max(1, row.trials);
      io.out << row.successes << "/" << row.trials << "\n";
      md << "| " << row.scene << " | " << report::to_string(method) << " | " << row.successes << "/"
         << row.trials << " | " << percent(rate) << " | " << std::fixed << std::setprecision(0)
         << row.median_time_ms << " |\n";
      json["success"].push_back({{"scene", row.scene},
                                 {"method", report::to_string(method)},
                                 {"trials", row.trials},
                                 {"successes", row.successes},
                                 {"median_time_ms", row.median_time_ms}});
    }

  // The basin on the chapter scene, one panel per method.
  std::vector<report::HeatMap> panels;
  md << "\n## Convergence basin (chapter scene)\n\nSuccess rate over initial rotation angle × "
        "translation magnitude (fraction of the diagonal), "
     << cell_trials << " trials per cell with random axes and directions.\n";
  json["basin"] = nlohmann::json::array();
  for (const auto method : kMethods) {
    io.out << "basin: " << report::to_string(method) << " ... " << std::flush;
    const report::Basin b =
        report::convergence_basin(scenes.front(), method, angles, shifts, cell_trials, o.seed);
    io.out << "done\n";
    report::HeatMap h;
    h.title = report::to_string(method);
    h.x_label = "initial rotation (deg)";
    h.y_label = "initial translation (× diagonal)";
    h.value_label = "success rate";
    for (double a : angles) h.x_ticks.push_back(std::to_string(static_cast<int>(a)));
    for (double f : shifts) {
      std::ostringstream s;
      s << f;
      h.y_ticks.push_back(s.str());
    }
    h.values = b.success;
    panels.push_back(h);
    md << std::defaultfloat << std::setprecision(6) << "\n"
       << report::to_string(method) << "\n\n| translation \\ rotation |";
    for (double a : angles) md << " " << a << "° |";
    md << "\n|---|";
    for (std::size_t i = 0; i < angles.size(); ++i) md << "---:|";
    md << "\n";
    for (Eigen::Index r = b.success.rows() - 1; r >= 0; --r) {
      md << "| " << shifts[static_cast<std::size_t>(r)] << " |";
      for (Eigen::Index c = 0; c < b.success.cols(); ++c)
        md << " " << percent(b.success(r, c)) << " |";
      md << "\n";
    }
    json["basin"].push_back({{"method", report::to_string(method)},
                             {"angles_deg", angles},
                             {"translation_fractions", shifts},
                             {"success", [&] {
                                nlohmann::json rows = nlohmann::json::array();
                                for (Eigen::Index r = 0; r < b.success.rows(); ++r) {
                                  nlohmann::json row = nlohmann::json::array();
                                  for (Eigen::Index c = 0; c < b.success.cols(); ++c)
                                    row.push_back(b.success(r, c));
                                  rows.push_back(row);
                                }
                                return rows;
                              }()}});
  }
  const std::filesystem::path dir(o.outdir);
  report::write_heatmaps(panels, "Convergence basin on the chapter scene", dir / "basin");
  io::write_text_atomically(dir / "evaluation.md", md.str());
  io::write_text_atomically(dir / "evaluation.json", json.dump(2) + "\n");
  io.out << "\n"
         << md.str() << "\nwrote " << o.outdir
         << "/{evaluation.md,evaluation.json,basin.svg,basin.png} in "
         << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
         << " s\n";
  return 0;
}

}  // namespace

Command add_evaluate(CLI::App& app, Streams io) {
  auto o = std::make_shared<EvaluateOptions>();
  CLI::App* sub = app.add_subcommand(
      "evaluate",
      "Measure registration from arbitrary starting poses on the chapter scene and two object "
      "views:\n"
      "success rates of ICP alone and of global + ICP, and the convergence basin (heat map).\n"
      "The full run takes several minutes; --quick is a smoke test.");
  sub->add_option("OUTDIR", o->outdir, "Output directory")->capture_default_str();
  sub->add_option("--trials", o->trials, "Random poses per scene and method")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  sub->add_option("--cell-trials", o->cell_trials, "Trials per basin cell")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the random poses")->capture_default_str();
  sub->add_flag("--quick", o->quick, "3 trials and a 2×2 basin: checks the machinery only");
  return {sub, [o, io] { return run_evaluate(*o, io); }};
}

}  // namespace align3d::cli
