// align3d evaluate [OUTDIR]: success rates from random poses and the convergence basin
// (evaluate.hpp).
#include <chrono>
#include <iomanip>
#include <sstream>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "align3d/evaluate.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/report/figure.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct EvaluateOptions {
  std::string outdir = "align3d_evaluation";
  int trials = 100;
  int cell_trials = 4;
  std::uint64_t seed = 1;
  bool quick = false, quiet = false, scenes_only = false;
  int threads = 0;
  std::string scenes;  // comma-separated built-in names or scene directories; empty: the four
};

constexpr std::size_t kBasinColumns = 3;  // panels a row in the basin figures

constexpr EvalMethod kMethods[] = {EvalMethod::kPointToPoint, EvalMethod::kPointToPlane,
                                   EvalMethod::kGicp,         EvalMethod::kSymmetric,
                                   EvalMethod::kGlobal,       EvalMethod::kAuto};

std::string percent(double x) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(x == 1.0 || x == 0.0 ? 0 : 1) << 100 * x << " %";
  return s.str();
}

// Success from random poses: one row per scene and method, into the markdown and the JSON.
void success_table(const EvaluateOptions& o, int trials, const std::vector<EvalScene>& scenes,
                   Streams io, std::ostringstream& md, nlohmann::json& json) {
  md << "## Success from random initial poses\n\n"
     << trials
     << " seeded trials per row: rotation uniform in [0°, 180°] about a uniform random axis, "
        "translation uniform in [0, ½ diagonal] in a uniform random direction. Success: rotation "
        "error < 1° and translation error < 0.5 % of the model's bounding-box diagonal.\n\n"
        "| scene | method | successes | rate | median time (ms) |\n|---|---|---:|---:|---:|\n";
  json["success"] = nlohmann::json::array();
  ProgressLine progress(io.err, o.quiet, "");
  for (const auto& scene : scenes)
    for (const auto method : kMethods) {
      const std::string name = scene.name + ", " + to_string(method);
      progress.set_label("success rate: " + name);
      const SuccessRow row =
          success_rate(scene, method, trials, o.seed, o.threads, progress.callback());
      if (!o.quiet)
        io.out << "success rate: " << name << ": " << row.successes << "/" << trials << "\n";
      const double rate = static_cast<double>(row.successes) / std::max(1, row.trials);
      md << "| " << row.scene << " | " << to_string(method) << " | " << row.successes << "/"
         << row.trials << " | " << percent(rate) << " | " << std::fixed << std::setprecision(0)
         << row.median_time_ms << " |\n";
      json["success"].push_back({{"scene", row.scene},
                                 {"method", to_string(method)},
                                 {"trials", row.trials},
                                 {"successes", row.successes},
                                 {"median_time_ms", row.median_time_ms}});
    }
}

report::HeatMap heat_map(EvalMethod method, const Basin& b) {
  report::HeatMap h;
  h.title = to_string(method);
  h.x_label = "initial rotation (deg)";
  h.y_label = "initial translation (× diagonal)";
  h.value_label = "success rate";
  for (double a : b.angles_deg) h.x_ticks.push_back(std::to_string(static_cast<int>(a)));
  for (double f : b.translation_fractions) {
    std::ostringstream s;
    s << f;
    h.y_ticks.push_back(s.str());
  }
  h.values = b.success;
  return h;
}

void basin_markdown(EvalMethod method, const Basin& b, std::ostringstream& md) {
  md << std::defaultfloat << std::setprecision(6) << "\n"
     << to_string(method) << "\n\n| translation \\ rotation |";
  for (double a : b.angles_deg) md << " " << a << "° |";
  md << "\n|---|";
  for (std::size_t i = 0; i < b.angles_deg.size(); ++i) md << "---:|";
  md << "\n";
  for (Eigen::Index r = b.success.rows() - 1; r >= 0; --r) {
    md << "| " << b.translation_fractions[static_cast<std::size_t>(r)] << " |";
    for (Eigen::Index c = 0; c < b.success.cols(); ++c)
      md << " " << percent(b.success(r, c)) << " |";
    md << "\n";
  }
}

nlohmann::json basin_json(EvalMethod method, const Basin& b) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index r = 0; r < b.success.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index c = 0; c < b.success.cols(); ++c) row.push_back(b.success(r, c));
    rows.push_back(row);
  }
  return {{"method", to_string(method)},
          {"angles_deg", b.angles_deg},
          {"translation_fractions", b.translation_fractions},
          {"success", rows}};
}

