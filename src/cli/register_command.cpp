// align3d register SOURCE TARGET: align() (align.hpp) from the command line (README, "align3d
// register"; the report's keys: docs/report.md).
#include <chrono>
#include <cmath>
#include <iomanip>
#include <optional>

#include "align3d/align.hpp"
#include "align3d/coarse/ppf.hpp"
#include "align3d/error.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/se3.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

// Options that are not fields of AlignSettings, and those given as text. Every default comes from
// the library's settings structs (declared once there).
struct RegisterOptions {
  std::string source, target;
  RefineOptions refine;
  std::string init = to_string(AlignSettings{}.init);
  std::string global = to_string(AlignSettings{}.global.method);
  std::string reject = to_string(AlignSettings{}.refine.rejection);
  std::string output, report, ground_truth, ppf_model;
  bool strict = false, quiet = false;
  AlignSettings settings;
};

// The settings from the options; reads --init FILE and --ppf-model FILE.
AlignSettings settings_from(RegisterOptions& o, std::optional<PpfModel>& model) {
  AlignSettings s = o.settings;
  apply_refine_options(o.refine, s.refine);
  try {
    s.refine.rejection = parse_rejection_rule(o.reject);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--reject: ") + e.what());
  }
  s.global.method = o.global == "ppf" ? GlobalMethod::kPpf : GlobalMethod::kFpfh;
  apply_init(o.init, s);
  if (!o.ppf_model.empty()) {
    if (s.init != InitPolicy::kGlobal && s.init != InitPolicy::kAuto)
      throw UsageError("--ppf-model needs --init global or auto (it feeds the global stage)");
    if (s.global.voxel > 0)
      throw UsageError(
          "--voxel with --ppf-model: the model's voxel was fixed when it was built "
          "(align3d ppf-model --voxel)");
    model = load_ppf_model(o.ppf_model);
    s.ppf_model = &*model;
  }
  return s;
}

// A DataError about "source" or "target" names the file instead.
[[noreturn]] void rethrow_naming_files(const DataError& e, const RegisterOptions& o) {
  if (e.subject() == "source") throw DataError(o.source + " (source)", e.problem());
  if (e.subject() == "target") throw DataError(o.target + " (target)", e.problem());
  throw e;
}

void print_summary(std::ostream& out, const RegisterOptions& o, const AlignResult& r,
                   const nlohmann::json& report, std::size_t source_points,
                   const report::InputInfo& target) {
  const Eigen::Isometry3d& T = r.transformation;
  const IcpResult& icp = r.refine.icp;
  out << std::fixed << std::setprecision(6);
  out << "registered " << o.source << " (" << source_points << " points) onto " << o.target << " ("
      << (target.triangles > 0 ? std::to_string(target.triangles) + " triangles, its exact surface"
                               : std::to_string(target.points) + " points")
      << ")\n";
  out << "  init " << o.init << ": kept the answer from the " << r.path
      << (r.path == "global" ? " registration" : " pose");
  if (!r.reason.empty()) out << " (global registration ran because " << r.reason << ")";
  out << "\n  converged: " << (icp.converged ? "yes" : "no") << " (" << to_string(icp.stop_reason)
      << ") after " << r.refine.total_iterations << " iterations, " << std::setprecision(1)
      << r.timings.total_ms << " ms\n";
  if (r.global)
    out << "  global (" << to_string(r.global->method)
        << "): " << (r.global->success ? "" : "FAILED, ") << "overlap " << std::setprecision(3)
        << r.global->overlap << ", " << r.global->candidates << " candidates, "
        << std::setprecision(1) << r.global->time_ms << " ms"
        << (r.global->ambiguous ? ", AMBIGUOUS" : "") << "\n";
  out << std::setprecision(6) << "  rms " << icp.rms << ", fitness " << icp.fitness << " ("
      << icp.correspondences << " pairs); support: " << std::setprecision(1)
      << 100 * r.support.overlap << " % of the " << to_string(r.support.object)
      << " on the other's surface, noise " << std::setprecision(6) << r.support.noise << "\n";
  out << "  rotation " << rad_to_deg(rotation_angle(T.linear())) << " deg, translation ["
      << T.translation().x() << ", " << T.translation().y() << ", " << T.translation().z() << "]\n";
  if (report.contains("rotation_error_deg"))
    out << "  error vs ground truth: rotation " << report["rotation_error_deg"].get<double>()
        << " deg, translation " << report["translation_error"].get<double>() << "\n";
  out << "  T (target ≈ T·source):\n";
  for (int i = 0; i < 4; ++i)
    out << "    " << T.matrix()(i, 0) << " " << T.matrix()(i, 1) << " " << T.matrix()(i, 2) << " "
        << T.matrix()(i, 3) << "\n";
  out << std::defaultfloat;
}

