// align3d find MODEL SCENE: find() (find.hpp) from the command line (README, "Pick parts from a
// bin"; the report's keys: docs/report.md, "find").
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <string>

#include "align3d/error.hpp"
#include "align3d/find.hpp"
#include "align3d/report/find_overlay.hpp"
#include "common.hpp"
#include "detail/number.hpp"

namespace align3d::cli {
namespace {

struct FindOptions {
  std::string model, scene, report, output, image, depth_range, symmetry = "auto";
  double voxel_fraction = kFindVoxelFraction;
  bool keep_plane = false, strict = false, quiet = false;
  FindSettings settings;
  RefineOptions refine;
};

// MODEL: a saved description (.ppf, from `align3d ppf-model --find`), a mesh or a cloud.
PpfModel load_model(const FindOptions& o, Streams io, report::InputInfo& info) {
  info.path = o.model;
  if (std::filesystem::path(o.model).extension() == ".ppf") {
    PpfModel m = load_ppf_model(o.model);
    if (!m.outward)
      throw DataError(o.model,
                      "a PPF model for registration; find needs one with outward "
                      "normals (align3d ppf-model --find MODEL OUT)");
    info.points = m.points.size();
    return m;
  }
  try {
    if (io::is_mesh_file(o.model)) {
      const TriangleMesh mesh = load_mesh(o.model, io.err);
      info.points = mesh.vertices.size(), info.triangles = mesh.triangles.size();
      return build_find_model(mesh, o.voxel_fraction, o.settings.threads);
    }
    const PointCloud cloud = load_cloud(o.model, io.err);
    info.points = cloud.size();
    return build_find_model(cloud, o.voxel_fraction, o.settings.threads);
  } catch (const DataError& e) {
    throw DataError(o.model, e.problem());
  }
}

// --depth-range MIN,MAX (camera z, data units).
void apply_depth_range(const std::string& text, FindSettings& s) {
  if (text.empty()) return;
  const std::size_t comma = text.find(',');
  const auto lo = detail::parse_finite(text.substr(0, comma));
  const auto hi =
      comma == std::string::npos ? std::nullopt : detail::parse_finite(text.substr(comma + 1));
  if (!lo || !hi || !(*lo >= 0 && *lo < *hi))
    throw UsageError("--depth-range: expected MIN,MAX with 0 <= MIN < MAX, got '" + text + "'");
  s.min_depth = *lo, s.max_depth = *hi;
}

void print_summary(std::ostream& out, const FindOptions& o, const FindResult& r) {
  out << "found " << r.instances.size() << " instance(s) of " << o.model << " in " << o.scene
      << " (model diameter " << std::setprecision(4) << r.model_diameter
      << (r.model_side.partial ? ", partial: one side" : "") << ", symmetry " << r.symmetry.name()
      << "; " << r.hypotheses << " hypotheses, " << std::setprecision(3) << r.total_ms << " ms)\n";
  for (std::size_t k = 0; k < r.instances.size(); ++k) {
    const FoundInstance& f = r.instances[k];
    const Eigen::Vector3d t = f.T_scene_model.translation();
    char line[160];
    std::snprintf(line, sizeof line,
                  "  %2zu  score %.3f  visible %.2f  rms %.3g  at (%.4g, %.4g, %.4g)\n", k + 1,
                  f.score, f.visible_fraction, f.rms, t.x(), t.y(), t.z());
    out << line;
  }
}

int run_find(FindOptions& o, Streams io) {
  FindSettings& s = o.settings;
  apply_depth_range(o.depth_range, s);
  apply_refine_options(o.refine, s.cost);
  s.remove_plane = !o.keep_plane;
  report::InputInfo model_info, scene_info{o.scene, 0, 0};
  const PpfModel model = load_model(o, io, model_info);
  if (o.symmetry != "auto") {
    try {
      s.symmetry = parse_symmetry(o.symmetry, model.points);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--") + e.what());
    }
    s.detect_symmetry = false;
  }
  const FindScene scene = read_find_scene(o.scene);  // NaN pixels of a depth image are no news
  scene_info.points = scene.cloud.size();
  FindResult r;
  try {
    r = find(model, scene, s);
  } catch (const DataError& e) {
    throw DataError(e.subject() == "model" ? o.model : o.scene, e.problem());
  }
  if (!o.output.empty()) report::write_find_overlay(o.output, scene.cloud, model, r);
  if (!o.image.empty()) report::write_find_image(o.image, r);
  if (!o.report.empty())
    write_json(o.report, report::find_report(r, s, model_info, scene_info), io.out);
  if (o.report != "-" && !o.quiet) print_summary(io.out, o, r);
  return report_warnings(r.warnings, o.strict, io.err);
}

}  // namespace

Command add_find(CLI::App& app, Streams io) {
  auto o = std::make_shared<FindOptions>();
  FindSettings& s = o->settings;
  CLI::App* sub = app.add_subcommand(
      "find",
      "Find every instance of the part MODEL in SCENE, a depth camera's view (bin picking): point\n"
      "pair feature voting, ICP, and a check of each pose against the depth image (the surface\n"
      "the camera should see is there; nothing is seen through the part). Prints each instance's\n"
      "pose (MODEL -> SCENE), score and visible fraction, best first. Exit code 0 also when none\n"
      "is found.");
  sub->add_option("MODEL", o->model,
                  "The part: its CAD mesh (.stl .obj .off .ply with faces .step .iges; sampled "
                  "evenly by area), a cloud with outward normals, a teach-in scan of the part "
                  "(a cloud without normals, or a mesh of one side: partial, verified only at "
                  "poses that show the scanned side to the camera), or a description saved by "
                  "`align3d ppf-model --find` (.ppf)")
      ->required();
  sub->add_option("SCENE", o->scene,
                  "The scene: an organized PCD from a depth camera (WIDTH x HEIGHT, NaN holes, "
                  "VIEWPOINT the camera's position; its orientation and intrinsics are fitted to "
                  "the pixels' rays), or any cloud seen from its viewpoint or the origin")
      ->required();
  sub->add_option("--max-instances", s.max_instances, "Report at most N instances; 0: all")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--min-score", s.min_score,
                  "Accept instances scoring at least S: the share of the part's unoccluded "
                  "visible surface the scene explains (normals agreeing), less what is seen "
                  "through it and the share of its outline the scene's surface continues past; "
                  "parts less than " +
                      std::to_string(std::lround(100 * kFindMinVisible)) +
                      " % visible, or whose explained surface is one face of a larger surface, "
                      "are not reported")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  sub->add_option("--symmetry", o->symmetry,
                  "auto (detect from the model), none, x, y or z (continuous about that model "
                  "axis through the centroid), or AXIS:N (N-fold, e.g. z:4)")
      ->capture_default_str();
  sub->add_option("--voxel-fraction", o->voxel_fraction,
                  "Sampling step of the model and scene, as a share of the model's diameter")
      ->check(CLI::Range(0.005, 0.25))
      ->capture_default_str();
  sub->add_flag("--keep-plane", o->keep_plane,
                "Keep the scene's dominant plane (the bin floor) for voting; by default it is "
                "removed when it holds 20 % of the scene");
  sub->add_option("--depth-range", o->depth_range,
                  "MIN,MAX: only scene points at these depths along the camera axis (data units)");
  sub->add_option("--report", o->report, "Write the JSON report to FILE, or to stdout with -");
  sub->add_option("--output", o->output,
                  "Write the scene with each instance's model points in its colour (PLY; an int "
                  "property `instance`: 0 scene, else the rank)");
  sub->add_option("--image", o->image,
                  "Write the depth image with each instance's mask, outline and rank (PNG)");
  add_refine_options(
      sub, o->refine,
      {"each instance's final refinement (hypotheses are refined point-to-plane)", "none"});
  add_seed(sub, s.seed);
  add_strict(sub, o->strict);
  add_quiet(sub, o->quiet);
  add_threads(sub, s.threads);
  return {sub, [o, io] { return run_find(*o, io); }};
}

}  // namespace align3d::cli
