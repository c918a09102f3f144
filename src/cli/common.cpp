#include "common.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sstream>
#include <string_view>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "detail/number.hpp"

namespace align3d::cli {

PointCloud load_cloud(const std::filesystem::path& path, std::ostream& err, io::ReadInfo* info) {
  io::ReadInfo read;
  PointCloud cloud = io::read_point_cloud(path, &read);
  if (read.dropped_non_finite > 0)
    err << "align3d: warning: " << path.string() << ": dropped " << read.dropped_non_finite
        << " points with NaN or Inf coordinates\n";
  if (info != nullptr) *info = read;
  return cloud;
}

TriangleMesh load_mesh(const std::filesystem::path& path, std::ostream& err,
                       const io::MeshReadSettings& settings, io::MeshReadInfo* info) {
  io::MeshReadInfo read;
  TriangleMesh mesh = io::read_mesh(path, settings, &read);
  if (read.dropped_faces > 0)
    err << "align3d: warning: " << path.string() << ": dropped " << read.dropped_faces
        << " faces with fewer than 3 distinct corners\n";
  if (info != nullptr) *info = read;
  return mesh;
}

report::InputInfo TargetInput::info(const std::string& path) const {
  if (mesh) return {path, mesh->vertices.size(), mesh->triangles.size()};
  return {path, cloud.size(), 0};
}

TargetInput load_target(const std::filesystem::path& path, std::ostream& err,
                        const io::MeshReadSettings& settings) {
  TargetInput t;
  if (io::is_mesh_file(path))
    t.mesh = load_mesh(path, err, settings);
  else
    t.cloud = load_cloud(path, err);
  return t;
}

void apply_init(const std::string& init, AlignSettings& s) {
  if (init == "auto") {
    s.init = InitPolicy::kAuto;
  } else if (init == "identity") {
    s.init = InitPolicy::kIdentity;
  } else if (init == "global") {
    s.init = InitPolicy::kGlobal;
  } else {
    s.init = InitPolicy::kPose;
    s.initial_pose = io::read_matrix(init);
  }
}

Eigen::Vector3d parse_vector(const std::string& text, const std::string& flag) {
  Eigen::Vector3d v;
  std::string_view rest = text;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = rest.find(',');
    // Exactly three parts: a fourth ("1,2,3,4") or a trailing comma leaves a comma after the third.
    const bool last = i == 2;
    const std::optional<double> x = (last == (comma == std::string_view::npos))
                                        ? detail::parse_finite(rest.substr(0, comma))
                                        : std::nullopt;
    if (!x) throw UsageError(flag + ": expected X,Y,Z (three finite numbers), got '" + text + "'");
    v[i] = *x;
    if (!last) rest.remove_prefix(comma + 1);
  }
  return v;
}

int report_warnings(const std::vector<Warning>& warnings, bool strict, std::ostream& err) {
  for (const Warning& w : warnings) err << "align3d: warning: " << w.message << "\n";
  return strict && !warnings.empty() ? static_cast<int>(ExitCode::kWarnings) : 0;
}

ProgressLine::ProgressLine(std::ostream& err, bool quiet, std::string label)
    : err_(err),
      shown_(!quiet && &err == &std::cerr && isatty(STDERR_FILENO) == 1),
      label_(std::move(label)),
      start_(Clock::now()),
      task_start_(start_),
      last_draw_(start_) {}

ProgressLine::~ProgressLine() {
  if (drawn_) err_ << "\r\033[K" << std::flush;
}

ProgressCallback ProgressLine::callback() {
  if (!shown_) return {};
  return [this](const Progress& p) { update(p); };
}

