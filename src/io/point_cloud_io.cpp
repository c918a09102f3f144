#include "align3d/io/point_cloud_io.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <new>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "align3d/error.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace detail {

void fail(const std::filesystem::path& path, const std::string& problem) {
  throw IoError(path, problem);
}

void check_line_length(const std::filesystem::path& path, std::string_view line, std::size_t number,
                       std::size_t limit) {
  if (line.size() > limit) {
    fail(path,
         "line " + std::to_string(number) + " is longer than " + std::to_string(limit) + " bytes");
  }
}

std::string quoted(std::string_view token) {
  constexpr std::size_t kMaxShown = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < token.size() && i < kMaxShown; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (token.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

void fail_out_of_memory(const std::filesystem::path& path, const std::string& what) {
  throw DataError(path.string() + ": not enough memory for " + what);
}

void CloudBuilder::reserve(std::size_t count) {
  try {
    positions_.reserve(count);
    if (keep_indices_) indices_.reserve(count);
    if (normals_ok_) normals_.reserve(count);
  } catch (const std::bad_alloc&) {
    const double bytes =
        static_cast<double>(count) * (normals_ok_ ? 2 : 1) * sizeof(Eigen::Vector3d);
    fail_out_of_memory(
        path_, std::to_string(count) + " points (" +
                   std::to_string(static_cast<std::uint64_t>(std::ceil(bytes / (1 << 20)))) +
                   " MiB" + (normals_ok_ ? " with normals)" : ")"));
  }
}

void CloudBuilder::allocate(std::size_t count) {
  reserve(count);
  positions_.resize(count);
  if (normals_ok_) normals_.resize(count);
  columns_ = true;
}

PointCloud CloudBuilder::finish() {
  if (columns_) {
    // The rules of add(), in place: point i moves to `kept` <= i.
    std::size_t kept = 0;
    for (std::size_t i = 0; i < positions_.size(); ++i) {
      const Eigen::Vector3d p = positions_[i];
      if (!p.allFinite()) {
        ++dropped_;
        continue;
      }
      positions_[kept] = p;
      keep_index(i);
      if (normals_ok_) keep_normal(normals_[i], kept);
      ++kept;
    }
    positions_.resize(kept);
    if (normals_ok_) normals_.resize(kept);
    columns_ = false;
  }
  PointCloud cloud;
  cloud.positions = std::move(positions_);
  if (normals_ok_) {
    for (auto& n : normals_) n.normalize();
    cloud.normals = std::move(normals_);
  }
  return cloud;
}

}  // namespace detail

namespace {

using detail::lower_extension;

std::string unknown_format_problem(const std::string& ext) {
  return "unknown point cloud format " +
         (ext.empty() ? std::string("(no extension)") : "'" + ext + "'") +
         " (expected .ply, .pcd, .xyz, .txt or .csv)";
}

}  // namespace

std::optional<CloudFormat> cloud_format(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return CloudFormat::kPly;
  if (ext == ".pcd") return CloudFormat::kPcd;
  if (ext == ".xyz" || ext == ".txt" || ext == ".csv") return CloudFormat::kXyz;
  return std::nullopt;
}

std::optional<Eigen::Vector3d> sensor_position(const ReadInfo& info) {
  if (!info.viewpoint.position.isZero(0)) return info.viewpoint.position;
  if (info.height > 1) return Eigen::Vector3d::Zero();
  return std::nullopt;
}

PointCloud read_point_cloud(const std::filesystem::path& path, ReadInfo* info) {
  const std::optional<CloudFormat> format = cloud_format(path);
  if (!format) detail::fail(path, unknown_format_problem(lower_extension(path)));

  // No size limit: the file is streamed (block_reader.hpp), so only the cloud grows with it.
  const auto file = detail::open_file(path, std::numeric_limits<std::uint64_t>::max());
  detail::BlockReader in(path, *file);
  ReadInfo read;
  PointCloud cloud;
  try {
    switch (*format) {
      case CloudFormat::kPly:
        cloud = detail::read_ply(in, read);
        break;
      case CloudFormat::kPcd:
        cloud = detail::read_pcd(in, read);
        break;
      case CloudFormat::kXyz:
        cloud = detail::read_xyz(in, read);
        break;
    }
  } catch (const std::bad_alloc&) {
    // Allocations that a count announces are reported where they are made (CloudBuilder); this
    // catches any other, e.g. a text file growing while it is read.
    detail::fail_out_of_memory(path,
                               "the points read up to byte offset " + std::to_string(in.offset()));
  }
  if (info != nullptr) *info = read;
  if (cloud.empty()) {
    const std::size_t dropped = read.dropped_non_finite;
    detail::fail(path, dropped == 0 ? std::string("contains no points")
                                    : "contains no points (all " + std::to_string(dropped) +
                                          " had a NaN or Inf coordinate)");
  }
  return cloud;
}

namespace {

// Sets `out` to the encoding named `name` in `table`; false if the table has no such name.
template <typename E, std::size_t kSize>
bool set_encoding(const std::pair<std::string_view, E> (&table)[kSize], std::string_view name,
                  E& out) {
  for (const auto& [key, value] : table) {
    if (key == name) {
      out = value;
      return true;
    }
  }
  return false;
}

}  // namespace

WriteSettings write_settings(CloudFormat format, const std::string& encoding) {
  static constexpr std::pair<std::string_view, PlyEncoding> kPly[] = {
      {"ascii", PlyEncoding::kAscii},
      {"binary", PlyEncoding::kBinaryLittleEndian},
      {"binary_little_endian", PlyEncoding::kBinaryLittleEndian},
      {"binary_big_endian", PlyEncoding::kBinaryBigEndian}};
  static constexpr std::pair<std::string_view, PcdEncoding> kPcd[] = {
      {"ascii", PcdEncoding::kAscii},
      {"binary", PcdEncoding::kBinary},
      {"binary_compressed", PcdEncoding::kBinaryCompressed}};
  WriteSettings settings;
  if (encoding.empty()) return settings;
  if (format == CloudFormat::kPly && !set_encoding(kPly, encoding, settings.ply)) {
    throw std::invalid_argument("PLY has no encoding '" + encoding +
                                "' (ascii, binary, binary_big_endian)");
  }
  if (format == CloudFormat::kPcd && !set_encoding(kPcd, encoding, settings.pcd)) {
    throw std::invalid_argument("PCD has no encoding '" + encoding +
                                "' (ascii, binary, binary_compressed)");
  }
  if (format == CloudFormat::kXyz) {
    throw std::invalid_argument(".xyz, .txt and .csv files are text and have no encoding");
  }
  return settings;
}

std::string_view encoding_name(CloudFormat format, const WriteSettings& s) {
  switch (format) {
    case CloudFormat::kPly:
      return s.ply == PlyEncoding::kAscii                ? "ascii"
             : s.ply == PlyEncoding::kBinaryLittleEndian ? "binary little-endian"
                                                         : "binary big-endian";
    case CloudFormat::kPcd:
      return s.pcd == PcdEncoding::kAscii    ? "ascii"
             : s.pcd == PcdEncoding::kBinary ? "binary"
                                             : "binary_compressed";
    case CloudFormat::kXyz:
      break;
  }
  return "text";
}

void write_point_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                       const WriteSettings& settings) {
  const std::optional<CloudFormat> format = cloud_format(path);
  if (!format) {
    throw OutputError(path, "cannot write: " + unknown_format_problem(lower_extension(path)));
  }
  switch (*format) {
    case CloudFormat::kPly:
      return write_ply(path, cloud, settings.ply);
    case CloudFormat::kPcd:
      return write_pcd(path, cloud, settings.pcd, settings.pcd_layout);
    case CloudFormat::kXyz:
      return write_xyz(path, cloud);
  }
}

}  // namespace align3d::io
