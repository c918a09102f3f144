// PointCloud (point_cloud.hpp) with numpy views of its data, the file readers and writers
// (io/point_cloud_io.hpp) and 4x4 transform files (io/matrix_io.hpp).
//
// Memory: the C++ PointCloud owns its points (std::vector<Eigen::Vector3d>: N × 3 doubles in a row,
// C order). The constructor copies the caller's array in once; `points` and `normals` are views of
// that storage (no copy), each holding a reference to the cloud, so a view outlives nothing it
// points into. No function here resizes a cloud's storage after construction (views stay valid):
// new data of the same shape is written in place, normals are added only where there were none
// (and so no view of them).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/point_cloud.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double), "a point is 3 packed doubles");

// C-contiguous float64; the package converts and checks dtype and shape first (ValueError with
// the argument's name), so forcecast only guards direct callers of _core.
using Rows = py::array_t<double, py::array::c_style | py::array::forcecast>;

void check_rows(const Rows& a, const char* what, std::optional<py::ssize_t> rows = std::nullopt) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + ": expected an array of shape (N, 3)");
  if (rows && a.shape(0) != *rows)
    throw py::value_error(std::string(what) + ": " + std::to_string(a.shape(0)) + " rows for " +
                          std::to_string(*rows) + " points");
}

void copy_rows(const Rows& a, std::vector<Eigen::Vector3d>& v) {
  if (!v.empty()) std::memcpy(v.front().data(), a.data(), v.size() * sizeof(Eigen::Vector3d));
}

// Normals as the readers leave them (point_cloud_io.hpp): unit length. A zero or non-finite one is
// a DataError here rather than dropping every normal silently.
void normalise(std::vector<Eigen::Vector3d>& normals) {
  for (std::size_t i = 0; i < normals.size(); ++i) {
    const double norm = normals[i].norm();
    if (!(norm > 0) || !std::isfinite(norm))
      throw DataError("normals",
                      "row " + std::to_string(i) + " has no direction (zero, NaN or Inf)");
    normals[i] /= norm;
  }
}

// A view of `v` as an (N, 3) float64 array that keeps `owner` (the Python cloud) alive.
py::array view(std::vector<Eigen::Vector3d>& v, py::handle owner) {
  const auto n = static_cast<py::ssize_t>(v.size());
  if (n == 0) return py::array_t<double>(std::vector<py::ssize_t>{0, 3});
  return py::array_t<double>(
      {n, py::ssize_t{3}},
      {static_cast<py::ssize_t>(sizeof(Eigen::Vector3d)), static_cast<py::ssize_t>(sizeof(double))},
      v.front().data(), owner);
}

PointCloud make_cloud(const Rows& points, const std::optional<Rows>& normals) {
  check_rows(points, "points");
  PointCloud cloud;
  cloud.positions.resize(static_cast<std::size_t>(points.shape(0)));
  copy_rows(points, cloud.positions);
  if (normals) {
    check_rows(*normals, "normals", points.shape(0));
    cloud.normals.resize(cloud.positions.size());
    copy_rows(*normals, cloud.normals);
  }
  check_finite(cloud, "cloud");
  normalise(cloud.normals);
  return cloud;
}

// New points (normals) for `cloud`, checked as make_cloud checks them before the cloud is touched,
// then copied into its storage in place: views stay valid.
void set_points(PointCloud& cloud, const Rows& points) {
  check_rows(points, "points", static_cast<py::ssize_t>(cloud.size()));
  PointCloud probe;
  probe.positions.resize(cloud.size());
  copy_rows(points, probe.positions);
  check_finite(probe, "cloud");
  std::copy(probe.positions.begin(), probe.positions.end(), cloud.positions.begin());
}

void set_normals(PointCloud& cloud, const Rows& normals) {
  check_rows(normals, "normals", static_cast<py::ssize_t>(cloud.size()));
  std::vector<Eigen::Vector3d> next(cloud.size());
  copy_rows(normals, next);
  normalise(next);  // refuses NaN and Inf too
  if (cloud.has_normals())
    std::copy(next.begin(), next.end(), cloud.normals.begin());
  else
    cloud.normals = std::move(next);  // there were none, so no view of them
}

}  // namespace

Eigen::Isometry3d rigid(const Eigen::Matrix4d& m, const std::string& what) {
  const std::string problem = io::rigid_problem(m);
  if (!problem.empty()) throw std::invalid_argument(what + ": " + problem);
  return io::to_rigid(m);
}

void bind_cloud(py::module_& m) {
  py::class_<PointCloud>(m, "PointCloud",
                         "Positions and optional unit normals (align3d/point_cloud.hpp).")
      .def(py::init(&make_cloud), py::arg("points"), py::arg("normals") = py::none())
      .def("__len__", &PointCloud::size)
      .def_property_readonly("has_normals", &PointCloud::has_normals)
      .def_property_readonly(
          "points", [](py::object self) { return view(self.cast<PointCloud&>().positions, self); })
      .def_property_readonly("normals",
                             [](py::object self) -> py::object {
                               PointCloud& cloud = self.cast<PointCloud&>();
                               if (!cloud.has_normals()) return py::none();
                               return view(cloud.normals, self);
                             })
      .def("set_points", &set_points, py::arg("points"))
      .def("set_normals", &set_normals, py::arg("normals"))
      .def("transformed",
           [](const PointCloud& cloud, const Eigen::Matrix4d& T) {
             return transformed(cloud, rigid(T, "transformation"));
           })
      .def("copy", [](const PointCloud& cloud) { return cloud; });

  m.def(
      "read_point_cloud",
      [](const std::filesystem::path& path) {
        io::ReadInfo info;
        PointCloud cloud;
        {
          py::gil_scoped_release release;
          cloud = io::read_point_cloud(path, &info);
        }
        // The sensor's position where the file gives one (io::sensor_position), else None.
        const std::optional<Eigen::Vector3d> eye = io::sensor_position(info);
        return py::make_tuple(std::move(cloud), info.dropped_non_finite,
                              eye ? py::cast(*eye) : py::none());
      },
      py::arg("path"));
  m.def(
      "write_point_cloud",
      [](const std::filesystem::path& path, const PointCloud& cloud, const std::string& encoding) {
        const std::optional<io::CloudFormat> format = io::cloud_format(path);
        // An unknown extension is the writer's OutputError, whatever the encoding.
        const io::WriteSettings settings =
            format ? io::write_settings(*format, encoding) : io::WriteSettings{};
        py::gil_scoped_release release;
        io::write_point_cloud(path, cloud, settings);
      },
      py::arg("path"), py::arg("cloud"), py::arg("encoding") = "");
  m.def(
      "read_matrix",
      [](const std::filesystem::path& path) -> Eigen::Matrix4d {
        return io::read_matrix(path).matrix();
      },
      py::arg("path"));
  m.def(
      "write_matrix",
      [](const std::filesystem::path& path, const Eigen::Matrix4d& T) {
        io::write_matrix(path, rigid(T, "transformation"));
      },
      py::arg("path"), py::arg("transformation"));
  m.def(
      "write_text",
      [](const std::filesystem::path& path, const std::string& text) {
        py::gil_scoped_release release;
        io::write_text_atomically(path, text);
      },
      py::arg("path"), py::arg("text"));
}

}  // namespace align3d::python
