// align() (align.hpp) and rectify() (plane/rectify.hpp) with the settings of `align3d register`
// and `align3d rectify`, returning the JSON report the command line writes, built by the same
// function (report/json.hpp): the package's Result.to_dict() is that report.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "align3d/align.hpp"
#include "align3d/coarse/ppf.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/plane/rectify.hpp"
#include "align3d/report/json.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

constexpr InitPolicy kInitPolicies[] = {InitPolicy::kAuto, InitPolicy::kIdentity,
                                        InitPolicy::kGlobal, InitPolicy::kPose};
constexpr GlobalMethod kGlobalMethods[] = {GlobalMethod::kFpfh, GlobalMethod::kPpf};

// A Python progress callback behind the library's (progress.hpp: called on the thread that called
// the library, which has released the GIL): takes the GIL for the call. A callback must not throw
// into the library, so the first Python exception is kept, later calls are skipped, and rethrow()
// raises it once the work is done.
class PythonProgress {
 public:
  explicit PythonProgress(py::object callback) : callback_(std::move(callback)) {}

  ProgressCallback callback() {
    if (callback_.is_none()) return {};
    return [this](const Progress& p) { call(p); };
  }

  void rethrow() {  // with the GIL held
    if (error_) throw *error_;
  }

 private:
  void call(const Progress& p) {
    py::gil_scoped_acquire gil;
    if (error_) return;
    try {
      callback_(p.task, p.done, p.total);
    } catch (py::error_already_set& e) {
      error_ = std::make_unique<py::error_already_set>(std::move(e));
    }
  }

  py::object callback_;
  std::unique_ptr<py::error_already_set> error_;
};

// The report text as the command line writes it (report::write_json).
std::string text(const nlohmann::json& report) { return report.dump(2) + "\n"; }

// What the report says of a target.
report::InputInfo target_info(const PointCloud& t, const std::string& path) {
  return {path, t.size()};
}
report::InputInfo target_info(const TriangleMesh& t, const std::string& path) {
  return {path, t.vertices.size(), t.triangles.size()};
}
report::InputInfo target_info(const PreparedTarget& t, const std::string& path) {
  if (t.surface()) return target_info(t.surface()->mesh(), path);
  return {path, t.size()};
}

// TARGET: a PointCloud, a TriangleMesh, or a PreparedTarget (the package's Target) built once for
// many sources.
template <class Target>
std::string register_clouds(const PointCloud& source, const Target& target, const std::string& init,
                            const py::object& initial_pose, const std::string& method,
                            const std::string& kernel, double kernel_scale,
                            const std::string& global_method,
                            const std::optional<std::filesystem::path>& ppf_model, double voxel,
                            std::uint64_t seed, bool mutual, const std::string& reject,
                            int max_iterations, double tolerance, int normal_k, bool model_error,
                            int threads, const py::object& ground_truth,
                            const std::string& source_path, const std::string& target_path,
                            double read_ms, const py::object& progress) {
  AlignSettings s;
  s.init = parse_choice("init", init, kInitPolicies);
  if (const auto T = pose(initial_pose, "init")) s.initial_pose = *T;
  set_cost(s.refine, method, kernel, kernel_scale);
  s.global.method = parse_choice("global_method", global_method, kGlobalMethods);
  try {
    s.refine.rejection = parse_rejection_rule(reject);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("reject: ") + e.what());
  }
  s.global.voxel = voxel;
  s.seed = seed;
  s.global.mutual_filter = mutual;
  s.refine.termination.max_iterations = max_iterations;
  s.refine.termination.rms_change = tolerance;
  s.refine.normals.k = normal_k;
  s.refine.model_error = model_error;
  s.threads = threads;
  const std::optional<Eigen::Isometry3d> truth = pose(ground_truth, "ground_truth");

  PythonProgress python_progress(progress);
  s.progress = python_progress.callback();
  std::optional<PpfModel> model;
  nlohmann::json report;
  {
    py::gil_scoped_release release;
    if (ppf_model) {
      model = load_ppf_model(*ppf_model);
      s.ppf_model = &*model;
    }
    const AlignResult r = align(source, target, s);
    report = report::registration_report(r, s, {source_path, source.size()},
                                         target_info(target, target_path), truth);
  }
  python_progress.rethrow();
  report["timing_ms"]["read"] = read_ms;  // as `align3d register` adds it
  return text(report);
}

