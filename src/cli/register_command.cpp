// align3d register SOURCE TARGET: the contract of issue #2 (README, "align3d register").
#include <chrono>
#include <cmath>
#include <iomanip>

#include "align3d/coarse/global.hpp"
#include "align3d/coarse/ppf.hpp"
#include "align3d/error.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/registration.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct RegisterOptions {
  std::string source, target;
  std::string method = "point-to-plane";
  std::string init = "identity";
  std::string reject = "auto";
  int max_iterations = 60;
  double tolerance = 1e-5;
  std::string output, report, ground_truth;
  int normal_k = 20;
  int threads = 0;
  std::string global = "fpfh";
  std::string ppf_model;
  double voxel = 0;
  std::uint64_t seed = 1;
  bool mutual = false;
};

nlohmann::json global_json(const GlobalResult& g) {
  nlohmann::json j = {{"method", to_string(g.method)},
                      {"success", g.success},
                      {"time_ms", g.time_ms},
                      {"score", g.score},
                      {"overlap", g.overlap},
                      {"candidates", g.candidates},
                      {"voxel", g.voxel},
                      {"transformation", to_json(g.T_target_source)},
                      {"ambiguous", g.ambiguous}};
  if (g.ambiguous) {
    j["second_transformation"] = to_json(g.second_T);
    j["second_score"] = g.second_score;
  }
  if (!g.message.empty()) j["message"] = g.message;
  return j;
}

// The coarse stage of --init global: a saved PPF model, or a method run on SOURCE and TARGET.
GlobalResult run_global(const RegisterOptions& o, const PointCloud& source,
                        const PointCloud& target) {
  GlobalSettings gs;
  gs.method = o.global == "ppf" ? GlobalMethod::kPpf : GlobalMethod::kFpfh;
  gs.voxel = o.voxel;
  gs.seed = o.seed;
  gs.threads = o.threads;
  gs.mutual_filter = o.mutual;
  if (o.ppf_model.empty()) return global_register(source, target, gs);
  const PpfModel model = load_ppf_model(o.ppf_model);
  const auto start = std::chrono::steady_clock::now();
  GlobalResult g = ppf_match(model, source, gs);
  g.method = GlobalMethod::kPpf;
  g.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return g;
}

nlohmann::json registration_json(const RegistrationResult& r, const RegisterOptions& o,
                                 std::size_t source_points, std::size_t target_points) {
  const IcpResult& f = r.icp;
  const Eigen::Isometry3d& T = f.T_target_source;
  // nlohmann writes a non-finite threshold (rejection none) as null.
  nlohmann::json history = nlohmann::json::array();
  for (const auto& h : r.history)
    history.push_back({{"rms", h.rms}, {"kept", h.kept}, {"threshold", h.threshold}});
  nlohmann::json stages = nlohmann::json::array();
  nlohmann::json weak = nlohmann::json::array();
  for (const auto& w : f.degenerate_directions)
    weak.push_back({{"rotation", to_json(w.rotation)},
                    {"translation", to_json(w.translation)},
                    {"strength", w.strength}});
  for (const auto& s : r.stages)
    stages.push_back({{"metric", s.metric},
                      {"max_distance", s.max_distance},
                      {"first_iteration", s.first_iteration},
                      {"iterations", s.iterations}});
  return {{"source", {{"path", o.source}, {"points", source_points}}},
          {"target", {{"path", o.target}, {"points", target_points}}},
          {"method", o.method},
          {"rejection", o.reject},
          {"transformation", to_json(T)},
          {"rotation_deg", rad_to_deg(rotation_angle(T.linear()))},
          {"translation", to_json(T.translation())},
          {"iterations", r.total_iterations},
          {"converged", f.converged},
          {"stop_reason", to_string(f.stop_reason)},
          {"rms", f.rms},
          {"fitness", f.fitness},
          {"correspondences", f.correspondences},
          {"degenerate_directions", weak},
          {"history", history},
          {"stages", stages}};
}

