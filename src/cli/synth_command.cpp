// align3d synth OUTDIR: the chapter's scene and plates (synth/scenes.hpp), the parts cell, the
// depth-camera scenes (synth/depth_scenes.hpp, written by synth_depth.cpp), or the machined part
// and its as-built scan (synth/part.hpp), with ground truth.
#include <algorithm>
#include <bit>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/part.hpp"
#include "align3d/synth/scenes.hpp"
#include "common.hpp"
#include "synth_depth.hpp"

namespace align3d::cli {

namespace {

struct SynthOptions {
  std::string outdir;
  std::uint64_t seed = 39;
  std::string variant = "chapter";
  std::string scene = "chapter";
  int points = 100000;
  int instances = 1;
  double azimuth = 30;
  double angle = 60;
  int views = 2;
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

// Appends a value's bytes, little-endian whatever the host.
template <class T>
void put_le(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  out.append(bytes, sizeof(T));
}

// scan_truth.ply: one vertex per scan point, in scan order: x y z (float, as scan.ply), label
// (uchar: 0 part, 1 fixture), deviation (float, mm: the true δ along the CAD normal, no noise),
// view (uchar).
void write_scan_truth(const std::filesystem::path& path, const synth::AsBuiltScan& scan) {
  std::string data =
      "ply\nformat binary_little_endian 1.0\ncomment align3d synth --scene part: ground truth per "
      "scan point\nelement vertex " +
      std::to_string(scan.scan.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nproperty uchar label\n"
      "property float deviation\nproperty uchar view\nend_header\n";
  data.reserve(data.size() + 18 * scan.scan.size());
  for (std::size_t i = 0; i < scan.scan.size(); ++i) {
    for (int k = 0; k < 3; ++k) put_le(data, static_cast<float>(scan.scan.positions[i][k]));
    put_le(data, static_cast<std::uint8_t>(scan.label[i]));
    put_le(data, static_cast<float>(scan.deviation[i]));
    put_le(data, scan.view[i]);
  }
  io::write_text_atomically(path, data);
}

nlohmann::json part_json(const synth::PartModel& part, const TriangleMesh& mesh) {
  const synth::PartSettings& p = part.settings();
  nlohmann::json holes = nlohmann::json::array();
  for (const synth::PartHole& h : p.holes)
    holes.push_back({{"centre", {h.centre.x(), h.centre.y()}},
                     {"radius", h.radius},
                     {"through", part.in_pocket(h) ? "the pocket floor" : "the top"}});
  return {{"file", "part.stl"},
          {"meaning",
           "the CAD model, as designed: closed, manifold, wound outward; corners shared "
           "exactly, so welding the STL's corners restores the mesh"},
          {"format", "binary STL, float32"},
          {"frame", "CAD: base on z = 0, z up, the block centred on the z axis"},
          {"triangles", mesh.triangles.size()},
          {"vertices", mesh.vertices.size()},
          {"block", to_json(p.block)},
          {"chamfer", {{"leg", p.chamfer}, {"angle_deg", 45}, {"edges", "the top outer edges"}}},
          {"pocket",
           {{"min", {p.pocket_min.x(), p.pocket_min.y()}},
            {"max", {p.pocket_max.x(), p.pocket_max.y()}},
            {"depth", p.pocket_depth},
            {"floor_z", part.floor_z()}}},
          {"holes", holes},
          {"boss",
           {{"centre", {p.boss_centre.x(), p.boss_centre.y()}},
            {"radius", p.boss_radius},
            {"height", p.boss_height},
            {"top_z", part.top_z() + p.boss_height}}},
          {"circle_segments", p.circle_segments},
          {"circles", "regular polygons, vertex k at angle 2πk/n from +x, radius = circumradius"},
          {"surface_area", surface_area(mesh)},
          {"volume", analyse_topology(mesh).signed_volume}};
}

nlohmann::json defects_json(const synth::AsBuiltSettings& s) {
  nlohmann::json list = nlohmann::json::array();
  for (const synth::SurfaceDefect& d : s.defects)
    list.push_back({{"kind", d.peak < 0 ? "dent" : "bump"},
                    {"centre", to_json(d.centre)},
                    {"normal", to_json(d.normal)},
                    {"radius", d.radius},
                    {"peak", d.peak}});
  return list;
}

nlohmann::json scan_json(const synth::AsBuiltSettings& s, const synth::AsBuiltScan& scan) {
  nlohmann::json views = nlohmann::json::array(), fixture = nlohmann::json::array();
  for (const synth::ScanRaster& r : scan.rasters)
    views.push_back({{"direction", to_json(r.direction)},
                     {"origin", to_json(r.origin)},
                     {"u", to_json(r.u)},
                     {"v", to_json(r.v)},
                     {"columns", r.columns},
                     {"rows", r.rows},
                     {"points", r.points}});
  for (const synth::FixtureBox& b : s.fixture)
    fixture.push_back(
        {{"name", b.name}, {"min", to_json(b.min)}, {"max", to_json(b.max)}, {"framed", b.framed}});
  return {
      {"file", "scan.ply"},
      {"frame", "scanner: CAD ≈ T·scan (ground_truth.txt)"},
      {"points", scan.scan.size()},
      {"part_points", scan.part_points},
      {"fixture_points", scan.fixture_points},
      {"scanner",
       {{"projection",
         "parallel rays (telecentric), ray (i, j) from origin + (i + ½)·pitch·u + "
         "(j + ½)·pitch·v along direction; CAD frame; points in view order, then row j, "
         "then column i"},
        {"pitch", scan.pitch},
        {"target_points", s.target_points > 0 ? nlohmann::json(s.target_points) : nlohmann::json()},
        {"raster_margin", s.raster_margin},
        {"max_incidence_deg", s.max_incidence_deg},
        {"noise_sigma", s.noise_sigma},
        {"noise", "Gaussian, along the ray (range noise)"},
        {"views", views}}},
      {"defects", defects_json(s)},
      {"defect_profile",
       "the surface moves along the face's outward normal by peak·cos²(π·r / 2·radius) at "
       "distance r < radius from the centre in the face's plane; peak < 0 is a dent"},
      {"warp",
       {{"amplitude", s.warp_amplitude},
        {"wavelength", s.warp_wavelength},
        {"formula",
         "along the normal: amplitude·sin(2πx/λ + 0.3)·sin(2πy/λ + 1.1)·cos(2πz/λ), "
         "CAD frame"}}},
      {"fixture",
       {{"boxes", fixture},
        {"clearance", s.fixture_clearance},
        {"dropped_near_part", scan.dropped_near_part},
        {"meaning",
         "scanned but not in the CAD; fixture hits closer than `clearance` to the CAD surface "
         "are dropped"}}}};
}

// The machined part and its as-built scan (synth::make_as_built_scan): part.stl, part_fine.stl
// (with triangles > 0), scan.ply, scan_truth.ply, ground_truth.txt and scene.json.
nlohmann::json write_part_scene(const std::filesystem::path& outdir, const SynthOptions& o,
                                bool points_given) {
  if (o.views < 1 || o.views > 2) throw UsageError("--views: 1 or 2 with --scene part");
  make_directory(outdir);
  synth::AsBuiltSettings s;
  s.seed = o.seed;
  s.noise_sigma = o.noise;
  s.views.resize(static_cast<std::size_t>(o.views));
  if (points_given) s.target_points = static_cast<std::size_t>(o.points);
  const synth::PartModel part(s.part);
  const TriangleMesh mesh = part.mesh();
  const synth::AsBuiltScan scan = synth::make_as_built_scan(s);
  io::write_mesh(outdir / "part.stl", mesh);
  nlohmann::json json = {{"units", "mm"}, {"seed", o.seed}, {"scene", "part"}};
  json["part"] = part_json(part, mesh);
  if (o.triangles > 0) {
    const TriangleMesh fine = part.mesh(o.triangles);
    io::write_mesh(outdir / "part_fine.stl", fine);
    json["part_fine"] = {{"file", "part_fine.stl"},
                         {"triangles", fine.triangles.size()},
                         {"meaning",
                          "part.stl with every triangle split into 4 at its edge "
                          "midpoints until --triangles is reached: the same surface"}};
  }
  io::write_ply(outdir / "scan.ply", scan.scan);
  write_scan_truth(outdir / "scan_truth.ply", scan);
  io::write_matrix(outdir / "ground_truth.txt", scan.T_cad_scan);
  json["scan"] = scan_json(s, scan);
  json["scan_truth"] = {
      {"file", "scan_truth.ply"},
      {"meaning",
       "per scan point, in scan.ply's order: x y z (float, as scan.ply), label (uchar: 0 part, 1 "
       "fixture), deviation (float, mm: the true displacement along the CAD normal, dents and "
       "bumps plus warp, without noise; 0 on the fixture), view (uchar)"}};
  json["ground_truth"] = {{"file", "ground_truth.txt"},
                          {"meaning", "maps the scan into the CAD frame: CAD ≈ T·scan"},
                          {"transformation", to_json(scan.T_cad_scan)},
                          {"inverse",
                           {{"meaning",
                             "T_scan_cad: rotation_deg about rotation_axis, then "
                             "translation"},
                            {"rotation_deg", s.rotation_deg},
                            {"rotation_axis", to_json(s.rotation_axis)},
                            {"translation", to_json(s.translation)}}}};
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
      "With --scene bin: a 640x480 depth camera 0.9 m above a bin with --instances copies of a "
      "test object and clutter: scene.pcd (organized, NaN kept, camera frame), model.ply, "
      "instance_K.txt (scene ≈ T·model), instances.pgm (labels), scene.json.\n"
      "With --scene views: --views range scans of the test object, the first at --azimuth, "
      "then every --angle degrees: "
      "view_K.pcd (organized, own camera frame), model.ply, view_K.txt (view_K ≈ T·model), "
      "pair_0_K.txt (view_0 ≈ T·view_K), scene.json.\n"
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
                  "chapter (the conveyor scene and plates), parts, bin, views or part")
      ->check(CLI::IsMember({"chapter", "parts", "bin", "views", "part"}))
      ->capture_default_str();
  CLI::Option* points =
      sub->add_option("--points", o->points,
                      "Points in each cloud of the parts scene; about this many scan points "
                      "(--scene part, the raster's pitch chosen to match; default pitch 0.3 mm)")
          ->check(CLI::Range(10, 100000000))
          ->capture_default_str();
  sub->add_option("--instances", o->instances,
                  "Test objects in the bin (--scene bin; up to 3 fit for any seed)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  sub->add_option("--angle", o->angle, "Azimuth step between the views in degrees (--scene views)")
      ->check(CLI::Range(0.0, 360.0))
      ->capture_default_str();
  sub->add_option("--azimuth", o->azimuth, "Azimuth of the first view in degrees (--scene views)")
      ->check(CLI::Range(-360.0, 360.0))
      ->capture_default_str();
  sub->add_option("--views", o->views, "Number of views (--scene views; --scene part: 1 or 2)")
      ->check(CLI::Range(1, 360))
      ->capture_default_str();
  sub->add_option("--noise", o->noise, "Scan noise sigma in mm, along the ray (--scene part)")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  sub->add_option("--triangles", o->triangles,
                  "Also write part_fine.stl, subdivided to at least this many triangles "
                  "(--scene part)")
      ->check(CLI::Range(std::size_t{0}, std::size_t{100000000}))
      ->capture_default_str();
  return {sub, [o, io, points] {
            if (o->scene == "part") {
              const nlohmann::json j = write_part_scene(o->outdir, *o, points->count() > 0);
              io.out << "wrote " << o->outdir << ": part.stl " << j["part"]["triangles"]
                     << " triangles, scan " << j["scan"]["points"] << " points ("
                     << j["scan"]["fixture_points"] << " on the fixture)\n";
              return 0;
            }
            if (o->scene == "bin") {
              make_directory(o->outdir);
              const nlohmann::json j = write_bin_scene(o->outdir, o->seed, o->instances);
              io.out << "wrote " << o->outdir << ": scene.pcd " << j["cloud"]["width"] << "x"
                     << j["cloud"]["height"] << " (" << j["cloud"]["valid_points"]
                     << " valid points), model " << j["model"]["points"] << " points, "
                     << j["instances"].size() << " instance(s)\n";
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
              io.out << "wrote " << o->outdir << ": model " << j["model"]["points"]
                     << " points, scan " << j["scan"]["points"] << " points\n";
              return 0;
            }
            const nlohmann::json j = write_scene(o->outdir, o->seed, o->variant);
            io.out << "wrote " << o->outdir << ": model " << j["model"]["points"]
                   << " points, scan " << j["scan"]["points"] << " points ("
                   << j["scan"]["no_correspondence"] << " without correspondence), plates "
                   << j["plate"]["points"] << " and " << j["plate_cluttered"]["points"]
                   << " points\n";
            return 0;
          }};
}

}  // namespace align3d::cli