// The one file in `dir` named `stem` with any extension (source.ply, target.pcd, ...).
std::filesystem::path scene_file(const std::filesystem::path& dir, const std::string& stem) {
  std::vector<std::filesystem::path> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec))
    if (entry.path().stem() == stem && entry.path().has_extension()) found.push_back(entry.path());
  if (ec) throw IoError(dir, "cannot list the scene directory: " + ec.message());
  if (found.size() != 1)
    throw IoError(dir, (found.empty() ? "no " : "more than one ") + stem +
                           ".<ext> in the scene directory (expected source.*, target.* and "
                           "truth.txt)");
  return found[0];
}

// A scene of the user's: a directory with source.*, target.* (clouds) and truth.txt (target ≈
// T·source), the layout --scenes-only writes; named after the directory.
EvalScene scene_from_directory(const std::filesystem::path& dir, std::ostream& err) {
  EvalScene scene;
  const std::filesystem::path full = std::filesystem::absolute(dir).lexically_normal();
  scene.name = (full.has_filename() ? full : full.parent_path()).filename().string();
  auto load = [&](const std::string& role) {  // source.* or target.*, checked registrable
    const std::filesystem::path path = scene_file(dir, role);
    PointCloud cloud = load_cloud(path, err);
    try {
      check_registrable(cloud, role);
    } catch (const DataError& e) {
      throw DataError(path.string() + " (" + role + ")", e.problem());
    }
    return cloud;
  };
  scene.source = load("source");
  scene.target = load("target");
  scene.T_target_source = io::read_matrix(dir / "truth.txt");
  return scene;
}

// --scenes: each a built-in scene's name or else a scene directory (./chapter for a directory of
// that name); none: the four built-in ones.
std::vector<EvalScene> chosen_scenes(const EvaluateOptions& o, std::ostream& err) {
  if (o.scenes.empty()) return evaluation_scenes();
  std::vector<EvalScene> scenes;
  for (std::size_t begin = 0; begin <= o.scenes.size();) {
    const std::size_t end = std::min(o.scenes.find(',', begin), o.scenes.size());
    const std::string item = o.scenes.substr(begin, end - begin);
    begin = end + 1;
    if (item.empty()) throw UsageError("--scenes: an empty name in '" + o.scenes + "'");
    try {
      scenes.push_back(evaluation_scene(item));
    } catch (const std::invalid_argument& e) {
      if (!std::filesystem::is_directory(item))
        throw UsageError(std::string("--scenes: ") + e.what() + ", or a scene directory");
      scenes.push_back(scene_from_directory(item, err));
    }
    for (std::size_t i = 0; i + 1 < scenes.size(); ++i)
      if (scenes[i].name == scenes.back().name)
        throw UsageError("--scenes: two scenes named '" + scenes.back().name + "'");
  }
  return scenes;
}