int run_register(RegisterOptions& o, Streams io) {
  const auto start_read = std::chrono::steady_clock::now();
  const PointCloud source = load_cloud(o.source, io.err);
  const TargetInput target = load_target(o.target, io.err);
  std::optional<Eigen::Isometry3d> truth;
  if (!o.ground_truth.empty()) truth = io::read_matrix(o.ground_truth);
  std::optional<PpfModel> model;
  AlignSettings settings = settings_from(o, model);
  const double read_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_read)
          .count();

  ProgressLine progress(io.err, o.quiet, "register");
  settings.progress = progress.callback();
  AlignResult r;
  try {
    r = target.mesh ? align(source, *target.mesh, settings) : align(source, target.cloud, settings);
  } catch (const DataError& e) {
    rethrow_naming_files(e, o);
  }
  nlohmann::json report = report::registration_report(r, settings, {o.source, source.size()},
                                                      target.info(o.target), truth);
  report["timing_ms"]["read"] = read_ms;
  if (r.success && !o.output.empty())
    io::write_point_cloud(o.output, transformed(source, r.transformation));
  if (!o.report.empty()) write_json(o.report, report, io.out);
  if (!r.success) {
    report_warnings(r.warnings, false, io.err);
    throw Error(ExitCode::kNoSolution, o.source + ": no solution: " + r.failure);
  }
  if (o.report != "-" && !o.quiet)
    print_summary(io.out, o, r, report, source.size(), target.info(o.target));
  return report_warnings(r.warnings, o.strict, io.err);
}

}  // namespace

Command add_register(CLI::App& app, Streams io) {
  auto o = std::make_shared<RegisterOptions>();
  AlignSettings& s = o->settings;
  CLI::App* sub = app.add_subcommand(
      "register",
      "Register SOURCE (the measured scan) onto TARGET (the model): prints T with target ≈ "
      "T·source.\n"
      "Default: ICP from the identity (the robust coarse-to-fine schedule, --reject auto, ending "
      "in point-to-plane); when that answer is not well supported (less than half of the "
      "smaller cloud on the other's surface, residuals above those a right pose leaves, free "
      "directions, no convergence), global "
      "registration runs too and the better supported answer is kept, and when that does not "
      "help, ICP from the identity again with basin hopping (--init auto). Distances "
      "scale with the data: the global stage's sampling follows the smaller cloud (the object), "
      "ICP's the target's spacing. A result that may still be wrong is reported with warnings on "
      "stderr and in the report; --strict makes them exit code 7.");
  sub->add_option("SOURCE", o->source, "Source cloud (.ply .pcd .xyz .txt .csv), moved onto TARGET")
      ->required();
  sub->add_option("TARGET", o->target,
                  "Target: a cloud, the fixed reference, or a mesh (.stl .obj .off .step .iges, a "
                  ".ply with faces: a CAD model, registered onto its exact surface)")
      ->required();
  add_refine_options(sub, o->refine, schedule_refine_help());
  add_init(sub, o->init, "a file with a 4x4 matrix (4 rows of 4 numbers; ICP starts there)");
  sub->add_option("--global", o->global,
                  "Global method: fpfh (descriptors + RANSAC) or ppf (point pair features, "
                  "model-to-scene; the model is the smaller cloud)")
      ->check(CLI::IsMember({"fpfh", "ppf"}))
      ->capture_default_str();
  sub->add_option("--ppf-model", o->ppf_model,
                  "A description of TARGET saved by `align3d ppf-model` (the global stage then "
                  "uses ppf)");
  sub->add_option("--voxel", s.global.voxel,
                  "Voxel of the global stage, for every method (data units); 0: the smaller "
                  "cloud's extent / 50 (its bulk: 0.5-99.5 percentiles), at least 3 point spacings")
      ->check(finite_non_negative())
      ->capture_default_str();
  add_seed(sub, s.seed);
  sub->add_flag("--mutual", s.global.mutual_filter,
                "fpfh: keep only mutual descriptor nearest neighbours (fewer, cleaner matches)");
  sub->add_option("--reject", o->reject,
                  "Correspondence rejection: auto (coarse-to-fine schedule scaled to the data), "
                  "median[:FACTOR[:FLOOR]] (keep d <= max(FACTOR*median, FLOOR); the chapter uses "
                  "median:2.5:0.5), distance:D (data units), none")
      ->capture_default_str();
  sub->add_option("--max-iterations", s.refine.termination.max_iterations,
                  "Iteration cap (with auto: of the final stage; coarse stages cap at 30 each)")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  sub->add_option("--tolerance", s.refine.termination.rms_change,
                  "Stop when |ΔRMS| < EPS·RMS between iterations (relative, so unit-free); ICP "
                  "also stops when an update is negligible")
      ->check(CLI::PositiveNumber & finite_non_negative())
      ->capture_default_str();
  sub->add_option("--output", o->output,
                  "Write SOURCE moved into TARGET's frame (binary PLY or by extension)");
  sub->add_option("--report", o->report,
                  "Write a JSON report to FILE, or to stdout with - (keys: docs/report.md)");
  sub->add_option("--ground-truth", o->ground_truth,
                  "4x4 matrix file of the true T; adds rotation_error_deg and translation_error");
  sub->add_option("--normal-k", s.refine.normals.k, "Neighbours for PCA normals of the target")
      ->check(CLI::Range(3, 1000))
      ->capture_default_str();
  sub->add_flag("--model-error", s.refine.model_error,
                "The covariance also takes in point-to-plane's (and point-to-point's) model error: "
                "a tangent plane misses a curved surface, which biases the pose by an amount the "
                "residuals do not show (report: covariance). Needs the source's normals: about a "
                "third more time on two 40 000-point scans; gicp and symmetric have none to add");
  add_strict(sub, o->strict);
  add_quiet(sub, o->quiet);
  add_threads(sub, s.threads);
  return {sub, [o, io] { return run_register(*o, io); }};
}

}  // namespace align3d::cli
