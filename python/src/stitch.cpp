// stitch() (stitch.hpp) with the settings of `align3d stitch`, returning the JSON report the
// command line writes (report::stitch_report), the merged cloud and each merged point's scan, and
// writing the files asked for with the command line's writers (report/stitch_files.hpp).
#include "align3d/stitch.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/report/json.hpp"
#include "align3d/report/stitch_files.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

// What the package passes besides the scans: the command line's flags.
struct StitchArgs {
  double min_overlap, voxel, prune_rotation, prune_translation;
  int multiview_iterations;
  std::vector<std::optional<Eigen::Vector3d>> viewpoints;
  int threads;
  std::vector<std::string> paths;  // per scan, "" in memory
  std::string output, figure, html;
  bool scan_index;
  std::string method, kernel;
  double kernel_scale;
};

static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double), "a point is 3 packed doubles");
using Rows = py::array_t<double, py::array::c_style | py::array::forcecast>;

// (K, 3) rows as points; the package checks the shape first (ValueError naming the keyword).
std::vector<Eigen::Vector3d> points_of(const Rows& a, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + ": expected an array of shape (K, 3)");
  std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(a.shape(0)));
  if (!out.empty()) std::memcpy(out.front().data(), a.data(), out.size() * sizeof(Eigen::Vector3d));
  return out;
}

// (K, 3) sensor positions; a row of NaN: not known (stitch.hpp places that scan's sensor).
std::vector<std::optional<Eigen::Vector3d>> viewpoints_of(const Rows& a) {
  std::vector<std::optional<Eigen::Vector3d>> out;
  for (const Eigen::Vector3d& p : points_of(a, "viewpoints"))
    out.push_back(p.array().isNaN().all() ? std::nullopt : std::optional<Eigen::Vector3d>(p));
  return out;
}

py::array_t<std::int32_t> copy_of(const std::vector<std::int32_t>& v) {
  py::array_t<std::int32_t> a(static_cast<py::ssize_t>(v.size()));
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(std::int32_t));
  return a;
}

py::tuple stitch_scans(const std::vector<PointCloud>& scans, const StitchArgs& a) {
  if (a.paths.size() != scans.size())
    throw std::invalid_argument("paths: " + std::to_string(a.paths.size()) + " for " +
                                std::to_string(scans.size()) + " scans");
  StitchSettings s;
  s.min_overlap = a.min_overlap, s.voxel = a.voxel;
  s.prune_rotation_deg = a.prune_rotation, s.prune_translation = a.prune_translation;
  s.multiview_iterations = a.multiview_iterations;
  s.viewpoints = a.viewpoints, s.threads = a.threads;
  set_cost(s.cost, a.method, a.kernel, a.kernel_scale);
  StitchResult r;
  std::string report;
  {
    py::gil_scoped_release release;
    try {
      r = stitch(scans, s);
    } catch (const DataError& e) {
      throw report::naming_scan_file(e, a.paths);
    }
    std::vector<report::InputInfo> inputs;
    for (std::size_t k = 0; k < scans.size(); ++k) inputs.push_back({a.paths[k], scans[k].size()});
    report::StitchOutputs outputs{a.output, a.figure, a.html, a.scan_index, {}};
    outputs.info.files = a.paths;
    report::write_stitch_outputs(outputs, r);
    report = report::stitch_report(r, s, inputs, a.output, a.scan_index).dump(2) + "\n";
  }
  return py::make_tuple(report, std::move(r.merged), copy_of(r.merged_scan));
}

}  // namespace

void bind_stitch(py::module_& m) {
  m.def(
      "stitch",
      [](const std::vector<PointCloud>& scans, double min_overlap, double voxel,
         double prune_rotation, double prune_translation, int multiview_iterations,
         const Rows& viewpoints, int threads, const std::vector<std::string>& paths,
         const std::string& output, const std::string& figure, const std::string& html,
         bool scan_index, const std::string& method, const std::string& kernel,
         double kernel_scale) {
        return stitch_scans(
            scans, StitchArgs{min_overlap, voxel, prune_rotation, prune_translation,
                              multiview_iterations, viewpoints_of(viewpoints), threads, paths,
                              output, figure, html, scan_index, method, kernel, kernel_scale});
      },
      py::arg("scans"), py::kw_only(), py::arg("min_overlap"), py::arg("voxel"),
      py::arg("prune_rotation"), py::arg("prune_translation"), py::arg("multiview_iterations"),
      py::arg("viewpoints"), py::arg("threads"), py::arg("paths"), py::arg("output"),
      py::arg("figure"), py::arg("html"), py::arg("scan_index"), py::arg("method"),
      py::arg("kernel"), py::arg("kernel_scale"));
  const StitchSettings s;
  m.def("stitch_defaults", [s] {
    return py::dict(py::arg("min_overlap") = s.min_overlap, py::arg("voxel") = s.voxel,
                    py::arg("prune_rotation") = s.prune_rotation_deg,
                    py::arg("prune_translation") = s.prune_translation,
                    py::arg("multiview_iterations") = s.multiview_iterations,
                    py::arg("threads") = s.threads, py::arg("method") = to_string(s.cost.method),
                    py::arg("kernel") = kernel_name(s.cost),
                    py::arg("kernel_scale") = s.cost.kernel_scale);
  });
}

}  // namespace align3d::python