std::string rectify_cloud(const PointCloud& cloud, const std::string& fit,
                          const std::optional<Eigen::Vector3d>& up, std::uint64_t seed,
                          const std::string& cloud_path) {
  RectifySettings s;
  if (fit != "robust" && fit != "lsq")
    throw std::invalid_argument("fit: expected one of 'robust', 'lsq', got '" + fit + "'");
  s.robust = fit == "robust";
  s.up = up;
  s.ransac.seed = seed;
  py::gil_scoped_release release;
  const RectifyResult r = rectify(cloud, s);
  return text(report::rectify_report(r, s, {cloud_path, cloud.size()}));
}

// Every default of the two functions, from the library's settings structs (declared once there).
py::dict defaults() {
  const AlignSettings a;
  const RectifySettings r;
  return py::dict(
      py::arg("register") = py::dict(
          py::arg("init") = to_string(a.init), py::arg("method") = to_string(a.refine.method),
          py::arg("kernel") = kernel_name(a.refine),
          py::arg("kernel_scale") = a.refine.kernel_scale,
          py::arg("global_method") = to_string(a.global.method), py::arg("voxel") = a.global.voxel,
          py::arg("seed") = a.seed, py::arg("mutual") = a.global.mutual_filter,
          py::arg("reject") = to_string(a.refine.rejection),
          py::arg("max_iterations") = a.refine.termination.max_iterations,
          py::arg("tolerance") = a.refine.termination.rms_change,
          py::arg("normal_k") = a.refine.normals.k, py::arg("model_error") = a.refine.model_error,
          py::arg("threads") = a.threads),
      py::arg("rectify") =
          py::dict(py::arg("fit") = r.robust ? "robust" : "lsq", py::arg("seed") = r.ransac.seed));
}

// The package's Target: a PreparedTarget built with the GIL released.
void bind_target(py::module_& m) {
  py::class_<PreparedTarget>(m, "Target")
      .def(py::init([](const PointCloud& cloud, int normal_k, int threads) {
             if (normal_k < 3) throw std::invalid_argument("normal_k: must be at least 3");
             if (threads < 0) throw std::invalid_argument("threads: must be >= 0 (0: all cores)");
             NormalSettings ns;
             ns.k = normal_k;
             py::gil_scoped_release release;
             return PreparedTarget(cloud, ns, threads);
           }),
           py::arg("cloud"), py::kw_only(), py::arg("normal_k"), py::arg("threads"))
      .def(py::init([](const TriangleMesh& mesh, int threads) {
             if (threads < 0) throw std::invalid_argument("threads: must be >= 0 (0: all cores)");
             py::gil_scoped_release release;
             return PreparedTarget(mesh, threads);
           }),
           py::arg("mesh"), py::kw_only(), py::arg("threads"))
      .def("__len__", &PreparedTarget::size)
      .def_property_readonly("is_mesh",
                             [](const PreparedTarget& t) { return t.surface() != nullptr; })
      .def_property_readonly("normal_k", &PreparedTarget::normal_k);
}

template <class Target>
void def_register(py::module_& m) {
  m.def("register", &register_clouds<Target>, py::arg("source"), py::arg("target"), py::kw_only(),
        py::arg("init"), py::arg("initial_pose"), py::arg("method"), py::arg("kernel"),
        py::arg("kernel_scale"), py::arg("global_method"), py::arg("ppf_model"), py::arg("voxel"),
        py::arg("seed"), py::arg("mutual"), py::arg("reject"), py::arg("max_iterations"),
        py::arg("tolerance"), py::arg("normal_k"), py::arg("model_error"), py::arg("threads"),
        py::arg("ground_truth"), py::arg("source_path"), py::arg("target_path"), py::arg("read_ms"),
        py::arg("progress"));
}

}  // namespace

std::optional<Eigen::Isometry3d> pose(const py::object& value, const std::string& what) {
  if (value.is_none()) return std::nullopt;
  if (py::isinstance<py::str>(value)) return io::read_matrix(value.cast<std::string>());
  return rigid(value.cast<Eigen::Matrix4d>(), what);
}

void set_cost(CostSettings& cost, const std::string& method, const std::string& kernel,
              double kernel_scale) {
  cost.method = parse_choice("method", method, kIcpMethods);
  set_kernel(cost, kernel, kernel_scale);
}

void bind_register(py::module_& m) {
  bind_target(m);
  def_register<PointCloud>(m);
  def_register<TriangleMesh>(m);
  def_register<PreparedTarget>(m);
  m.def("rectify", &rectify_cloud, py::arg("cloud"), py::kw_only(), py::arg("fit"), py::arg("up"),
        py::arg("seed"), py::arg("cloud_path"));
  m.def("defaults", &defaults);
}

}  // namespace align3d::python
