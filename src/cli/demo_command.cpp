// align3d demo [OUTDIR]: the chapter's experiments, table and figures (report/chapter.hpp).
#include <chrono>

#include "align3d/report/chapter.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct DemoOptions {
  std::string outdir = "align3d_demo";
  std::string scene;
  std::uint64_t seed = 39;
  int threads = 0;
};

}  // namespace

Command add_demo(CLI::App& app, Streams io) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* sub = app.add_subcommand(
      "demo",
      "Reproduce the chapter: ICP point-to-point (good and bad initial value), point-to-plane, our "
      "robust default, the global-registration remedy, plane correction; print the table beside "
      "the "
      "chapter's numbers and write "
      "table.md, results.json, figures fig39_1..6 (.svg, .png) and report.html into OUTDIR.");
  sub->add_option("OUTDIR", o->outdir, "Output directory (created if missing)")
      ->capture_default_str();
  sub->add_option("--scene", o->scene,
                  "Read the scene from a directory written by `align3d synth`");
  sub->add_option("--seed", o->seed, "Seed of the generated scene")->capture_default_str();
  sub->add_option("--threads", o->threads, "Threads (0: all cores)")->capture_default_str();
  return {sub, [o, io] {
            const auto start = std::chrono::steady_clock::now();
            io.out << (o->scene.empty()
                           ? "generating the chapter's scene (seed " + std::to_string(o->seed) + ")"
                           : "reading the scene from " + o->scene)
                   << "\n"
                   << std::flush;
            const report::ChapterScene scene = o->scene.empty()
                                                   ? report::generate_chapter_scene(o->seed)
                                                   : report::read_chapter_scene(o->scene);
            io.out << "running the experiments (" << scene.model.size() << " model points, "
                   << scene.scan.size() << " scan points)\n"
                   << std::flush;
            const report::ChapterResults results =
                report::run_chapter_experiments(scene, o->threads);
            io.out << "writing figures and report into " << o->outdir << "\n\n" << std::flush;
            report::write_chapter_report(scene, results, o->outdir);
            io.out << report::chapter_table(results) << "\n";
            const double s =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            io.out << "wrote " << o->outdir
                   << "/{table.md,results.json,fig39_1..6.svg/.png,report.html} in " << s << " s\n";
            return 0;
          }};
}

}  // namespace align3d::cli
