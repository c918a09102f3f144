// One command of the `align3d` tool, run in-process (cli.hpp, cli::execute): the package's
// synth(), evaluate(), demo(), convert() and ppf_model() are those commands, with the same checks,
// outputs and defaults, and their errors arrive as exceptions (errors.cpp) instead of exit codes.
#include <pybind11/stl.h>

#include <sstream>
#include <string>
#include <vector>

#include "align3d/cli.hpp"
#include "binding.hpp"

namespace align3d::python {

void bind_commands(py::module_& m) {
  m.def(
      "run_command",
      [](const std::vector<std::string>& args) {
        std::ostringstream out, err;
        int code = 0;
        {
          py::gil_scoped_release release;
          code = cli::execute(args, out, err);
        }
        return py::make_tuple(code, out.str(), err.str());
      },
      py::arg("args"),
      "Runs `align3d ARGS...` in-process: (exit code 0 or 7, stdout text, stderr text); errors "
      "raise.");
}

}  // namespace align3d::python
