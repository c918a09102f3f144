// inspect() (inspect.hpp) with the settings of `align3d inspect`, returning the JSON report the
// command line writes (report::inspection_report) and the per-point arrays, and writing the files
// asked for with the command line's writers (report/deviation_files.hpp).
#include "align3d/inspect.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cstring>
#include <optional>
#include <string>

#include "align3d/report/deviation_files.hpp"
#include "align3d/report/json.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

// What the package passes besides the clouds: the command line's flags.
struct InspectArgs {
  double lower, upper, max_distance, pass_fraction;
  std::string init;
  py::object initial_pose;  // None, or a checked 4x4 array (init "pose")
  std::string method, kernel;
  double kernel_scale;
  std::uint64_t seed;
  int threads;
  std::string scan_path, cad_path;
  double read_ms;
  report::InspectionOutputs outputs;
};

py::array_t<double> copy_of(const std::vector<double>& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(double));
  return a;
}

py::array_t<double> copy_of(const std::vector<Eigen::Vector3d>& v) {
  py::array_t<double> a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  if (!v.empty()) std::memcpy(a.mutable_data(), v.front().data(), v.size() * 3 * sizeof(double));
  return a;
}

py::array_t<std::int64_t> triangles_of(const std::vector<std::uint32_t>& v) {
  py::array_t<std::int64_t> a(static_cast<py::ssize_t>(v.size()));
  std::int64_t* out = a.mutable_data();
  for (std::size_t i = 0; i < v.size(); ++i)
    out[i] = v[i] == kNoTriangle ? std::int64_t{-1} : static_cast<std::int64_t>(v[i]);
  return a;
}

// CAD: a TriangleMesh, or a PreparedTarget of one (the package's Target).
template <class Cad>
py::tuple inspect_scan(const PointCloud& scan, const Cad& cad, const InspectArgs& a) {
  InspectSettings s;
  s.tolerance = {a.lower, a.upper};
  s.max_distance = a.max_distance;
  s.pass_fraction = a.pass_fraction;
  s.threads = a.threads;
  s.align.seed = a.seed;
  if (a.init == "auto") {
    s.align.init = InitPolicy::kAuto;
  } else if (a.init == "identity") {
    s.align.init = InitPolicy::kIdentity;
  } else if (a.init == "global") {
    s.align.init = InitPolicy::kGlobal;
  } else if (const auto T = pose(a.initial_pose, "init"); a.init == "pose" && T) {
    s.align.init = InitPolicy::kPose;
    s.align.initial_pose = *T;
  } else {
    throw std::invalid_argument("init: expected 'auto', 'identity', 'global' or a pose, got '" +
                                a.init + "'");
  }
  set_cost(s.align.refine, a.method, a.kernel, a.kernel_scale);
  InspectResult r;
  nlohmann::json report;
  {
    py::gil_scoped_release release;
    r = inspect(scan, cad, s);
    report = report::inspection_report(
        r, s, {a.scan_path, scan.size()},
        {a.cad_path, r.surface->mesh().vertices.size(), r.surface->mesh().triangles.size()});
    report["timing_ms"]["read"] = a.read_ms;
    report::write_inspection_outputs(a.outputs, scan, r);
  }
  return py::make_tuple(report.dump(2) + "\n", copy_of(r.map.deviation), copy_of(r.map.closest),
                        triangles_of(r.map.triangle));
}

template <class Cad>
void def_inspect(py::module_& m) {
  m.def(
      "inspect",
      [](const PointCloud& scan, const Cad& cad, double lower, double upper, double max_distance,
         double pass_fraction, const std::string& init, const py::object& initial_pose,
         const std::string& method, const std::string& kernel, double kernel_scale,
         std::uint64_t seed, int threads, const std::string& scan_path, const std::string& cad_path,
         double read_ms, const std::string& output, const std::string& csv,
         const std::string& histogram, const std::string& html, const std::string& figures,
         const std::string& units) {
        InspectArgs a{lower,        upper,     max_distance, pass_fraction, init,
                      initial_pose, method,    kernel,       kernel_scale,  seed,
                      threads,      scan_path, cad_path,     read_ms,       {}};
        a.outputs = {output, csv, histogram, html, figures, scan_path, cad_path, units};
        return inspect_scan(scan, cad, a);
      },
      py::arg("scan"), py::arg("cad"), py::kw_only(), py::arg("lower"), py::arg("upper"),
      py::arg("max_distance"), py::arg("pass_fraction"), py::arg("init"), py::arg("initial_pose"),
      py::arg("method"), py::arg("kernel"), py::arg("kernel_scale"), py::arg("seed"),
      py::arg("threads"), py::arg("scan_path"), py::arg("cad_path"), py::arg("read_ms"),
      py::arg("output"), py::arg("csv"), py::arg("histogram"), py::arg("html"), py::arg("figures"),
      py::arg("units"));
}

}  // namespace

void bind_inspect(py::module_& m) {
  def_inspect<TriangleMesh>(m);
  def_inspect<PreparedTarget>(m);
  const InspectSettings s;
  m.def("inspect_defaults", [s] {
    return py::dict(py::arg("max_distance") = s.max_distance,
                    py::arg("pass_fraction") = s.pass_fraction,
                    py::arg("init") = to_string(s.align.init),
                    py::arg("method") = to_string(s.align.refine.method),
                    py::arg("kernel") = kernel_name(s.align.refine),
                    py::arg("kernel_scale") = s.align.refine.kernel_scale,
                    py::arg("seed") = s.align.seed, py::arg("threads") = s.threads);
  });
}

}  // namespace align3d::python