int run_register(const RegisterOptions& o, Streams io) {
  const auto start_read = std::chrono::steady_clock::now();
  const PointCloud source = load_cloud(o.source, io.err);
  const PointCloud target = load_cloud(o.target, io.err);
  const bool global = o.init == "global";
  if (!o.ppf_model.empty() && !(global && o.global == "ppf"))
    throw UsageError("--ppf-model needs --init global --global ppf");
  Eigen::Isometry3d init =
      o.init == "identity" || global ? Eigen::Isometry3d::Identity() : io::read_matrix(o.init);
  std::optional<Eigen::Isometry3d> truth;
  if (!o.ground_truth.empty()) truth = io::read_matrix(o.ground_truth);
  // Checked here as well as in register_clouds so that the message names the file, not the role.
  check_registrable(source, o.source + " (source)");
  check_registrable(target, o.target + " (target)");

  RegistrationSettings settings;
  settings.method =
      o.method == "point-to-point" ? IcpMethod::kPointToPoint : IcpMethod::kPointToPlane;
  if (o.reject != "auto") {
    try {
      settings.rejection = parse_rejection_rule(o.reject);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--reject: ") + e.what());
    }
  }
  settings.max_iterations = o.max_iterations;
  settings.tolerance = o.tolerance;
  settings.normals.k = o.normal_k;
  settings.threads = o.threads;

  const auto start = std::chrono::steady_clock::now();
  const auto ms = [](auto a, auto b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  std::optional<GlobalResult> coarse;
  if (global) {
    coarse = run_global(o, source, target);
    if (!coarse->success) {
      // Honest failure: no ICP from a pose without support (it would end with a good-looking fit).
      if (!o.report.empty())
        write_json(o.report,
                   {{"success", false}, {"converged", false}, {"global", global_json(*coarse)}},
                   io.out);
      throw Error(ExitCode::kNoSolution,
                  o.source + ": global registration found no pose: " + coarse->message);
    }
    if (coarse->ambiguous)
      io.err << "align3d: warning: ambiguous pose (a distinct pose scores " << coarse->second_score
             << " against " << coarse->score
             << "; a symmetric part?): see \"global\" in the report\n";
    init = coarse->T_target_source;
  }
  const RegistrationResult r = register_clouds(source, target, init, settings);
  const auto end = std::chrono::steady_clock::now();

  nlohmann::json report = registration_json(r, o, source.size(), target.size());
  report["timing_ms"] = {{"total", ms(start, end)}, {"read", ms(start_read, start)}};
  if (r.estimated_normals > 0) {
    report["normals"] = {{"estimated", r.estimated_normals}, {"undefined", r.undefined_normals}};
  }
  if (coarse) report["global"] = global_json(*coarse);
  const Eigen::Isometry3d& T = r.icp.T_target_source;
  if (truth) {
    const Eigen::Matrix3d dR = T.linear().transpose() * truth->linear();
    report["rotation_error_deg"] = rad_to_deg(rotation_angle(dR));
    report["translation_error"] = (T.translation() - truth->translation()).norm();
  }
  const bool failed = r.icp.stop_reason == StopReason::kTooFewCorrespondences;
  report["success"] = !failed;

  if (!failed && !o.output.empty()) io::write_point_cloud(o.output, transformed(source, T));
  if (!o.report.empty()) write_json(o.report, report, io.out);
  if (o.report != "-") {
    auto& out = io.out;
    out << std::setprecision(6) << std::fixed;
    out << "registered " << o.source << " (" << source.size() << " points) onto " << o.target
        << " (" << target.size() << " points)\n";
    out << "  converged: " << (r.icp.converged ? "yes" : "no") << " ("
        << to_string(r.icp.stop_reason) << ") after " << r.total_iterations << " iterations, "
        << std::setprecision(1) << report["timing_ms"]["total"].get<double>() << " ms\n";
    if (coarse)
      out << "  global (" << to_string(coarse->method) << "): overlap " << coarse->overlap << ", "
          << coarse->candidates << " candidates, " << std::setprecision(1) << coarse->time_ms
          << " ms" << (coarse->ambiguous ? ", AMBIGUOUS" : "") << std::setprecision(6) << "\n";
    out << std::setprecision(6) << "  rms " << r.icp.rms << ", fitness " << r.icp.fitness << " ("
        << r.icp.correspondences << " pairs)\n";
    out << "  rotation " << report["rotation_deg"].get<double>() << " deg, translation ["
        << T.translation().x() << ", " << T.translation().y() << ", " << T.translation().z()
        << "]\n";
    if (truth)
      out << "  error vs ground truth: rotation " << report["rotation_error_deg"].get<double>()
          << " deg, translation " << report["translation_error"].get<double>() << "\n";
    out << "  T (target ≈ T·source):\n";
    for (int i = 0; i < 4; ++i)
      out << "    " << T.matrix()(i, 0) << " " << T.matrix()(i, 1) << " " << T.matrix()(i, 2) << " "
          << T.matrix()(i, 3) << "\n";
    out << std::defaultfloat;
  }
  if (failed)
    throw Error(ExitCode::kNoSolution,
                o.source +
                    ": registration failed: too few correspondences within the rejection "
                    "threshold (try --reject auto or a larger distance)");
  if (!r.icp.degenerate_directions.empty())
    io.err << "align3d: warning: the geometry does not constrain "
           << r.icp.degenerate_directions.size()
           << " direction(s) of the pose (a plane, a cylinder, ...); the pose was not moved along "
              "them (report: degenerate_directions)\n";
  if (!r.icp.converged)
    io.err << "align3d: warning: did not converge (" << to_string(r.icp.stop_reason)
           << "); the pose may be inaccurate\n";
  return 0;
}

}  // namespace

