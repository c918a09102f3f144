// Private plumbing shared by the readers and writers in src/io (not installed): errors that start
// with the file name, locale-free number parsing, byte-order-aware loads and stores, the decoding
// of fixed-size binary records, and the builder that applies point_cloud_io.hpp's rules for
// non-finite points and normals. The input itself is streamed (block_reader.hpp).
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
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <system_error>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "align3d/io/point_cloud_io.hpp"
#include "align3d/point_cloud.hpp"
#include "block_reader.hpp"
#include "detail/number.hpp"

namespace align3d::io::detail {

// Real PLY/PCD headers are a few hundred bytes; a megabyte without an end marker is not a header.
inline constexpr std::size_t kMaxHeaderBytes = std::size_t{1} << 20;

// Throws IoError("<path>: <problem>").
[[noreturn]] void fail(const std::filesystem::path& path, const std::string& problem);

// Throws DataError("<path>: not enough memory for <what>"): the file is fine, this machine is too
// small for it (README, "Exit codes").
[[noreturn]] void fail_out_of_memory(const std::filesystem::path& path, const std::string& what);

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

// "line <number>: ", the start of an error message about one line of a text file.
inline std::string line_prefix(std::size_t number) {
  return "line " + std::to_string(number) + ": ";
}

// The extension of `path` in lower case (".PLY" gives ".ply"), by which a reader is chosen.
inline std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return ext;
}

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

inline bool is_blank(std::string_view line) {
  return std::all_of(line.begin(), line.end(), is_space);
}

enum class Token { kNumber, kEnd, kNotANumber };

// The next number on the line, parsed in place with the rules of detail/number.hpp: one pass over
// its characters instead of finding the token's end and then parsing it, which matters for
// multi-million-line files. A number must end at a separator or at the end of the line. On
// kNotANumber `pos` is left at the offending token, so that the caller can quote it (next_token).
template <typename IsSeparator>
Token next_number(std::string_view line, std::size_t& pos, IsSeparator is_separator,
                  double& value) {
  while (pos < line.size() && is_separator(line[pos])) ++pos;
  if (pos == line.size()) return Token::kEnd;
  const char* last = line.data() + line.size();
  const auto result =
      fast_float::from_chars(align3d::detail::skip_plus(line.data() + pos, last), last, value);
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

// The C++ type of each ScalarType, in the enum's order.
using ScalarTypes = std::tuple<std::int8_t, std::uint8_t, std::int16_t, std::uint16_t, std::int32_t,
                               std::uint32_t, std::int64_t, std::uint64_t, float, double>;

template <typename F, std::size_t... kIndex>
constexpr auto visit_scalar(ScalarType type, const F& f, std::index_sequence<kIndex...>) {
  decltype(f(std::int8_t{})) result{};
  static_cast<void>(((static_cast<std::size_t>(type) == kIndex &&
                      (result = f(std::tuple_element_t<kIndex, ScalarTypes>{}), true)) ||
                     ...));
  return result;
}

// f(T{}) with the C++ type T that `type` names (f returns the same type for all).
template <typename F>
constexpr auto visit_scalar(ScalarType type, const F& f) {
  return visit_scalar(type, f, std::make_index_sequence<std::tuple_size_v<ScalarTypes>>{});
}

// The value that `name` stands for in `table`, or nullopt.
template <typename T, std::size_t kSize>
std::optional<T> lookup(const std::pair<std::string_view, T> (&table)[kSize],
                        std::string_view name) {
  for (const auto& [key, value] : table) {
    if (key == name) return value;
  }
  return std::nullopt;
}

// The value that `word` stands for in `table`; IoError "<problem> '<word>'" if none.
template <typename T, std::size_t kSize>
T lookup_or_fail(const std::pair<std::string_view, T> (&table)[kSize], std::string_view word,
                 const std::filesystem::path& path, const std::string& problem) {
  const std::optional<T> value = lookup(table, word);
  if (!value) fail(path, problem + " " + quoted(word));
  return *value;
}

constexpr std::size_t scalar_size(ScalarType type) {
  return visit_scalar(type, [](auto t) { return sizeof(t); });
}

constexpr bool is_integer(ScalarType type) {
  return visit_scalar(type, [](auto t) { return std::is_integral_v<decltype(t)>; });
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
  return visit_scalar(type,
                      [p](auto t) { return static_cast<double>(load<decltype(t), kSwap>(p)); });
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
// are finite and non-zero, and then normalised. Running out of memory is fail_out_of_memory.
class CloudBuilder {
 public:
  CloudBuilder(const std::filesystem::path& path, bool with_normals)
      : path_(path), normals_ok_(with_normals) {}

  // Only call with a count already checked against the bytes the file holds.
  void reserve(std::size_t count);

  // Also records the file index of every kept point (ReadInfo::indices: an organized cloud's
  // pixels). Call before adding points.
  void keep_indices() { keep_indices_ = true; }

  void add(double x, double y, double z) {
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
      ++dropped_;
      return;
    }
    keep_index(positions_.size() + dropped_);
    positions_.emplace_back(x, y, z);
  }

  void add(double x, double y, double z, double nx, double ny, double nz) {
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
      ++dropped_;
      return;
    }
    keep_index(positions_.size() + dropped_);
    positions_.emplace_back(x, y, z);
    if (normals_ok_) keep_normal(Eigen::Vector3d(nx, ny, nz), normals_.size());
  }

  // Column-major input (PCD binary_compressed): allocate(count) makes points 0 .. count - 1
  // settable in any order, component 0-2 the position, 3-5 the normal; finish() then applies the
  // rules above in place. Only call with a count already checked against the file.
  void allocate(std::size_t count);
  void set(std::size_t point, std::size_t component, double value) {
    auto& v = component < 3 ? positions_[point] : normals_[point];
    v[static_cast<Eigen::Index>(component % 3)] = value;
  }

  std::size_t dropped() const { return dropped_; }
  PointCloud finish();
  // After finish(): the file index of each kept point, if keep_indices() was called.
  std::vector<std::uint32_t> take_indices() { return std::move(indices_); }

 private:
  void keep_index(std::size_t file_index) {
    if (keep_indices_) indices_.push_back(static_cast<std::uint32_t>(file_index));
  }

  // A zero normal is how many tools write "unknown"; it cannot be made a unit vector. Others are
  // scaled by their largest component first, so that tiny (even subnormal) or huge components
  // still normalise to a unit vector: their squared norm would underflow or overflow.
  void keep_normal(const Eigen::Vector3d& n, std::size_t index) {
    const double largest = n.cwiseAbs().maxCoeff();
    if (n.allFinite() && largest > 0.0) {
      if (index == normals_.size()) {
        normals_.push_back(n / largest);
      } else {
        normals_[index] = n / largest;
      }
    } else {
      normals_ok_ = false;
      normals_ = {};
    }
  }

  const std::filesystem::path& path_;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Eigen::Vector3d> normals_;
  bool normals_ok_;
  bool columns_ = false;  // filled by allocate() and set()
  std::size_t dropped_ = 0;
  bool keep_indices_ = false;
  std::vector<std::uint32_t> indices_;
};

