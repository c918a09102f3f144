#include "synth_depth.hpp"

#include <Eigen/Geometry>
#include <iostream>
#include <string>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/mesh.hpp"
#include "align3d/synth/bin_picking.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

// An organized binary PCD (WIDTH × HEIGHT, NaN kept, VIEWPOINT the identity: the points are in the
// sensor's frame).
void write_organized_pcd(const std::filesystem::path& path, const synth::OrganizedCloud& cloud) {
  PointCloud points;
  points.positions = cloud.positions;
  io::PcdLayout layout;
  layout.width = static_cast<std::size_t>(cloud.width);
  layout.height = static_cast<std::size_t>(cloud.height);
  io::write_pcd(path, points, io::PcdEncoding::kBinary, layout);
}

// An 8-bit binary PGM of per-pixel labels: 0 where label < 0, label + 1 otherwise (up to 254).
void write_label_pgm(const std::filesystem::path& path, int width, int height,
                     const std::vector<int>& labels) {
  std::string data = "P5\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
  for (int label : labels) data += static_cast<char>(label < 0 ? 0 : std::min(label + 1, 255));
  io::write_text_atomically(path, data);
}

nlohmann::json camera_json(const synth::PinholeCamera& c) {
  return {{"width", c.width},
          {"height", c.height},
          {"fx", c.fx},
          {"fy", c.fy},
          {"cx", c.cx},
          {"cy", c.cy},
          {"frame",
           "x right, y down, z forward (optical axis); pixel (u, v) = column u, row v, "
           "point index v·width + u; u = cx + fx·x/z, v = cy + fy·y/z"}};
}

nlohmann::json sensor_json(const synth::DepthSensorSettings& s) {
  return {{"min_depth", s.min_depth},
          {"max_depth", s.max_depth},
          {"noise", "along the ray, depth sigma(z) = noise_a + noise_b·z² (mm)"},
          {"noise_a", s.noise_a},
          {"noise_b", s.noise_b},
          {"max_incidence_deg", s.max_incidence_deg},
          {"projector_offset", to_json(s.projector_offset)},
          {"dropout", s.dropout},
          {"hole_clusters", s.hole_clusters},
          {"hole_radius_max", s.hole_radius_max}};
}

nlohmann::json cloud_json(const std::string& file, const synth::OrganizedCloud& cloud) {
  return {{"file", file},
          {"organized", true},
          {"width", cloud.width},
          {"height", cloud.height},
          {"valid_points", cloud.valid_count()},
          {"frame", "camera"},
          {"viewpoint", "0 0 0 1 0 0 0 (the camera)"},
          {"nan",
           "pixels without a return: no surface or out of range, grazing incidence, "
           "projector shadow, dropout, hole clusters"}};
}

nlohmann::json model_json(const PointCloud& model) {
  return {{"file", "model.ply"},
          {"points", model.size()},
          {"normals", "outward"},
          {"frame", "object: base on z = 0, z up"},
          {"description",
           "the test object (synth::test_object_shapes): base block 140 × 80 × 30, upright wall "
           "18 × 68 × 65 near +x, cylinder boss r 16 at (−35, 12), sphere knob r 16 at "
           "(5, −22, 34)"}};
}

}  // namespace

