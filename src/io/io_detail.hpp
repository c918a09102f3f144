// Private plumbing shared by the readers and writers in src/io (not installed): whole-file loading,
// errors that start with the file name, locale-free number parsing, byte-order-aware loads and
// stores, and the builder that applies point_cloud_io.hpp's rules for non-finite points and
// normals.
#pragma once

#include <fast_float/fast_float.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <ostream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d::io::detail {

// Files are loaded with one bulk read and parsed from memory with pointers (no per-value stream
// calls), and the size known up front bounds every count a header announces before anything is
// allocated.
inline constexpr std::uint64_t kMaxFileBytes = std::uint64_t{16} << 30;
// Real PLY/PCD headers are a few hundred bytes; a megabyte without an end marker is not a header.
inline constexpr std::size_t kMaxHeaderBytes = std::size_t{1} << 20;

// Throws IoError("<path>: <problem>").
[[noreturn]] void fail(const std::filesystem::path& path, const std::string& problem);

// A data line of a PLY or PCD ascii body longer than this is refused (PCL's largest descriptors
// take a few tens of kB as text), so that a binary body under an ascii header, or a missing
// newline, gives a short error instead of a scan of the whole file for one record.
inline constexpr std::size_t kMaxRecordLineBytes = std::size_t{1} << 20;

// Throws unless line `number` fits in `limit` bytes.
void check_line_length(const std::filesystem::path& path, std::string_view line, std::size_t number,
                       std::size_t limit);

// A token quoted for an error message: truncated, control bytes replaced, so that a binary file
// misread as text cannot garble the message.
std::string quoted(std::string_view token);

class FileBytes {
 public:
  FileBytes(std::unique_ptr<char[]> data, std::size_t size) : data_(std::move(data)), size_(size) {}
  std::string_view view() const { return {data_.get(), size_}; }

 private:
  std::unique_ptr<char[]> data_;
  std::size_t size_;
};

// The whole file; IoError if it is missing, not a regular file, unreadable, empty or larger than
// max_bytes.
FileBytes read_file(const std::filesystem::path& path, std::uint64_t max_bytes);

// Iterates over the lines of a buffer. A line ends at '\n'; a '\r' before it is dropped so that
// files written on Windows parse the same.
class LineCursor {
 public:
  LineCursor(const char* begin, const char* end, std::size_t first_line_number = 1)
      : pos_(begin), end_(end), next_number_(first_line_number) {}

  // False at the end of the buffer; otherwise `line` is the next line without its terminator.
  bool next(std::string_view& line) {
    if (pos_ == end_) return false;
    const auto* newline = static_cast<const char*>(std::memchr(pos_, '\n', end_ - pos_));
    const char* stop = newline != nullptr ? newline : end_;
    const char* text_end = (stop != pos_ && stop[-1] == '\r') ? stop - 1 : stop;
    line = std::string_view(pos_, text_end - pos_);
    pos_ = newline != nullptr ? newline + 1 : end_;
    number_ = next_number_++;
    return true;
  }
  std::size_t number() const { return number_; }  // 1-based number of the line last returned
  const char* position() const { return pos_; }   // start of the next line
  const char* end() const { return end_; }

 private:
  const char* pos_;
  const char* end_;
  std::size_t next_number_;
  std::size_t number_ = 0;
};

inline bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

// Separator predicates are passed to next_token as function objects, which inline; with a function
// pointer, the indirect call per character made next_token and is_space a third of the ascii parse
// time in a profile.
inline constexpr auto kSpace = [](char c) { return is_space(c); };

// The next run of characters that are not separators, starting the search at `pos` (updated to
// just past the token); empty at the end of the line.
template <typename IsSeparator>
std::string_view next_token(std::string_view line, std::size_t& pos, IsSeparator is_separator) {
  while (pos < line.size() && is_separator(line[pos])) ++pos;
  const std::size_t begin = pos;
  while (pos < line.size() && !is_separator(line[pos])) ++pos;
  return line.substr(begin, pos - begin);
}

std::vector<std::string_view> split_words(std::string_view line);  // on is_space

