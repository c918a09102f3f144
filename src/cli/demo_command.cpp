// align3d demo [OUTDIR]: the chapter's experiments (chapter.hpp), table and figures
// (report/chapter_report.hpp).
#include <chrono>

#include "align3d/chapter.hpp"
#include "align3d/report/chapter_report.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct DemoOptions {
  std::string outdir = "align3d_demo";
  std::string scene;
  std::uint64_t seed = 39;
  int threads = 0;
  bool quiet = false;
};

int run_demo(const DemoOptions& o, Streams io) {
  const auto start = std::chrono::steady_clock::now();
  auto say = [&](const std::string& line) {
    if (!o.quiet) io.out << line << "\n" << std::flush;
  };
  say(o.scene.empty() ? "generating the chapter's scene (seed " + std::to_string(o.seed) + ")"
                      : "reading the scene from " + o.scene);
  const ChapterScene scene =
      o.scene.empty() ? generate_chapter_scene(o.seed) : report::read_chapter_scene(o.scene);
  say("running the experiments (" + std::to_string(scene.model.size()) + " model points, " +
      std::to_string(scene.scan.size()) + " scan points)");
  ChapterResults results;
  {
    ProgressLine progress(io.err, o.quiet, "demo");
    results = run_chapter_experiments(scene, o.threads, progress.callback());
  }
  say("writing figures and report into " + o.outdir + "\n");
  report::write_chapter_report(scene, results, o.outdir);
  if (!o.quiet) {
    io.out << report::chapter_table(results) << "\n";
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    io.out << "wrote " << o.outdir << "/{table.md,results.json,fig39_1..6.svg/.png,report.html} in "
           << s << " s\n";
  }
  return 0;
}

}  // namespace

Command add_demo(CLI::App& app, Streams io) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* sub = app.add_subcommand(
      "demo",
      "Reproduce the chapter: ICP point-to-point (good and bad initial value), point-to-plane, "
      "align3d's defaults, the global-registration remedy, plane correction; print the table "
      "beside the chapter's numbers and write table.md, results.json, figures fig39_1..6 (.svg, "
      ".png) and report.html into OUTDIR.");
  sub->add_option("OUTDIR", o->outdir, "Output directory (created if missing)")
      ->capture_default_str();
  sub->add_option("--scene", o->scene,
                  "Read the scene from a directory written by `align3d synth`");
  sub->add_option("--seed", o->seed, "Seed of the generated scene")
      ->check(CLI::NonNegativeNumber)  // CLI11 would wrap -1 to 2^64 - 1
      ->capture_default_str();
  add_threads(sub, o->threads);
  add_quiet(sub, o->quiet);
  return {sub, [o, io] { return run_demo(*o, io); }};
}

}  // namespace align3d::cli
