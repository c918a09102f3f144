// `align3d synth --scene part`: the machined part of synth/part.hpp and its as-built scan written
// as files (private to the tool).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>

namespace align3d::cli {

// The values of synth's flags (their defaults are declared there, with the flags).
struct PartSceneOptions {
  std::uint64_t seed;
  int views;              // 1 or 2 (else UsageError)
  double noise;           // mm
  std::size_t triangles;  // > 0: part_fine.stl subdivided to at least this many
  std::size_t points;     // > 0: the pitch is chosen for about this many points
};

// part.stl, part_fine.stl (with triangles > 0), scan.ply, scan_truth.ply, ground_truth.txt
// (CAD ≈ T·scan) and scene.json, which it returns; `outdir` is created if missing.
nlohmann::json write_part_scene(const std::filesystem::path& outdir, const PartSceneOptions& o);

}  // namespace align3d::cli
