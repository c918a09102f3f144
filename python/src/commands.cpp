// One command of the `align3d` tool, run in-process (cli.hpp, cli::execute): the package's
// synth(), evaluate(), demo(), convert() and ppf_model() are those commands, with the same checks,
// outputs and defaults, and their errors arrive as exceptions (errors.cpp) instead of exit codes.
// cli_main is the whole tool as its executable runs it: the wheel's `align3d` entry point
// (align3d/_cli.py), so an installed package has the command line without a compiler.
#include <pybind11/stl.h>

#include <iostream>
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
  m.def(
      "cli_main",
      [](const std::vector<std::string>& argv) {
        int code = 0;
        {
          py::gil_scoped_release release;
          // argv[0] is the program's name, as in main(argc, argv); output goes to the process's
          // own stdout and stderr, flushed before Python writes again.
          const std::vector<std::string> args(argv.begin() + (argv.empty() ? 0 : 1), argv.end());
          code = cli::run(args, std::cout, std::cerr);
          std::cout.flush();
          std::cerr.flush();
        }
        return code;
      },
      py::arg("argv"),
      "Runs the `align3d` tool on argv (argv[0] the program's name) as its executable does: "
      "output on this process's stdout and stderr, errors reported there; the exit code.");
}

}  // namespace align3d::python