Command add_register(CLI::App& app, Streams io) {
  auto o = std::make_shared<RegisterOptions>();
  CLI::App* sub = app.add_subcommand(
      "register",
      "Register SOURCE (the measured scan) onto TARGET (the model): prints T with target ≈ "
      "T·source.\n"
      "Default: the robust coarse-to-fine schedule (--reject auto) ending in point-to-plane ICP.");
  sub->add_option("SOURCE", o->source, "Source cloud (.ply .pcd .xyz .txt .csv), moved onto TARGET")
      ->required();
  sub->add_option("TARGET", o->target, "Target cloud, the fixed reference (e.g. the model)")
      ->required();
  sub->add_option("--method", o->method, "Final ICP metric")
      ->check(CLI::IsMember({"point-to-point", "point-to-plane"}))
      ->capture_default_str();
  sub->add_option("--init", o->init,
                  "Initial pose: identity, global (coarse registration first: any starting pose), "
                  "or a file with a 4x4 matrix (4 rows of 4)")
      ->capture_default_str();
  sub->add_option("--global", o->global,
                  "Coarse method for --init global: fpfh (descriptors + RANSAC) or ppf (point pair "
                  "features, model-to-scene)")
      ->check(CLI::IsMember({"fpfh", "ppf"}))
      ->capture_default_str();
  sub->add_option("--ppf-model", o->ppf_model,
                  "A model description saved by `align3d ppf-model` (with --global ppf)");
  sub->add_option("--voxel", o->voxel,
                  "Voxel size of the coarse stage (data units); 0: the target's diagonal / 50")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--seed", o->seed, "Seed of the coarse stage (same seed, same pose)")
      ->capture_default_str();
  sub->add_flag("--mutual", o->mutual,
                "fpfh: keep only mutual descriptor nearest neighbours (fewer, cleaner matches)");
  sub->add_option("--reject", o->reject,
                  "Correspondence rejection: auto (robust schedule scaled to the data), "
                  "median[:FACTOR[:FLOOR]] (keep d <= max(FACTOR*median, FLOOR); the chapter uses "
                  "median:2.5:0.5), distance:D (data units), none")
      ->capture_default_str();
  sub->add_option("--max-iterations", o->max_iterations,
                  "Iteration cap (with auto: of the final stage; coarse stages cap at 30 each)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  sub->add_option(
         "--tolerance", o->tolerance,
         "Stop when |ΔRMS| < EPS·RMS between iterations (relative, so unit-free); ICP also "
         "stops when an update is negligible")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_option("--output", o->output,
                  "Write SOURCE moved into TARGET's frame (binary PLY or by extension)");
  sub->add_option("--report", o->report, "Write a JSON report to FILE, or to stdout with -");
  sub->add_option("--ground-truth", o->ground_truth,
                  "4x4 matrix file of the true T; adds rotation_error_deg and translation_error");
  sub->add_option("--normal-k", o->normal_k, "Neighbours for PCA normals of the target")
      ->check(CLI::Range(3, 1000))
      ->capture_default_str();
  sub->add_option("--threads", o->threads, "Threads (0: all cores); results do not depend on it")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  return {sub, [o, io] { return run_register(*o, io); }};
}

}  // namespace align3d::cli
