// align3d._core: the module's entry point (binding.hpp says what each file binds).
#include "binding.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() =
      "align3d's C++ core, bound with pybind11. Private: use the align3d package, which validates "
      "its arguments and wraps these functions.";
  m.attr("__version__") = ALIGN3D_VERSION;
  align3d::python::bind_errors(m);
  align3d::python::bind_cloud(m);
  align3d::python::bind_mesh(m);
  align3d::python::bind_register(m);
  align3d::python::bind_inspect(m);
  align3d::python::bind_find(m);
  align3d::python::bind_stitch(m);
  align3d::python::bind_instance_match(m);
  align3d::python::bind_commands(m);
}
