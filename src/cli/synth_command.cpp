// align3d synth OUTDIR: the chapter's scene and plates (synth/scenes.hpp), the parts cell, the
// depth-camera scenes (synth/depth_scenes.hpp, written by synth_depth.cpp), the machined part
// and its as-built scan (synth/part.hpp), or multi-view scans for stitching
// (synth/stitch_scans.hpp, written by synth_stitch.cpp), with ground truth.
#include <filesystem>
#include <iostream>

#include "align3d/error.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "common.hpp"
#include "synth_depth.hpp"
#include "synth_part.hpp"
#include "synth_stitch.hpp"

namespace align3d::cli {

namespace {

struct SynthOptions {
  std::string outdir;
  std::uint64_t seed = 39;
  std::string variant = "chapter";
  std::string scene = "chapter";
  int points = 100000;
  int instances = 6;  // --scene bin
  std::string part = "bracket";
  int distractors = 3;
  double azimuth = 30;
  double angle = 60;
  int views = 2;
  bool no_leaf = false;  // --scene stitch
  double noise = 0.01;
  std::size_t triangles = 0;
};

void make_directory(const std::filesystem::path& outdir) {
  std::error_code ec;
  std::filesystem::create_directories(outdir, ec);
  if (ec) throw OutputError(outdir, "cannot create directory: " + ec.message());
}

// model.ply (the target), scan.ply (the source) and ground_truth.txt (model ≈ T·scan).
void write_scene_clouds(const std::filesystem::path& outdir, const synth::Scene& scene) {
  io::write_ply(outdir / "model.ply", scene.model);
  io::write_ply(outdir / "scan.ply", scene.scan);
  io::write_matrix(outdir / "ground_truth.txt", scene.T_model_scan);
}

// The benchmark work cell (synth::make_parts_scene): model.ply, scan.ply, ground_truth.txt and
// scene.json.
nlohmann::json write_parts_scene(const std::filesystem::path& outdir, std::uint64_t seed,
                                 int points) {
  make_directory(outdir);
  synth::PartsSettings ps;
  ps.seed = seed;
  ps.points = points;
  const synth::Scene scene = synth::make_parts_scene(ps);
  write_scene_clouds(outdir, scene);
  const nlohmann::json json = {
      {"units", "mm"},
      {"seed", seed},
      {"scene", "parts"},
      {"model", {{"file", "model.ply"}, {"points", scene.model.size()}, {"parts", ps.parts}}},
      {"scan",
       {{"file", "scan.ply"},
        {"points", scene.scan.size()},
        {"from_model", scene.scan_corresponding},
        {"no_correspondence", scene.scan_outliers},
        {"overlap", ps.overlap},
        {"rotation_deg", ps.rotation_deg},
        {"rotation_axis", to_json(ps.rotation_axis)},
        {"translation", to_json(ps.translation)},
        {"noise_sigma", ps.noise_sigma}}},
      {"ground_truth",
       {{"file", "ground_truth.txt"},
        {"meaning", "maps scan into the model frame: model ≈ T·scan"},
        {"transformation", to_json(scene.T_model_scan)}}}};
  write_json((outdir / "scene.json").string(), json, std::cout);
  return json;
}

}  // namespace

// Writes the scene files into `outdir` (created if missing) and returns scene.json's content.
nlohmann::json write_scene(const std::filesystem::path& outdir, std::uint64_t seed,
                           const std::string& variant) {
  make_directory(outdir);
  synth::ConveyorSettings cs = synth::ConveyorSettings::variant(variant);
  cs.seed = seed;
  const synth::Scene scene = synth::make_conveyor_scene(cs);
  const synth::PlateSettings ps = synth::chapter_plate(seed, false);
  const synth::Plate plate = synth::make_plate(ps);
  const synth::PlateSettings cps = synth::chapter_plate(seed, true);
  const synth::Plate cluttered = synth::make_plate(cps);

  write_scene_clouds(outdir, scene);
  io::write_ply(outdir / "plate.ply", plate.cloud);
  io::write_ply(outdir / "plate_cluttered.ply", cluttered.cloud);

  const nlohmann::json json = {
      {"units", "mm"},
      {"seed", seed},
      {"variant", variant},
      {"model",
       {{"file", "model.ply"},
        {"points", scene.model.size()},
        {"plane_size", {cs.plane_x, cs.plane_y}},
        {"box", {{"base_centre", to_json(cs.box_centre)}, {"size", to_json(cs.box_size)}}},
        {"cap",
         {{"centre", {cs.cap_centre.x(), cs.cap_centre.y()}},
          {"sphere_radius", cs.cap_radius},
          {"height", cs.cap_height}}}}},
      {"scan",
       {{"file", "scan.ply"},
        {"points", scene.scan.size()},
        {"from_model", scene.scan_corresponding},
        {"no_correspondence", scene.scan_outliers},
        {"no_correspondence_percent",
         100.0 * static_cast<double>(scene.scan_outliers) / static_cast<double>(scene.scan.size())},
        {"rotation_deg", cs.rotation_deg},
        {"rotation_axis", to_json(cs.rotation_axis)},
        {"translation", to_json(cs.translation)},
        {"noise_sigma", cs.noise_sigma},
        {"crop", "the left side (smallest x in the scanner frame) is cropped away"},
        {"wall", {{"gap", cs.wall_gap}, {"height", cs.wall_height}}}}},
      {"ground_truth",
       {{"file", "ground_truth.txt"},
        {"meaning", "maps scan into the model frame: model ≈ T·scan"},
        {"transformation", to_json(scene.T_model_scan)}}},
      {"plate",
       {{"file", "plate.ply"},
        {"points", plate.cloud.size()},
        {"tilt_deg", ps.tilt_deg},
        {"tilt_axis", to_json(ps.tilt_axis)},
        {"noise_sigma", ps.noise_sigma},
        {"true_normal", to_json(plate.true_normal)}}},
      {"plate_cluttered",
       {{"file", "plate_cluttered.ply"},
        {"points", cluttered.cloud.size()},
        {"plate_points", cluttered.plate_points},
        {"clutter_fraction", cps.clutter_fraction},
        {"tilt_deg", cps.tilt_deg},
        {"true_normal", to_json(cluttered.true_normal)}}}};
  write_json((outdir / "scene.json").string(), json, std::cout);
  return json;
}

Command add_synth(CLI::App& app, Streams io) {
  auto o = std::make_shared<SynthOptions>();
  CLI::App* sub = app.add_subcommand(
      "synth",
      "Write the chapter's synthetic scene into OUTDIR: model.ply (5678 points), scan.ply (6497: "
      "4310 from the model, 2187 on an intruder wall), ground_truth.txt (4x4, model ≈ T·scan), "
      "plate.ply (7° tilt), plate_cluttered.ply (20 % clutter) and scene.json. Units: mm.\n"
      "With --scene parts: a benchmark work cell of --points points (floor, back wall, 48 "
      "boxes, cylinders and domes; the scan an independent sampling with 70 % overlap, 10°, "
      "noise 0.1 mm, 2 % outliers): model.ply, scan.ply, ground_truth.txt, scene.json.\n"
      "With --scene bin: a 640x480 depth camera 1 m above a bin into which --instances copies of "
      "--part and --distractors other objects were dropped: scene.pcd (organized, NaN kept, "
      "camera frame), model.stl (the part), instance_K.txt (scene ≈ T·model), instances.pgm "
      "(labels), scene.json (poses, visible fractions).\n"
      "With --scene views: --views range scans of the test object, the first at --azimuth, "
      "then every --angle degrees: "
      "view_K.pcd (organized, own camera frame), model.ply, view_K.txt (view_K ≈ T·model), "
      "pair_0_K.txt (view_0 ≈ T·view_K), scene.json.\n"
      "With --scene stitch: range scans of --part (bracket, or flange: keyed by three lugs) from "
      "--views ring views (default 8, at 50° and 25° elevation) around it, tilted 30°, plus a "
      "leaf view from below that overlaps only one of them, its parent at 5° (not with "
      "--no-leaf): scan_KK.ply (each in its own sensor "
      "frame), scans.txt, model.stl, truth.json (poses into scan_00's frame, eyes, overlaps).\n"
      "With --scene part: a machined part (120x80x40 block, chamfer, pocket, two through-holes, "
      "a boss) and its as-built scan from --views 1 or 2 viewpoints (dents, bumps, warp, "
      "--noise, a fixture, a known pose; about 385000 points, or --points): part.stl (CAD), "
      "part_fine.stl (with --triangles), scan.ply, scan_truth.ply (label and true deviation per "
      "point), ground_truth.txt (CAD ≈ T·scan), scene.json.");
  sub->add_option("OUTDIR", o->outdir, "Output directory (created if missing)")->required();
  sub->add_option("--seed", o->seed, "Random seed; the same seed writes the same bytes")
      ->check(CLI::NonNegativeNumber)  // CLI11 would wrap -1 to 2^64 - 1
      ->capture_default_str();
  sub->add_option("--variant", o->variant,
                  "Scene geometry: chapter, or a harder variant for testing registration")
      ->check(CLI::IsMember({"chapter", "wide-plane", "small-features", "large-offset", "extreme"}))
      ->capture_default_str();
  sub->add_option("--scene", o->scene,
                  "chapter (the conveyor scene and plates), parts, bin, views, part or stitch")
      ->check(CLI::IsMember({"chapter", "parts", "bin", "views", "part", "stitch"}))
      ->capture_default_str();
  CLI::Option* points =
      sub->add_option("--points", o->points,
                      "Points in each cloud of the parts scene; about this many scan points "
                      "(--scene part, the raster's pitch chosen to match; default pitch 0.3 mm)")
          ->check(CLI::Range(10, 100000000))
          ->capture_default_str();
  sub->add_option("--instances", o->instances, "Parts dropped into the bin (--scene bin)")
      ->check(CLI::Range(0, 12))
      ->capture_default_str();
  sub->add_option("--part", o->part,
                  "The part in the bin (--scene bin): bracket (no symmetry), flange (turned, "
                  "rotationally symmetric) or plate (mostly flat, 110x70x10 with small features); "
                  "the scanned object (--scene stitch): bracket or flange (keyed by three lugs: "
                  "near-symmetric)")
      ->check(CLI::IsMember({"bracket", "flange", "plate"}))
      ->capture_default_str();
  sub->add_option("--distractors", o->distractors,
                  "Boxes, cylinders and spheres dropped among the parts (--scene bin)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  sub->add_option("--angle", o->angle, "Azimuth step between the views in degrees (--scene views)")
      ->check(CLI::Range(0.0, 360.0))
      ->capture_default_str();
  sub->add_option("--azimuth", o->azimuth, "Azimuth of the first view in degrees (--scene views)")
      ->check(CLI::Range(-360.0, 360.0))
      ->capture_default_str();
  CLI::Option* views =
      sub->add_option("--views", o->views,
                      "Number of views (--scene views; --scene part: 1 or 2; --scene stitch: ring "
                      "views, at least 2, default 8)")
          ->check(CLI::Range(1, 360))
          ->capture_default_str();
  sub->add_flag("--no-leaf", o->no_leaf, "Leave out the leaf view (--scene stitch)");
  sub->add_option("--noise", o->noise, "Scan noise sigma in mm, along the ray (--scene part)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  sub->add_option("--triangles", o->triangles,
                  "Also write part_fine.stl, subdivided to at least this many triangles "
                  "(--scene part)")
      ->check(CLI::Range(std::size_t{0}, std::size_t{100000000}))
      ->capture_default_str();
  return {
      sub, [o, io, points, views] {
        if (o->scene == "stitch") {
          make_directory(o->outdir);
          const nlohmann::json j = write_stitch_scans(
              o->outdir, {o->seed, o->part, views->count() > 0 ? o->views : 8, !o->no_leaf});
          io.out << "wrote " << o->outdir << ": " << j["scans"].size() << " scans of " << o->part;
          if (!j["leaf"].is_null())
            io.out << " (scan " << j["leaf"] << " a leaf over scan " << j["leaf_parent"] << ")";
          io.out << ", scans.txt, model.stl, truth.json\n";
          return 0;
        }
        if (o->scene == "part") {
          const nlohmann::json j = write_part_scene(
              o->outdir, {o->seed, o->views, o->noise, o->triangles,
                          points->count() > 0 ? static_cast<std::size_t>(o->points) : 0});
          io.out << "wrote " << o->outdir << ": part.stl " << j["part"]["triangles"]
                 << " triangles, scan " << j["scan"]["points"] << " points ("
                 << j["scan"]["fixture_points"] << " on the fixture)\n";
          return 0;
        }
        if (o->scene == "bin") {
          make_directory(o->outdir);
          const nlohmann::json j =
              write_bin_scene(o->outdir, {o->seed, o->part, o->instances, o->distractors});
          io.out << "wrote " << o->outdir << ": scene.pcd " << j["cloud"]["width"] << "x"
                 << j["cloud"]["height"] << " (" << j["cloud"]["valid_points"]
                 << " valid points), model.stl (" << o->part << "), " << j["instances"].size()
                 << " instance(s), " << j["distractors"] << " distractor(s)\n";
          return 0;
        }
        if (o->scene == "views") {
          make_directory(o->outdir);
          const nlohmann::json j =
              write_object_views(o->outdir, o->seed, o->azimuth, o->angle, o->views);
          io.out << "wrote " << o->outdir << ": " << j["views"].size() << " views " << o->angle
                 << "° apart, model " << j["model"]["points"] << " points\n";
          return 0;
        }
        if (o->scene == "parts") {
          const nlohmann::json j = write_parts_scene(o->outdir, o->seed, o->points);
          io.out << "wrote " << o->outdir << ": model " << j["model"]["points"] << " points, scan "
                 << j["scan"]["points"] << " points\n";
          return 0;
        }
        const nlohmann::json j = write_scene(o->outdir, o->seed, o->variant);
        io.out << "wrote " << o->outdir << ": model " << j["model"]["points"] << " points, scan "
               << j["scan"]["points"] << " points (" << j["scan"]["no_correspondence"]
               << " without correspondence), plates " << j["plate"]["points"] << " and "
               << j["plate_cluttered"]["points"] << " points\n";
        return 0;
      }};
}

}  // namespace align3d::cli