void ProgressLine::update(const Progress& p) {
  const auto now = Clock::now();
  if (p.task != task_ || p.done < last_done_) {  // a new task, or the same one started again
    task_ = p.task;
    task_start_ = now;
  } else if (now - last_draw_ < std::chrono::milliseconds(200)) {
    return;
  }
  last_draw_ = now;
  last_done_ = p.done;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double in_task = std::chrono::duration<double>(now - task_start_).count();
  char line[256];
  int n = std::snprintf(line, sizeof line, "%s: %s", label_.c_str(), p.task.c_str());
  if (p.total > 0 && n > 0 && static_cast<std::size_t>(n) < sizeof line) {
    n += std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), " %zu/%zu", p.done,
                       p.total);
    if (p.done > 0 && in_task > 0 && static_cast<std::size_t>(n) < sizeof line) {
      const double rate = static_cast<double>(p.done) / in_task;
      const auto eta = static_cast<long>(static_cast<double>(p.total - p.done) / rate);
      std::snprintf(line + n, sizeof line - static_cast<std::size_t>(n), ", %.2g/s, ETA %ld:%02ld",
                    rate, eta / 60, eta % 60);
    }
  }
  err_ << "\r\033[K" << line << "  [" << static_cast<long>(elapsed) << " s]" << std::flush;
  drawn_ = true;
}

void add_quiet(CLI::App* sub, bool& quiet) {
  sub->add_flag("--quiet", quiet,
                "No progress line and no summary on stdout (warnings and errors still go to "
                "stderr)");
}

void add_init(CLI::App* sub, std::string& init, const std::string& matrix_file) {
  sub->add_option("--init", init,
                  "Initial pose: auto (ICP from the identity, global registration too when that "
                  "is weak), identity, global (global registration first: any starting pose), or " +
                      matrix_file)
      ->capture_default_str();
}

void add_strict(CLI::App* sub, bool& strict) {
  sub->add_flag("--strict", strict,
                "Exit with code 7 when the result comes with warnings (outputs are written)");
}

RefineHelp schedule_refine_help() {
  return {"the final stage of the coarse-to-fine schedule (its coarse stages are point-to-plane)",
          "the schedule's own (Geman-McClure at half the stage's reach; none with a fixed --reject "
          "rule)"};
}

void add_refine_options(CLI::App* sub, RefineOptions& o, const RefineHelp& help) {
  std::vector<std::string> methods, kernels{"auto"};
  for (IcpMethod m : kAllIcpMethods) methods.push_back(to_string(m));
  for (RobustKernel k : kAllKernels) kernels.push_back(to_string(k));
  sub->add_option("--method", o.method,
                  "ICP metric of " + help.method_applies_to +
                      ": point-to-point, point-to-plane, gicp (plane-to-plane with per-point "
                      "covariances, as small_gicp) or symmetric (Rusinkiewicz 2019). gicp and "
                      "symmetric need source normals, estimated when the file has none")
      ->check(CLI::IsMember(methods))
      ->capture_default_str();
  sub->add_option("--kernel", o.kernel,
                  "Robust kernel weighing ICP's pairs: none, huber, cauchy, geman-mcclure, tukey, "
                  "welsch; auto: " +
                      help.auto_kernel)
      ->check(CLI::IsMember(kernels))
      ->capture_default_str();
  sub->add_option("--kernel-scale", o.kernel_scale,
                  "Scale of --kernel (data units); 0: from the noise (the kernel's 95 %-efficiency "
                  "constant × the residuals' σ: 1.345 huber, 2.385 cauchy, 2 geman-mcclure, 4.685 "
                  "tukey, 2.985 welsch)")
      ->check(finite_non_negative())
      ->capture_default_str();
}

void apply_refine_options(const RefineOptions& o, CostSettings& s) {
  s.method = icp_method_from_string(o.method).value_or(s.method);
  try {
    set_kernel(s, o.kernel, o.kernel_scale);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--kernel, --kernel-scale: ") + e.what());
  }
}

void add_seed(CLI::App* sub, std::uint64_t& seed) {
  sub->add_option("--seed", seed, "Seed of the global stage (same seed, same pose)")
      ->check(CLI::NonNegativeNumber)  // CLI11 would wrap -1 to 2^64 - 1
      ->capture_default_str();
}

void add_threads(CLI::App* sub, int& threads) {
  sub->add_option("--threads", threads, "Threads (0: all cores); results do not depend on it")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
}

const CLI::Validator& finite_non_negative() {
  static const CLI::Validator validator(
      [](const std::string& text) -> std::string {
        const std::optional<double> v = detail::parse_finite(text);
        if (v && *v >= 0) return {};
        return "expected a finite non-negative number, got '" + text + "'";
      },
      "finite >= 0");
  return validator;
}

}  // namespace align3d::cli
