// Points with attributes as PLY: per-point float scalars (a deviation, a score) and RGB colours,
// for results a viewer (CloudCompare, MeshLab, ParaView) shows coloured and lets one pick values.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace align3d::io {

struct PlyAttributes {
  std::vector<Eigen::Vector3d> normals;  // property float nx ny nz; empty: none
  // property float <name>, one value per point (NaN allowed: a viewer shows it as "no value").
  std::vector<std::pair<std::string, std::vector<float>>> scalars;
  // property int <name>, one value per point (ids beyond a byte's range: an instance's rank).
  std::vector<std::pair<std::string, std::vector<std::int32_t>>> ints;
  // property uchar <name>, one value per point (labels, counts).
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> bytes;
  std::vector<std::array<std::uint8_t, 3>> colors;  // uchar red green blue; empty: none
};

// Binary little-endian PLY: float x y z, float nx ny nz (when there are normals; the cloud readers
// read them back as the cloud's normals), then the scalars, the ints, the bytes (each in order),
// then the colours. Every attribute must have one entry per point and names must be unique
// identifiers (std::invalid_argument otherwise). Atomic (OutputError on failure, nothing left
// behind).
void write_ply(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& positions,
               const PlyAttributes& attributes);

}  // namespace align3d::io
