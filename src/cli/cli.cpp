#include "align3d/cli.hpp"

#include <iostream>
#include <new>

#include "align3d/error.hpp"
#include "common.hpp"

#ifndef ALIGN3D_VERSION
#error "ALIGN3D_VERSION: CMakeLists.txt defines it for this file from project(VERSION)"
#endif

namespace align3d::cli {

int execute(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  CLI::App app{
      "align3d: rigid registration, inspection and rectification of 3D point clouds and meshes.\n"
      "Transforms map SOURCE into TARGET's frame (target ≈ T·source). Exit codes: 0 ok, 1 internal "
      "error, 2 usage, 3 input file, 4 unusable data, 5 output file, 6 no solution, 7 warnings "
      "with --strict, 8 some pairs of a batch failed, 9 the part failed inspection, 10 some scans "
      "overlap no other (stitch).",
      "align3d"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "align3d " ALIGN3D_VERSION);
  const Streams io{out, err};
  const Command commands[] = {add_register(app, io), add_synth(app, io),     add_rectify(app, io),
                              add_demo(app, io),     add_ppf_model(app, io), add_evaluate(app, io),
                              add_convert(app, io),  add_batch(app, io),     add_inspect(app, io),
                              add_find(app, io),     add_stitch(app, io)};

  try {
    std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 wants them reversed
    app.parse(reversed);
  } catch (const CLI::CallForHelp&) {
    out << app.help();
    return 0;
  } catch (const CLI::CallForAllHelp&) {
    out << app.help("", CLI::AppFormatMode::All);
    return 0;
  } catch (const CLI::CallForVersion&) {
    out << "align3d " ALIGN3D_VERSION "\n";
    return 0;
  } catch (const CLI::ParseError& e) {
    // Help requested on a subcommand arrives as CallForHelp too; everything else is a usage error.
    throw UsageError(std::string(e.what()) + " (see align3d --help)");
  }
  for (const Command& c : commands)
    if (c.app->parsed()) return c.run();
  throw UsageError("no subcommand (see align3d --help)");
}

int run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    return execute(args, out, err);
  } catch (const Error& e) {
    err << "align3d: " << e.what() << "\n";
    return static_cast<int>(e.code());
  } catch (const std::bad_alloc&) {
    err << "align3d: out of memory\n";
    return static_cast<int>(ExitCode::kData);
  } catch (const std::exception& e) {
    err << "align3d: internal error: " << e.what() << "\n";
    return static_cast<int>(ExitCode::kInternal);
  }
}

int run(int argc, char** argv) {
  std::vector<std::string> args(argv + std::min(argc, 1), argv + argc);
  return run(args, std::cout, std::cerr);
}

}  // namespace align3d::cli
