// TriangleMesh (mesh.hpp) with numpy views of its data, and the mesh files (io/mesh_io.hpp).
//
// Memory, as PointCloud's (cloud.cpp): the C++ mesh owns its vertices (N × 3 doubles) and
// triangles (M × 3 uint32); the constructor copies the caller's arrays in once, `vertices` and
// `triangles` are views (read-only in the package) of that storage holding a reference to the mesh.
#include "align3d/mesh.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cstring>
#include <stdexcept>
#include <string>

#include "align3d/error.hpp"
#include "align3d/io/mesh_io.hpp"
#include "binding.hpp"

namespace align3d::python {
namespace {

using Rows = py::array_t<double, py::array::c_style | py::array::forcecast>;
using Indices = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

static_assert(sizeof(std::array<std::uint32_t, 3>) == 3 * sizeof(std::uint32_t));

// The package checks dtypes and shapes first (ValueError naming the argument); indices out of
// range and non-finite vertices are the library's DataError (check_mesh).
TriangleMesh make_mesh(const Rows& vertices, const Indices& triangles) {
  if (vertices.ndim() != 2 || vertices.shape(1) != 3)
    throw py::value_error("vertices: expected an array of shape (N, 3)");
  if (triangles.ndim() != 2 || triangles.shape(1) != 3)
    throw py::value_error("triangles: expected an array of shape (M, 3)");
  TriangleMesh mesh;
  mesh.vertices.resize(static_cast<std::size_t>(vertices.shape(0)));
  if (!mesh.vertices.empty())
    std::memcpy(mesh.vertices.front().data(), vertices.data(),
                mesh.vertices.size() * sizeof(Eigen::Vector3d));
  const auto n = static_cast<std::int64_t>(mesh.vertices.size());
  const std::int64_t* t = triangles.data();
  mesh.triangles.resize(static_cast<std::size_t>(triangles.shape(0)));
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t v = t[3 * i + k];
      if (v < 0 || v >= n)
        throw DataError("mesh", "triangle " + std::to_string(i) + " refers to vertex " +
                                    std::to_string(v) + " of " + std::to_string(n));
      mesh.triangles[i][k] = static_cast<std::uint32_t>(v);
    }
  check_mesh(mesh, "mesh");
  return mesh;
}

// An (rows, 3) view of `data` keeping `owner` alive (the package makes it read-only).
template <class T>
py::array view(const T* data, py::ssize_t rows, py::handle owner) {
  if (rows == 0) return py::array_t<T>(std::vector<py::ssize_t>{0, 3});
  return py::array_t<T>(
      {rows, py::ssize_t{3}},
      {static_cast<py::ssize_t>(3 * sizeof(T)), static_cast<py::ssize_t>(sizeof(T))}, data, owner);
}

py::dict topology(const TriangleMesh& mesh) {
  const MeshTopology t = analyse_topology(mesh);
  return py::dict(py::arg("vertices") = t.vertices, py::arg("triangles") = t.triangles,
                  py::arg("closed") = t.closed(), py::arg("boundary_edges") = t.boundary_edges,
                  py::arg("non_manifold_edges") = t.non_manifold_edges,
                  py::arg("inconsistent_edges") = t.inconsistent_edges,
                  py::arg("components") = t.components, py::arg("signed_volume") = t.signed_volume);
}

}  // namespace

void bind_mesh(py::module_& m) {
  py::class_<TriangleMesh>(m, "TriangleMesh", "Vertices and triangles (align3d/mesh.hpp).")
      .def(py::init(&make_mesh), py::arg("vertices"), py::arg("triangles"))
      .def_property_readonly("vertices",
                             [](py::object self) {
                               const auto& v = self.cast<const TriangleMesh&>().vertices;
                               return view(v.empty() ? nullptr : v.front().data(),
                                           static_cast<py::ssize_t>(v.size()), self);
                             })
      .def_property_readonly("triangles",
                             [](py::object self) {
                               const auto& t = self.cast<const TriangleMesh&>().triangles;
                               return view(t.empty() ? nullptr : t.front().data(),
                                           static_cast<py::ssize_t>(t.size()), self);
                             })
      .def("area", &surface_area)
      .def("diagonal", [](const TriangleMesh& mesh) { return bounding_box_diagonal(mesh); })
      .def("topology", &topology)
      .def("cleaned", [](const TriangleMesh& mesh) { return clean_mesh(mesh); })
      .def("sample", &sample_surface, py::arg("count"), py::arg("seed"));

  m.def(
      "read_mesh",
      [](const std::filesystem::path& path, double chord_tolerance) {
        io::MeshReadSettings settings;
        settings.chord_tolerance = chord_tolerance;
        io::MeshReadInfo info;
        TriangleMesh mesh;
        {
          py::gil_scoped_release release;
          mesh = io::read_mesh(path, settings, &info);
        }
        return py::make_tuple(std::move(mesh), info.format, info.chord_tolerance,
                              info.dropped_faces);
      },
      py::arg("path"), py::arg("chord_tolerance"));
  m.def(
      "write_mesh",
      [](const std::filesystem::path& path, const TriangleMesh& mesh) {
        py::gil_scoped_release release;
        io::write_mesh(path, mesh);
      },
      py::arg("path"), py::arg("mesh"));
  m.def("is_mesh_file", [](const std::filesystem::path& path) { return io::is_mesh_file(path); });
  m.def("has_cad_exchange", &io::has_cad_exchange);
}

}  // namespace align3d::python
