// The `align3d` command-line tool as a library function, so tests run it in-process.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace align3d::cli {

// Runs one command line (args[0] is the subcommand, as argv[1] would be). Never throws: errors are
// reported as one line on `err` and returned as an ExitCode value (error.hpp, README "Exit codes").
int run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run(int argc, char** argv);

}  // namespace align3d::cli
