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

// Runs one command line as run() does, but lets its errors through as exceptions instead of
// printing them: align3d::Error and its subclasses (error.hpp; a bad command line is a UsageError
// whose message ends "(see align3d --help)"), std::bad_alloc, or any other exception (a bug).
// Returns 0, or ExitCode::kWarnings (--strict). For front ends that report errors their own way
// (the Python binding runs a command in-process and raises the matching exception).
int execute(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace align3d::cli
