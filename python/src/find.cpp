// find() (find.hpp) with the settings of `align3d find`, returning the JSON report the command line
// writes (report::find_report) and writing the overlays asked for with its writers.
#include "align3d/find.hpp"

#include <pybind11/stl.h>

#include <string>

#include "align3d/error.hpp"
#include "align3d/report/find_overlay.hpp"
#include "align3d/report/json.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

struct FindArgs {
  int max_instances;
  double min_score, voxel_fraction, min_depth, max_depth;
  std::string symmetry;
  bool keep_plane;
  std::uint64_t seed;
  int threads;
  std::string model_path, scene_path, output, image;
  std::string method, kernel;
  double kernel_scale;
};

// MODEL: a mesh or a cloud (built here), or a saved description (.ppf path); SCENE: a file.
template <class Model>
std::string find_in(const Model& model_data, const FindArgs& a) {
  FindSettings s;
  s.max_instances = a.max_instances, s.min_score = a.min_score;
  s.min_depth = a.min_depth, s.max_depth = a.max_depth;
  s.remove_plane = !a.keep_plane, s.seed = a.seed, s.threads = a.threads;
  set_cost(s.cost, a.method, a.kernel, a.kernel_scale);
  py::gil_scoped_release release;
  // A problem of the model or the scene names its file when it came from one, as the command's
  // errors do (src/cli/find_command.cpp).
  const auto named = [](const std::string& path, const DataError& e) {
    return path.empty() ? e : DataError(path, e.problem());
  };
  PpfModel model;
  if constexpr (std::is_same_v<Model, std::string>) {
    model = load_ppf_model(model_data);
  } else {
    try {
      model = build_find_model(model_data, a.voxel_fraction, a.threads);
    } catch (const DataError& e) {
      throw named(a.model_path, e);
    }
  }
  if (a.symmetry != "auto") s.symmetry = parse_symmetry(a.symmetry, model.points);
  s.detect_symmetry = a.symmetry == "auto";
  const FindScene scene = read_find_scene(a.scene_path);
  FindResult r;
  try {
    r = find(model, scene, s);
  } catch (const DataError& e) {
    throw named(e.subject() == "model" ? a.model_path : a.scene_path, e);
  }
  if (!a.output.empty()) report::write_find_overlay(a.output, scene.cloud, model, r);
  if (!a.image.empty()) report::write_find_image(a.image, r);
  return report::find_report(r, s, {a.model_path, model.points.size()},
                             {a.scene_path, scene.cloud.size()})
             .dump(2) +
         "\n";
}

template <class Model>
void def_find(py::module_& m) {
  m.def(
      "find",
      [](const Model& model, int max_instances, double min_score, double voxel_fraction,
         double min_depth, double max_depth, const std::string& symmetry, bool keep_plane,
         std::uint64_t seed, int threads, const std::string& model_path,
         const std::string& scene_path, const std::string& output, const std::string& image,
         const std::string& method, const std::string& kernel, double kernel_scale) {
        return find_in(model, FindArgs{max_instances, min_score, voxel_fraction, min_depth,
                                       max_depth, symmetry, keep_plane, seed, threads, model_path,
                                       scene_path, output, image, method, kernel, kernel_scale});
      },
      py::arg("model"), py::kw_only(), py::arg("max_instances"), py::arg("min_score"),
      py::arg("voxel_fraction"), py::arg("min_depth"), py::arg("max_depth"), py::arg("symmetry"),
      py::arg("keep_plane"), py::arg("seed"), py::arg("threads"), py::arg("model_path"),
      py::arg("scene_path"), py::arg("output"), py::arg("image"), py::arg("method"),
      py::arg("kernel"), py::arg("kernel_scale"));
}

}  // namespace

void bind_find(py::module_& m) {
  def_find<TriangleMesh>(m);
  def_find<PointCloud>(m);
  def_find<std::string>(m);  // a saved description (.ppf)
  m.def("find_defaults", [] {
    const FindSettings s;
    return py::dict(
        py::arg("min_score") = s.min_score, py::arg("voxel_fraction") = kFindVoxelFraction,
        py::arg("method") = to_string(s.cost.method), py::arg("kernel") = kernel_name(s.cost),
        py::arg("kernel_scale") = s.cost.kernel_scale);
  });
}

}  // namespace align3d::python
