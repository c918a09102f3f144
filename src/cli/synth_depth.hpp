// `align3d synth --scene bin|views`: the depth-camera scenes of synth/depth_scenes.hpp written as
// files (private to the tool).
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace align3d::cli {

// The values of synth's flags for --scene bin (their defaults are declared with the flags).
struct BinSceneOptions {
  std::uint64_t seed;
  std::string part;  // bracket or flange
  int instances;     // 0 to 12
  int distractors;
};

// The bin-picking scene of synth/bin_picking.hpp: scene.pcd (organized 640 × 480, NaN kept,
// camera frame), model.stl (the part), instance_K.txt (scene ≈ T·model), instances.pgm (per-pixel
// instance labels) and scene.json (with each instance's visible fraction), which it returns.
nlohmann::json write_bin_scene(const std::filesystem::path& outdir, const BinSceneOptions& o);

// view_K.pcd (organized, each in its own camera frame) at azimuths start_deg + K·angle_deg,
// model.ply, view_K.txt (view_K ≈ T·model), pair_0_K.txt (view_0 ≈ T·view_K) and scene.json.
nlohmann::json write_object_views(const std::filesystem::path& outdir, std::uint64_t seed,
                                  double start_deg, double angle_deg, int views);

}  // namespace align3d::cli
