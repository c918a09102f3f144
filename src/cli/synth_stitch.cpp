#include "synth_stitch.hpp"

#include <cstdio>
#include <iostream>
#include <string>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/synth/stitch_scans.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

// scan_00.ply, scan_01.ply, …: two digits at least.
std::string scan_name(std::size_t k) {
  char name[32];
  std::snprintf(name, sizeof name, "scan_%02zu.ply", k);
  return name;
}

nlohmann::json overlap_json(const Eigen::MatrixXd& overlap) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index i = 0; i < overlap.rows(); ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index j = 0; j < overlap.cols(); ++j) row.push_back(overlap(i, j));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json index_or_null(int k) { return k >= 0 ? nlohmann::json(k) : nlohmann::json(); }

}  // namespace

nlohmann::json write_stitch_scans(const std::filesystem::path& outdir,
                                  const StitchScenesOptions& o) {
  if (o.views < 2) throw UsageError("--scene stitch needs --views of at least 2");
  synth::StitchScanSettings s;
  s.seed = o.seed;
  s.object = synth::stitch_object_from_string(o.part);
  s.views = o.views;
  s.leaf = o.leaf;
  const synth::StitchScans out = synth::make_stitch_scans(s);
  io::write_mesh(outdir / "model.stl", out.mesh);
  std::string listing;
  nlohmann::json scans = nlohmann::json::array();
  for (std::size_t k = 0; k < out.scans.size(); ++k) {
    const std::string file = scan_name(k);
    io::write_ply(outdir / file, out.scans[k]);
    listing += file + "\n";
    scans.push_back({{"file", file},
                     {"points", out.scans[k].size()},
                     {"eye", to_json(out.eye[k])},
                     {"pose",
                      {{"meaning", "maps this scan into scan_00's frame: scan_00 ≈ T·scan_k"},
                       {"transformation", to_json(out.T_first_scan[k])}}},
                     {"T_camera_object", to_json(out.T_camera_object[k])}});
  }
  io::write_text_atomically(outdir / "scans.txt", listing);
  const double distance = s.distance;
  nlohmann::json json = {
      {"units", "mm"},
      {"seed", o.seed},
      {"scene", "stitch"},
      {"part", o.part},
      {"model",
       {{"file", "model.stl"},
        {"triangles", out.mesh.triangles.size()},
        {"frame", "object: resting on z = 0, z up; eye and T_camera_object refer to it"}}},
      {"diameter", out.diameter},
      {"noise_sigma", s.sensor.sigma(distance)},
      {"noise",
       "depth along the ray, sigma(z) = noise_a + noise_b·z² (mm); noise_sigma at the ring's "
       "distance"},
      {"noise_a", s.sensor.noise_a},
      {"noise_b", s.sensor.noise_b},
      {"scan_frame",
       "each scan in its own sensor frame: the sensor at the origin, x right, "
       "y down, looking along +z"},
      {"scans", scans},
      {"overlap", overlap_json(out.overlap)},
      {"overlap_meaning",
       "share of the model's surface samples visible in both scans among those visible in either "
       "(exact visibility: in the image, nothing in front, incidence below the sensor's maximum)"},
      {"leaf", index_or_null(out.leaf)},
      {"leaf_parent", index_or_null(out.leaf_parent)},
      {"ring",
       {{"views", o.views},
        {"distance", distance},
        {"high_elevation_deg", s.high_elevation_deg},
        {"low_elevation_deg", s.low_elevation_deg},
        {"parent_elevation_deg",
         s.leaf ? nlohmann::json(s.parent_elevation_deg) : nlohmann::json(nullptr)},
        {"tilt_deg", s.tilt_deg},
        {"jitter_deg", s.jitter_deg},
        {"jitter_mm", s.jitter_mm}}},
      {"camera",
       {{"width", s.camera.width},
        {"height", s.camera.height},
        {"fx", s.camera.fx},
        {"fy", s.camera.fy},
        {"cx", s.camera.cx},
        {"cy", s.camera.cy}}}};
  write_json((outdir / "truth.json").string(), json, std::cout);
  return json;
}

}  // namespace align3d::cli