nlohmann::json write_bin_scene(const std::filesystem::path& outdir, const BinSceneOptions& o) {
  synth::BinPickingSettings s;
  s.seed = o.seed;
  s.instances = o.instances;
  s.distractors = o.distractors;
  s.part = synth::bin_part_from_string(o.part);
  const synth::BinPickingScene scene = synth::make_bin_picking_scene(s);
  write_organized_pcd(outdir / "scene.pcd", scene.cloud);
  io::write_mesh(outdir / "model.stl", scene.model);
  write_label_pgm(outdir / "instances.pgm", scene.cloud.width, scene.cloud.height,
                  scene.cloud.shape);
  nlohmann::json list = nlohmann::json::array();
  for (std::size_t k = 0; k < scene.instances.size(); ++k) {
    const synth::BinPickingInstance& in = scene.instances[k];
    const std::string file = "instance_" + std::to_string(k) + ".txt";
    io::write_matrix(outdir / file, in.T_camera_model);
    list.push_back({{"file", file},
                    {"meaning", "maps the model into the scene (camera frame): scene ≈ T·model"},
                    {"transformation", to_json(in.T_camera_model)},
                    {"pixels", in.pixels},
                    {"visible_fraction", in.visible_fraction}});
  }
  const bool flange = s.part == synth::BinPart::kFlange;
  nlohmann::json json = {
      {"units", "mm"},
      {"seed", o.seed},
      {"scene", "bin"},
      {"cloud", cloud_json("scene.pcd", scene.cloud)},
      {"model",
       {{"file", "model.stl"},
        {"part", o.part},
        {"triangles", scene.model.triangles.size()},
        {"diameter", bounding_box_diagonal(scene.model)},
        {"frame", "the part's CAD frame: resting on z = 0, z up"},
        {"symmetry", flange ? "continuous rotation about the model's z axis" : "none"}}},
      {"instances", list},
      {"visible_fraction",
       "pixels where the instance is the first surface ÷ pixels it would cover alone (exact ray "
       "casts, no sensor losses; BOP's visib_fract)"},
      {"labels",
       {{"file", "instances.pgm"},
        {"meaning", "8-bit per pixel: 0 no instance (or no point), K + 1 instance K"}}},
      {"distractors", scene.distractors},
      {"camera", camera_json(scene.camera)},
      {"sensor", sensor_json(s.sensor)},
      {"floor",
       {{"frame", "camera"},
        {"normal", to_json(scene.floor.normal)},
        {"point", to_json(scene.floor.point)},
        {"meaning",
         "the bin's inside bottom: normal·(p − point) = 0, the normal towards the camera"}}},
      {"world",
       {{"meaning", "the floor is z = 0, z up, the bin's base centred on the origin"},
        {"T_world_camera", to_json(scene.camera.T_world_camera)},
        {"camera_height", s.camera_height},
        {"camera_tilt_deg", s.camera_tilt_deg},
        {"bin_size", to_json(s.bin_size)},
        {"bin_wall", s.bin_wall}}}};
  write_json((outdir / "scene.json").string(), json, std::cout);
  return json;
}

nlohmann::json write_object_views(const std::filesystem::path& outdir, std::uint64_t seed,
                                  double start_deg, double angle_deg, int views) {
  synth::ObjectViewsSettings s;
  s.seed = seed;
  s.azimuth_deg.clear();
  for (int k = 0; k < views; ++k) s.azimuth_deg.push_back(start_deg + k * angle_deg);
  const synth::ObjectViews out = synth::make_object_views(s);
  io::write_ply(outdir / "model.ply", out.model);
  nlohmann::json list = nlohmann::json::array(), pairs = nlohmann::json::array();
  for (std::size_t k = 0; k < out.views.size(); ++k) {
    const std::string name = "view_" + std::to_string(k);
    write_organized_pcd(outdir / (name + ".pcd"), out.views[k]);
    io::write_matrix(outdir / (name + ".txt"), out.T_camera_object[k]);
    list.push_back(
        {{"cloud", cloud_json(name + ".pcd", out.views[k])},
         {"azimuth_deg", s.azimuth_deg[k]},
         {"pose",
          {{"file", name + ".txt"},
           {"meaning", "maps the model into this view's camera frame: " + name + " ≈ T·model"},
           {"transformation", to_json(out.T_camera_object[k])}}},
         {"T_world_camera", to_json(out.cameras[k].T_world_camera)}});
    if (k == 0) continue;
    const std::string file = "pair_0_" + std::to_string(k) + ".txt";
    const Eigen::Isometry3d T = out.T_camera_object[0] * out.T_camera_object[k].inverse();
    io::write_matrix(outdir / file, T);
    pairs.push_back(
        {{"file", file},
         {"meaning", "maps view " + std::to_string(k) + " into view 0: view_0 ≈ T·" + name},
         {"angle_deg", s.azimuth_deg[k] - s.azimuth_deg[0]},
         {"transformation", to_json(T)}});
  }
  nlohmann::json json = {
      {"units", "mm"},
      {"seed", seed},
      {"scene", "views"},
      {"model", model_json(out.model)},
      {"views", list},
      {"pairs", pairs},
      {"world",
       {{"meaning", "the object frame; the camera on a circle about the object's z axis"},
        {"distance", s.distance},
        {"elevation_deg", s.elevation_deg},
        {"target", {0, 0, s.target_height}}}},
      {"camera", camera_json(s.camera)},
      {"sensor", sensor_json(s.sensor)}};
  write_json((outdir / "scene.json").string(), json, std::cout);
  return json;
}

}  // namespace align3d::cli