// Where a record's fields of interest lie: the six components x y z nx ny nz (the last three only
// with normals).
struct RecordField {
  std::size_t offset = 0;  // within the record
  ScalarType type = ScalarType::kFloat32;
};
struct RecordLayout {
  std::size_t stride = 0;  // record size, > 0
  std::array<RecordField, 6> fields{};
  bool normals = false;
};

// Decodes `count` packed records of a fixed size from `in` into the builder: the binary PLY vertex
// element without lists, and binary PCD. The count must have been checked against in.remaining(); a
// file that still ends early (it shrank while being read) is an IoError naming `what` and the byte
// offset. Records that fit the buffer are decoded straight from it, many at a time (the per-value
// type switch is well predicted: the same types repeat in every record); a larger one (a PCD field
// with a huge COUNT) is walked field by field.
template <bool kSwap>
void decode_records(BlockReader& in, std::uint64_t count, const RecordLayout& layout,
                    CloudBuilder& builder, const std::string& what) {
  const std::size_t stride = layout.stride;
  const std::size_t components = layout.normals ? 6 : 3;
  std::array<double, 6> v{};
  const auto emit = [&] {
    if (layout.normals) {
      builder.add(v[0], v[1], v[2], v[3], v[4], v[5]);
    } else {
      builder.add(v[0], v[1], v[2]);
    }
  };
  const auto truncated = [&] {
    fail(in.path(),
         "truncated data at byte offset " + std::to_string(in.offset()) + " (" + what + ")");
  };
  if (stride <= in.capacity()) {
    for (std::uint64_t r = 0; r < count;) {
      const std::string_view data = in.peek(stride);
      if (data.size() < stride) truncated();
      const auto n =
          static_cast<std::size_t>(std::min<std::uint64_t>(count - r, data.size() / stride));
      for (std::size_t i = 0; i < n; ++i) {
        const char* record = data.data() + i * stride;
        for (std::size_t k = 0; k < components; ++k) {
          v[k] = load_scalar<kSwap>(record + layout.fields[k].offset, layout.fields[k].type);
        }
        emit();
      }
      in.consume(n * stride);
      r += n;
    }
    return;
  }
  // Fields in file order, to walk each record front to back.
  std::array<std::size_t, 6> order{0, 1, 2, 3, 4, 5};
  std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(components),
            [&](std::size_t a, std::size_t b) {
              return layout.fields[a].offset < layout.fields[b].offset;
            });
  for (std::uint64_t r = 0; r < count; ++r) {
    std::size_t at = 0;  // within the record
    for (std::size_t j = 0; j < components; ++j) {
      const RecordField& field = layout.fields[order[j]];
      const std::size_t size = scalar_size(field.type);
      if (in.skip(field.offset - at) < field.offset - at) truncated();
      const std::string_view data = in.peek(size);
      if (data.size() < size) truncated();
      v[order[j]] = load_scalar<kSwap>(data.data(), field.type);
      in.consume(size);
      at = field.offset + size;
    }
    if (in.skip(stride - at) < stride - at) truncated();
    emit();
  }
}

// The format readers, from the file's first byte: they fill `info` and return the points (an empty
// result is not an error here).
PointCloud read_ply(BlockReader& in, ReadInfo& info);
PointCloud read_pcd(BlockReader& in, ReadInfo& info);
PointCloud read_xyz(BlockReader& in, ReadInfo& info);

// The matrix reader (matrix_io.hpp), from the file's first byte.
Eigen::Isometry3d parse_matrix(BlockReader& in);

}  // namespace align3d::io::detail
