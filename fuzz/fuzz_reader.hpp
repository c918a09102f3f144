// Shared body of the libFuzzer targets for the point-cloud readers. Each input is handed to a
// format reader as the bytes of a whole file (the readers parse from memory; see
// src/io/io_detail.hpp), so nothing touches the disk and an over-read of the exact-size buffer is
// an AddressSanitizer report. An IoError is the expected outcome for bad input; anything else that
// escapes (another exception, a crash, a leak, a timeout, an allocation beyond -malloc_limit_mb) is
// a finding. A cloud that is returned must honour point_cloud_io.hpp's contract.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "align3d/error.hpp"
#include "io_detail.hpp"

namespace align3d::fuzz {

// Aborts (a libFuzzer crash) when a returned cloud breaks the reader contract: positions finite,
// normals absent or one unit vector per position.
inline void check_cloud(const PointCloud& cloud) {
  for (const auto& p : cloud.positions) {
    if (!p.allFinite()) __builtin_trap();
  }
  if (cloud.normals.empty()) return;
  if (cloud.normals.size() != cloud.positions.size()) __builtin_trap();
  for (const auto& n : cloud.normals) {
    if (!n.allFinite() || std::abs(n.norm() - 1.0) > 1e-9) __builtin_trap();
  }
}

using Reader = PointCloud (*)(const std::filesystem::path&, std::string_view, std::size_t&);

inline int run_reader(Reader reader, const char* name, const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;  // read_file rejects empty files before any reader sees them
  static const std::filesystem::path path(name);
  try {
    std::size_t dropped = 0;
    const PointCloud cloud =
        reader(path, std::string_view(reinterpret_cast<const char*>(data), size), dropped);
    check_cloud(cloud);
  } catch (const IoError&) {
  }
  return 0;
}

}  // namespace align3d::fuzz
