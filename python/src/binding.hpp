// The extension module align3d._core: a thin shell over the library, one file per module of it.
// The Python package (python/align3d/) is the public API; it validates arrays and keywords and
// wraps what these functions return. Rules for every function here:
//   - the GIL is released around the library's work (clouds are read and registered in parallel
//     from Python threads); a Python callback takes it back for the duration of its call;
//   - C++ exceptions become the Python exceptions of align3d._errors in one place (errors.cpp);
//   - no logic the library, its report module or its command line does not already have.
#pragma once

#include <pybind11/pybind11.h>

#include <Eigen/Geometry>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>

#include "align3d/icp/factors.hpp"
#include "align3d/icp/refine.hpp"

namespace align3d::python {

namespace py = pybind11;

void bind_errors(py::module_& m);    // errors.cpp: the exception translator
void bind_cloud(py::module_& m);     // cloud.cpp: PointCloud, files, matrices
void bind_register(py::module_& m);  // register.cpp: align() and rectify() with their reports
void bind_commands(py::module_& m);  // commands.cpp: a command of the `align3d` tool in-process
void bind_mesh(py::module_& m);      // mesh.cpp: TriangleMesh, mesh files
void bind_inspect(py::module_& m);   // inspect.cpp: inspect() with its report and arrays
void bind_find(py::module_& m);      // find.cpp: find() with its report and overlays
void bind_stitch(py::module_& m);    // stitch.cpp: stitch() with its report and merged cloud
void bind_instance_match(py::module_& m);  // instance_match.cpp: BOP's scoring of found poses

// The rigid transform in a 4x4 array, by the rule of transform files (io/matrix_io.hpp);
// std::invalid_argument "<what>: <problem>" otherwise (cloud.cpp).
Eigen::Isometry3d rigid(const Eigen::Matrix4d& m, const std::string& what);

// A pose argument: None, a transform file's name (read as `--init FILE` and `--ground-truth FILE`
// are) or a 4x4 array (checked as such a file is) (register.cpp).
std::optional<Eigen::Isometry3d> pose(const py::object& value, const std::string& what);

// The value among `choices` whose to_string() is `text`; std::invalid_argument naming `what` and
// the choices otherwise.
template <typename E, std::size_t kSize>
E parse_choice(const std::string& what, const std::string& text, const E (&choices)[kSize]) {
  std::string names;
  for (const E c : choices) {
    if (text == to_string(c)) return c;
    names += (names.empty() ? "'" : ", '") + std::string(to_string(c)) + "'";
  }
  throw std::invalid_argument(what + ": expected one of " + names + ", got '" + text + "'");
}

// The ICP methods in the order the messages list them (the default first).
inline constexpr IcpMethod kIcpMethods[] = {IcpMethod::kPointToPlane, IcpMethod::kPointToPoint,
                                            IcpMethod::kGicp, IcpMethod::kSymmetric};

// Sets the ICP cost from the keywords `method`, `kernel` and `kernel_scale` of register, inspect,
// stitch and find (the command line's --method, --kernel, --kernel-scale); std::invalid_argument
// naming the keyword otherwise (register.cpp).
void set_cost(CostSettings& cost, const std::string& method, const std::string& kernel,
              double kernel_scale);

}  // namespace align3d::python
