// Shared body of the libFuzzer targets for the point-cloud readers. Each input is handed to a
// format reader as the bytes of a whole file, streamed from memory (src/io/block_reader.hpp) in
// short reads whose length varies with the input's size, so that block boundaries fall anywhere;
// nothing touches the disk, and an over-read of the reader's buffer is an AddressSanitizer report.
// An IoError is the expected outcome for bad input; anything else that escapes (another exception,
// a crash, a leak, a timeout, an allocation beyond -malloc_limit_mb) is a finding. A cloud that is
// returned must honour point_cloud_io.hpp's contract.
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

// A reader of the input as a file of that name: 1 to 97 bytes a read, by the input's size.
struct FuzzInput {
  FuzzInput(const char* name, const std::uint8_t* data, std::size_t size)
      : path(name),
        source(std::string_view(reinterpret_cast<const char*>(data), size), 1 + size % 97),
        in(path, source) {}
  std::filesystem::path path;
  io::detail::MemorySource source;
  io::detail::BlockReader in;
};

using Reader = PointCloud (*)(io::detail::BlockReader&, io::ReadInfo&);

inline int run_reader(Reader reader, const char* name, const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;  // open_file rejects empty files before any reader sees them
  FuzzInput input(name, data, size);
  try {
    io::ReadInfo info;
    const PointCloud cloud = reader(input.in, info);
    check_cloud(cloud);
    if (cloud.size() + info.dropped_non_finite != info.width * info.height) __builtin_trap();
  } catch (const IoError&) {
  }
  return 0;
}

}  // namespace align3d::fuzz
