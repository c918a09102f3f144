// `align3d synth --scene part` (synth_part.hpp).
#include "synth_part.hpp"

#include <iostream>

#include "align3d/error.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/ply_attributes.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/synth/part.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

// scan_truth.ply: one vertex per scan point, in scan order: x y z (float, as scan.ply), deviation
// (float, mm: the true δ along the CAD normal, no noise), label (uchar: 0 part, 1 fixture), view
// (uchar).
void write_scan_truth(const std::filesystem::path& path, const synth::AsBuiltScan& scan) {
  io::PlyAttributes a;
  a.scalars.push_back(
      {"deviation", std::vector<float>(scan.deviation.begin(), scan.deviation.end())});
  std::vector<std::uint8_t> label(scan.label.size());
  for (std::size_t i = 0; i < label.size(); ++i)
    label[i] = static_cast<std::uint8_t>(scan.label[i]);
  a.bytes.push_back({"label", std::move(label)});
  a.bytes.push_back({"view", scan.view});
  io::write_ply(path, scan.scan.positions, a);
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

}  // namespace

nlohmann::json write_part_scene(const std::filesystem::path& outdir, const PartSceneOptions& o) {
  if (o.views < 1 || o.views > 2) throw UsageError("--views: 1 or 2 with --scene part");
  std::error_code ec;
  std::filesystem::create_directories(outdir, ec);
  if (ec) throw OutputError(outdir, "cannot create directory: " + ec.message());
  synth::AsBuiltSettings s;
  s.seed = o.seed;
  s.noise_sigma = o.noise;
  s.views.resize(static_cast<std::size_t>(o.views));
  s.target_points = o.points;
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
       "per scan point, in scan.ply's order: x y z (float, as scan.ply), deviation (float, mm: "
       "the true displacement along the CAD normal, dents and bumps plus warp, without noise; 0 "
       "on the fixture), label (uchar: 0 part, 1 fixture), view (uchar)"}};
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

}  // namespace align3d::cli
