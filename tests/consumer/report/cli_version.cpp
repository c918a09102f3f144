// Runs `align3d --version` in-process through the installed command-line library and checks it
// reports the version of the package CMake found.
#include <align3d/cli.hpp>
#include <cstdio>
#include <sstream>
#include <string>

int main() {
  std::ostringstream out, err;
  const int code = align3d::cli::run({"--version"}, out, err);
  const std::string expected = "align3d " ALIGN3D_PACKAGE_VERSION;
  std::printf("cli_version: exit %d, printed \"%s\", package %s\n", code, out.str().c_str(),
              ALIGN3D_PACKAGE_VERSION);
  return code == 0 && out.str().rfind(expected, 0) == 0 ? 0 : 1;
}