// Numbers are parsed with fast_float: locale-independent, correctly rounded, and it reads "nan" and
// "inf" (so such points can be counted and dropped). A leading '+', which it rejects like
// std::from_chars by design, is skipped because some exporters write one.
inline const char* skip_plus(const char* first, const char* last) {
  return (last - first > 1 && first[0] == '+' && first[1] != '-') ? first + 1 : first;
}

// Parses a whole token.
inline bool parse_double(std::string_view token, double& value) {
  const char* last = token.data() + token.size();
  const auto result = fast_float::from_chars(skip_plus(token.data(), last), last, value);
  return result.ec == std::errc() && result.ptr == last;
}

enum class Token { kNumber, kEnd, kNotANumber };

// The next number on the line, parsed in place: one pass over its characters instead of finding
// the token's end and then parsing it, which matters for multi-million-line files. A number must
// end at a separator or at the end of the line. On kNotANumber `pos` is left at the offending
// token, so that the caller can quote it (next_token).
template <typename IsSeparator>
Token next_number(std::string_view line, std::size_t& pos, IsSeparator is_separator,
                  double& value) {
  while (pos < line.size() && is_separator(line[pos])) ++pos;
  if (pos == line.size()) return Token::kEnd;
  const char* last = line.data() + line.size();
  const auto result = fast_float::from_chars(skip_plus(line.data() + pos, last), last, value);
  if (result.ec != std::errc() || (result.ptr != last && !is_separator(*result.ptr))) {
    return Token::kNotANumber;
  }
  pos = static_cast<std::size_t>(result.ptr - line.data());
  return Token::kNumber;
}

// Header counts and sizes: non-negative decimal integers. fast_float parses only floating point,
// so integers go through std::from_chars, which is locale-independent too.
inline bool parse_u64(std::string_view token, std::uint64_t& value) {
  const char* last = token.data() + token.size();
  const auto result = std::from_chars(token.data(), last, value);
  return !token.empty() && result.ec == std::errc() && result.ptr == last;
}

enum class ScalarType : std::uint8_t {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat32,
  kFloat64,
};

constexpr std::size_t scalar_size(ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
    case ScalarType::kUint8:
      return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16:
      return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32:
      return 4;
    case ScalarType::kInt64:
    case ScalarType::kUint64:
    case ScalarType::kFloat64:
      return 8;
  }
  return 0;
}

constexpr bool is_integer(ScalarType type) {
  return type != ScalarType::kFloat32 && type != ScalarType::kFloat64;
}

inline constexpr bool kHostIsBigEndian = std::endian::native == std::endian::big;

// memcpy keeps the load legal at any alignment (records are packed); the compiler turns it and the
// reversal into a plain (byte-swapping) load.
template <typename T, bool kSwap>
T load(const char* p) {
  std::array<char, sizeof(T)> bytes;
  std::memcpy(bytes.data(), p, sizeof(T));
  if constexpr (kSwap) std::reverse(bytes.begin(), bytes.end());
  return std::bit_cast<T>(bytes);
}

template <bool kSwap>
double load_scalar(const char* p, ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
      return load<std::int8_t, kSwap>(p);
    case ScalarType::kUint8:
      return load<std::uint8_t, kSwap>(p);
    case ScalarType::kInt16:
      return load<std::int16_t, kSwap>(p);
    case ScalarType::kUint16:
      return load<std::uint16_t, kSwap>(p);
    case ScalarType::kInt32:
      return load<std::int32_t, kSwap>(p);
    case ScalarType::kUint32:
      return load<std::uint32_t, kSwap>(p);
    case ScalarType::kInt64:
      return static_cast<double>(load<std::int64_t, kSwap>(p));
    case ScalarType::kUint64:
      return static_cast<double>(load<std::uint64_t, kSwap>(p));
    case ScalarType::kFloat32:
      return load<float, kSwap>(p);
    case ScalarType::kFloat64:
      return load<double, kSwap>(p);
  }
  return 0.0;
}

// double -> float without the undefined behaviour of casting an out-of-range value (IEEE would give
// +-inf, which is what this returns).
inline float to_float(double value) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (value > kMax) return std::numeric_limits<float>::infinity();
  if (value < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(value);
}