// Every scene as files (OUTDIR/scenes/<name>/{source.ply,target.ply,truth.txt}), so that a peer
// (bench/compare_basin.py) can run on the same data; listed under "scenes" in the JSON.
nlohmann::json write_scenes(const std::filesystem::path& dir,
                            const std::vector<EvalScene>& scenes) {
  nlohmann::json list = nlohmann::json::array();
  for (const EvalScene& scene : scenes) {
    const std::filesystem::path rel = std::filesystem::path("scenes") / scene.name;
    std::error_code ec;
    std::filesystem::create_directories(dir / rel, ec);
    if (ec) throw OutputError(dir / rel, "cannot create directory: " + ec.message());
    io::write_point_cloud(dir / rel / "source.ply", scene.source);
    io::write_point_cloud(dir / rel / "target.ply", scene.target);
    io::write_matrix(dir / rel / "truth.txt", scene.T_target_source);
    list.push_back({{"name", scene.name},
                    {"source", (rel / "source.ply").generic_string()},
                    {"target", (rel / "target.ply").generic_string()},
                    {"truth", (rel / "truth.txt").generic_string()},
                    {"diagonal", bounding_box_diagonal(scene.target)}});
  }
  return list;
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
  const std::vector<EvalScene> scenes = chosen_scenes(o, io.err);  // before anything is written
  std::error_code ec;
  std::filesystem::create_directories(o.outdir, ec);
  if (ec) throw OutputError(o.outdir, "cannot create directory: " + ec.message());
  const std::filesystem::path dir(o.outdir);
  nlohmann::json json = {{"scenes", write_scenes(dir, scenes)}};
  if (o.scenes_only) {
    io::write_text_atomically(dir / "evaluation.json", json.dump(2) + "\n");
    if (!o.quiet) io.out << "wrote " << o.outdir << "/{evaluation.json,scenes/}\n";
    return 0;
  }
  json["trials"] = trials;
  json["seed"] = o.seed;
  std::ostringstream md;
  success_table(o, trials, scenes, io, md, json);

  // The basin on every scene, one figure per scene with a panel per method.
  json["basin"] = nlohmann::json::array();
  ProgressLine progress(io.err, o.quiet, "");
  for (const EvalScene& scene : scenes) {
    std::vector<report::HeatMap> panels;
    md << "\n## Convergence basin (" << scene.name
       << ")\n\nSuccess rate over the initial rotation angle (about the target's centroid) × "
          "translation (fraction of the diagonal) away from the truth, "
       << cell_trials << " trials per cell with random axes and directions.\n";
    for (const auto method : kMethods) {
      progress.set_label("basin: " + scene.name + ", " + to_string(method));
      const Basin b = convergence_basin(scene, method, angles, shifts, cell_trials, o.seed,
                                        o.threads, progress.callback());
      if (!o.quiet) io.out << "basin: " << scene.name << ", " << to_string(method) << ": done\n";
      panels.push_back(heat_map(method, b));
      basin_markdown(method, b, md);
      nlohmann::json entry = basin_json(method, b);
      entry["scene"] = scene.name;
      json["basin"].push_back(entry);
    }
    // Three panels a row: six in one row are too wide to read where the figure is shown.
    report::write_heatmaps(panels, "Convergence basin: " + scene.name,
                           dir / ("basin_" + scene.name), kBasinColumns);
  }
  io::write_text_atomically(dir / "evaluation.md", md.str());
  io::write_text_atomically(dir / "evaluation.json", json.dump(2) + "\n");
  if (!o.quiet)
    io.out << "\n"
           << md.str() << "\nwrote " << o.outdir
           << "/{evaluation.md,evaluation.json,basin_<scene>.svg,basin_<scene>.png} in "
           << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
           << " s\n";
  return 0;
}

}  // namespace

Command add_evaluate(CLI::App& app, Streams io) {
  auto o = std::make_shared<EvaluateOptions>();
  CLI::App* sub = app.add_subcommand(
      "evaluate",
      "Measure registration from arbitrary starting poses on the chapter scene, two object views "
      "against their whole surface (a bracket, a bumpy sphere; 60 % overlap, 5 % outliers) and "
      "two range scans of an animal 70° apart (61 % overlap, 5 % outliers): success rates of "
      "ICP alone (point-to-point, point-to-plane, GICP, symmetric), of global + ICP and of the "
      "default (init auto), and the convergence basin of each (heat maps, one figure per scene); "
      "or on the scenes --scenes names, your own among them.\n"
      "The full run takes about half an hour on 2 cores (progress on a terminal); --quick is a "
      "smoke test.");
  sub->add_option("OUTDIR", o->outdir, "Output directory")->capture_default_str();
  sub->add_option("--trials", o->trials, "Random poses per scene and method")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  sub->add_option("--cell-trials", o->cell_trials, "Trials per basin cell")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the random poses")
      ->check(CLI::NonNegativeNumber)  // CLI11 would wrap -1 to 2^64 - 1
      ->capture_default_str();
  sub->add_option("--scenes", o->scenes,
                  "Comma-separated scenes to run (default: all four): chapter, bracket, "
                  "bumpy-sphere, animal, or a directory of your own holding source.* and target.* "
                  "(clouds) and truth.txt (4x4, target ≈ T·source; the layout --scenes-only "
                  "writes), named after the directory (./chapter for a directory called chapter)");
  sub->add_flag("--quick", o->quick, "3 trials and a 2×2 basin: checks the machinery only");
  sub->add_flag("--scenes-only", o->scenes_only,
                "Only write the scenes (OUTDIR/scenes/<name>/source.ply, target.ply and truth.txt: "
                "target ≈ T·source) and evaluation.json listing them, for running a peer on the "
                "same data (bench/compare_basin.py); measures nothing");
  add_threads(sub, o->threads);
  add_quiet(sub, o->quiet);
  return {sub, [o, io] { return run_evaluate(*o, io); }};
}

}  // namespace align3d::cli
