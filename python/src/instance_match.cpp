// match_instances() (instance_match.hpp): BOP's matching of found poses to true ones by ADD-S over
// the model's points, as bench/compare_find.py and the tests score `align3d find`.
#include "align3d/instance_match.hpp"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "binding.hpp"

namespace align3d::python {
namespace {

using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// 4x4 arrays (the package checks their shape: _find.py) as rigid transforms.
std::vector<Eigen::Isometry3d> rigid_all(const py::list& m, const std::string& what) {
  std::vector<Eigen::Isometry3d> out;
  for (std::size_t k = 0; k < m.size(); ++k) {
    const std::string name = what + "[" + std::to_string(k) + "]";
    const auto a = m[k].cast<Array>();
    if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4)
      throw std::invalid_argument(name + ": expected a 4x4 matrix");
    out.push_back(
        rigid(Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(a.data()), name));
  }
  return out;
}

py::dict match(const Eigen::Ref<const Points>& points, const py::list& found, const py::list& truth,
               const std::vector<double>& visible, double max_error, double min_visible) {
  if (visible.size() != truth.size())
    throw std::invalid_argument("visible: " + std::to_string(visible.size()) + " fractions for " +
                                std::to_string(truth.size()) + " true instances");
  const std::vector<Eigen::Isometry3d> found_poses = rigid_all(found, "found");
  const std::vector<Eigen::Isometry3d> true_poses = rigid_all(truth, "truth");
  std::vector<TrueInstance> true_instances(truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k) true_instances[k] = {true_poses[k], visible[k]};
  std::vector<Eigen::Vector3d> model(static_cast<std::size_t>(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    model[static_cast<std::size_t>(i)] = points.row(i).transpose();
  InstanceMatch r;
  {
    py::gil_scoped_release release;
    const AddS add_s(std::move(model));
    r = match_instances(add_s, found_poses, true_instances, max_error, min_visible);
  }
  py::dict d;
  d["counted"] = r.counted;
  d["true_positives"] = r.true_positives;
  d["false_positives"] = r.false_positives;
  d["excused"] = r.excused;
  d["match"] = r.match;
  d["error"] = r.error;
  d["recall"] = r.recall();
  d["precision"] = r.precision();
  return d;
}

}  // namespace

void bind_instance_match(py::module_& m) {
  m.def("match_instances", &match, py::arg("model_points"), py::arg("found"), py::arg("truth"),
        py::arg("visible"), py::arg("max_error"), py::arg("min_visible"));
}

}  // namespace align3d::python