// The value a float32 property holds when it was written as text: rounding text to float makes an
// ascii file read exactly like the binary file of the same cloud.
inline double as_stored(double value, ScalarType type) {
  return type == ScalarType::kFloat32 ? static_cast<double>(to_float(value)) : value;
}

template <typename T>
void append_bytes(std::string& out, T value, bool swap) {
  auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
  if (swap) std::reverse(bytes.begin(), bytes.end());
  out.append(bytes.data(), bytes.size());
}

// Shortest text that reads back to the same float (std::to_chars: locale-independent, unlike
// printf, whose decimal point follows LC_NUMERIC).
inline void append_shortest(std::string& out, float value) {
  std::array<char, 32> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), result.ptr);
}

// Equivalent to printf("%.<precision>g"), without the locale.
inline void append_general(std::string& out, double value, int precision) {
  std::array<char, 40> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                                    std::chars_format::general, precision);
  out.append(buffer.data(), result.ptr);
}

// Writers fill a buffer and hand it to the stream in ~1 MiB pieces: one stream call per piece
// rather than per value, and memory bounded independently of the cloud's size.
class ChunkedOutput {
 public:
  explicit ChunkedOutput(std::ostream& out) : out_(out) { buffer_.reserve(kChunk + 4096); }
  ChunkedOutput(const ChunkedOutput&) = delete;
  ChunkedOutput& operator=(const ChunkedOutput&) = delete;

  std::string& buffer() { return buffer_; }
  void maybe_flush() {
    if (buffer_.size() >= kChunk) flush();
  }
  void flush() {
    out_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

 private:
  static constexpr std::size_t kChunk = std::size_t{1} << 20;
  std::ostream& out_;
  std::string buffer_;
};

// Collects points while parsing, applying the reader contract of point_cloud_io.hpp: a point with a
// non-finite coordinate is dropped and counted; the normals of the kept points are kept only if all
// are finite and non-zero, and then normalised.
class CloudBuilder {
 public:
  explicit CloudBuilder(bool with_normals) : normals_ok_(with_normals) {}

  // Only call with a count already checked against the bytes the file holds.
  void reserve(std::size_t count) {
    positions_.reserve(count);
    if (normals_ok_) normals_.reserve(count);
  }

  void add(double x, double y, double z) {
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
      ++dropped_;
      return;
    }
    positions_.emplace_back(x, y, z);
  }

  void add(double x, double y, double z, double nx, double ny, double nz) {
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
      ++dropped_;
      return;
    }
    positions_.emplace_back(x, y, z);
    if (!normals_ok_) return;
    const Eigen::Vector3d n(nx, ny, nz);
    // A zero normal is how many tools write "unknown"; it cannot be made a unit vector. Others are
    // scaled by their largest component first, so that tiny (even subnormal) or huge components
    // still normalise to a unit vector: their squared norm would underflow or overflow.
    const double largest = n.cwiseAbs().maxCoeff();
    if (n.allFinite() && largest > 0.0) {
      normals_.push_back(n / largest);
    } else {
      normals_ok_ = false;
      normals_ = {};
    }
  }

  PointCloud finish(std::size_t& dropped) {
    PointCloud cloud;
    cloud.positions = std::move(positions_);
    if (normals_ok_) {
      for (auto& n : normals_) n.normalize();
      cloud.normals = std::move(normals_);
    }
    dropped = dropped_;
    return cloud;
  }

 private:
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Eigen::Vector3d> normals_;
  bool normals_ok_;
  std::size_t dropped_ = 0;
};

// The format readers, given the whole (non-empty) file; `dropped` receives the number of points
// dropped for a non-finite coordinate. An empty result is not an error here.
PointCloud read_ply(const std::filesystem::path& path, std::string_view data, std::size_t& dropped);
PointCloud read_pcd(const std::filesystem::path& path, std::string_view data, std::size_t& dropped);
PointCloud read_xyz(const std::filesystem::path& path, std::string_view data, std::size_t& dropped);

// The matrix reader (matrix_io.hpp) given the whole file's bytes.
Eigen::Isometry3d parse_matrix(const std::filesystem::path& path, std::string_view data);

}  // namespace align3d::io::detail
