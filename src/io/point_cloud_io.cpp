#include "align3d/io/point_cloud_io.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <new>

#include "align3d/error.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace detail {

void fail(const std::filesystem::path& path, const std::string& problem) {
  throw IoError(path.string() + ": " + problem);
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

FileBytes read_file(const std::filesystem::path& path, std::uint64_t max_bytes) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) fail(path, "file not found");
  if (ec) fail(path, "cannot access: " + ec.message());
  if (!std::filesystem::is_regular_file(status)) fail(path, "not a regular file");
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) fail(path, "cannot determine the file size: " + ec.message());
  if (size == 0) fail(path, "file is empty");
  if (size > max_bytes) {
    fail(path, "file is too large (" + std::to_string(size) + " bytes, limit " +
                   std::to_string(max_bytes) + ")");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::unique_ptr<char[]> data;
  try {
    // for_overwrite: zero-filling a buffer that the read overwrites at once would touch every page
    // twice.
    data = std::make_unique_for_overwrite<char[]>(static_cast<std::size_t>(size));
  } catch (const std::bad_alloc&) {
    fail(path, "not enough memory to load " + std::to_string(size) + " bytes");
  }
  in.read(data.get(), static_cast<std::streamsize>(size));
  const auto got = static_cast<std::uint64_t>(in.gcount());
  if (got != size) {
    fail(path, "read error: got " + std::to_string(got) + " of " + std::to_string(size) +
                   " bytes (file changed while reading?)");
  }
  return FileBytes(std::move(data), static_cast<std::size_t>(size));
}

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t pos = 0;
  for (;;) {
    const auto word = next_token(line, pos, kSpace);
    if (word.empty()) return words;
    words.push_back(word);
  }
}

}  // namespace detail

namespace {

enum class Format { kPly, kPcd, kXyz, kUnknown };

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return ext;
}

Format format_of(const std::string& ext) {
  if (ext == ".ply") return Format::kPly;
  if (ext == ".pcd") return Format::kPcd;
  if (ext == ".xyz" || ext == ".txt" || ext == ".csv") return Format::kXyz;
  return Format::kUnknown;
}

std::string unknown_format_problem(const std::string& ext) {
  return "unknown point cloud format " +
         (ext.empty() ? std::string("(no extension)") : "'" + ext + "'") +
         " (expected .ply, .pcd, .xyz, .txt or .csv)";
}

}  // namespace

PointCloud read_point_cloud(const std::filesystem::path& path, ReadInfo* info) {
  const std::string ext = lower_extension(path);
  const Format format = format_of(ext);
  if (format == Format::kUnknown) detail::fail(path, unknown_format_problem(ext));

  const auto file = detail::read_file(path, detail::kMaxFileBytes);
  std::size_t dropped = 0;
  PointCloud cloud;
  switch (format) {
    case Format::kPly:
      cloud = detail::read_ply(path, file.view(), dropped);
      break;
    case Format::kPcd:
      cloud = detail::read_pcd(path, file.view(), dropped);
      break;
    case Format::kXyz:
    case Format::kUnknown:  // rejected above
      cloud = detail::read_xyz(path, file.view(), dropped);
      break;
  }
  if (info != nullptr) info->dropped_non_finite = dropped;
  if (cloud.empty()) {
    detail::fail(path, dropped == 0 ? std::string("contains no points")
                                    : "contains no points (all " + std::to_string(dropped) +
                                          " had a NaN or Inf coordinate)");
  }
  return cloud;
}

void write_point_cloud(const std::filesystem::path& path, const PointCloud& cloud) {
  const std::string ext = lower_extension(path);
  switch (format_of(ext)) {
    case Format::kPly:
      return write_ply(path, cloud, PlyEncoding::kBinaryLittleEndian);
    case Format::kPcd:
      return write_pcd(path, cloud, PcdEncoding::kBinary);
    case Format::kXyz:
      return write_xyz(path, cloud);
    case Format::kUnknown:
      break;
  }
  throw OutputError(path.string() + ": cannot write: " + unknown_format_problem(ext));
}

}  // namespace align3d::io
