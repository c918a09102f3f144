// align3d batch PAIRS.csv --report-dir DIR ...: the Python package's batch engine on Dask
// (python/align3d/batch.py), run as `PYTHON -m align3d.batch ARGS...`. The engine is Python
// because Dask is; this command only finds the interpreter the package was installed for: the
// environment's ALIGN3D_PYTHON (the installed package's own `align3d`, align3d/_cli.py, sets it to
// the Python that runs it, so a wheel needs no path from its build), else the one the build names
// (ALIGN3D_BATCH_PYTHON: scripts/build.sh sets its .venv/), else python3 on the PATH.
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "common.hpp"

#ifndef ALIGN3D_BATCH_PYTHON
#define ALIGN3D_BATCH_PYTHON "python3"
#endif

namespace align3d::cli {
namespace {

std::string batch_python() {
  const char* env = std::getenv("ALIGN3D_PYTHON");
  return env && *env ? env : ALIGN3D_BATCH_PYTHON;
}

// Runs PYTHON -m align3d.batch ARGS with this process's stdin, stdout and stderr; its exit code.
int run_batch(const std::vector<std::string>& args, Streams io) {
  const std::string python = batch_python();
  std::vector<std::string> argv = {python, "-m", "align3d.batch"};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<char*> c_argv;
  for (std::string& a : argv) c_argv.push_back(a.data());
  c_argv.push_back(nullptr);
  io.out.flush();
  io.err.flush();
  const pid_t pid = fork();
  if (pid < 0)
    throw Error(ExitCode::kInternal, std::string("batch: fork: ") + std::strerror(errno));
  if (pid == 0) {
    execvp(c_argv[0], c_argv.data());
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw Error(ExitCode::kInternal, "batch: waitpid failed");
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127)
    throw UsageError("batch: cannot run '" + python +
                     "' with the align3d Python package (scripts/build.sh installs it into .venv/; "
                     "or set ALIGN3D_PYTHON to a Python that can import align3d)");
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return WEXITSTATUS(status);
}

}  // namespace

Command add_batch(CLI::App& app, Streams io) {
  CLI::App* sub = app.add_subcommand(
      "batch",
      "Register every pair of a CSV file (source,target[,report]) on a Dask cluster, local or "
      "--scheduler ADDR, writing one JSON report per pair into --report-dir; resumable (pairs "
      "with a report are skipped). The engine is the Python package's align3d.batch; `align3d "
      "batch --help` lists its options (docs/cluster.md).");
  sub->prefix_command();  // every argument after `batch` goes to the engine, --help too
  sub->set_help_flag();
  return {sub, [sub, io] { return run_batch(sub->remaining(), io); }};
}

}  // namespace align3d::cli
