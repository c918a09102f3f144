// PCD, the Point Cloud Library's format (pointclouds.org, "The PCD (Point Cloud Data) file format",
// v0.7; older headers omit COUNT, spell FIELDS as COLUMNS, or give only WIDTH): a text header, then
// the points as text lines, packed little-endian records (binary), or LZF-compressed columns
// (binary_compressed).
#include <lzf.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io_detail.hpp"
#include "lzf_stream.hpp"

namespace align3d::io {
namespace {

using detail::CloudBuilder;
using detail::fail;
using detail::ScalarType;

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

struct PcdField {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  std::size_t count = 1;   // values per point
  std::size_t offset = 0;  // byte offset within a binary record
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width = 0, height = 1;  // points = width * height
  std::uint64_t points = 0;
  Viewpoint viewpoint;
  std::size_t point_bytes = 0;   // binary record size
  std::size_t point_values = 0;  // values per ascii line
  PcdData data = PcdData::kAscii;
  std::size_t line_count = 0;  // header lines; ascii data starts on the next
};

// Far above any real COUNT (PCL's largest descriptors have a few hundred values); it keeps the size
// arithmetic far from overflow, as the 1 MiB header bounds the number of fields.
constexpr std::uint64_t kMaxFieldCount = std::uint64_t{1} << 24;

bool to_scalar_type(char type, std::uint64_t size, ScalarType& out) {
  struct Entry {
    char type;
    std::uint64_t size;
    ScalarType scalar;
  };
  static constexpr Entry kTypes[] = {
      {'F', 4, ScalarType::kFloat32}, {'F', 8, ScalarType::kFloat64}, {'I', 1, ScalarType::kInt8},
      {'I', 2, ScalarType::kInt16},   {'I', 4, ScalarType::kInt32},   {'I', 8, ScalarType::kInt64},
      {'U', 1, ScalarType::kUint8},   {'U', 2, ScalarType::kUint16},  {'U', 4, ScalarType::kUint32},
      {'U', 8, ScalarType::kUint64},
  };
  for (const Entry& entry : kTypes) {
    if (entry.type == type && entry.size == size) {
      out = entry.scalar;
      return true;
    }
  }
  return false;
}

std::uint64_t single_count(const std::filesystem::path& path, const std::string& where,
                           const std::vector<std::string_view>& words) {
  std::uint64_t value = 0;
  if (words.size() != 2 || !detail::parse_u64(words[1], value)) {
    fail(path, where + "expected '" + std::string(words[0]) + " <non-negative integer>'");
  }
  return value;
}

// "VIEWPOINT tx ty tz qw qx qy qz": the sensor's position and orientation (normalised here).
Viewpoint parse_viewpoint(const std::filesystem::path& path, const std::string& where,
                          const std::vector<std::string_view>& words) {
  std::array<double, 7> v{};
  bool ok = words.size() == 8;
  for (std::size_t i = 0; ok && i < 7; ++i) {
    const auto value = align3d::detail::parse_finite(words[i + 1]);
    ok = value.has_value();
    if (ok) v[i] = *value;
  }
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
  if (!ok || !(q.coeffs().cwiseAbs().maxCoeff() > 0)) {
    fail(path, where +
                   "expected 'VIEWPOINT tx ty tz qw qx qy qz' (7 finite numbers, a non-zero "
                   "quaternion)");
  }
  // Scaled by the largest component first, like the normals: a tiny quaternion still normalises.
  return {Eigen::Vector3d(v[0], v[1], v[2]),
          Eigen::Quaterniond(q.coeffs() / q.coeffs().cwiseAbs().maxCoeff()).normalized()};
}

// The header's lines as read; checked against each other in make_header.
struct HeaderText {
  std::vector<std::string> names, sizes, types, counts;
  std::optional<std::uint64_t> width, height, points;
  Viewpoint viewpoint;
  // Where each keyword was seen, for the errors found once the whole header is known.
  std::size_t sizes_line = 0, types_line = 0, counts_line = 0, points_line = 0, height_line = 0;
  PcdData data = PcdData::kAscii;
  std::size_t line_count = 0;
};

constexpr std::pair<std::string_view, PcdData> kPcdData[] = {
    {"ascii", PcdData::kAscii},
    {"binary", PcdData::kBinary},
    {"binary_compressed", PcdData::kBinaryCompressed}};

HeaderText read_header_text(detail::LineReader& lines) {
  const std::filesystem::path& path = lines.input().path();
  detail::HeaderLines header_lines(lines, "a DATA line");
  HeaderText text;
  for (;;) {
    const auto& words = header_lines.next();
    if (words.empty() || words[0].front() == '#') continue;
    const std::string where = header_lines.where();
    const std::string_view keyword = words[0];
    const std::vector<std::string> rest(words.begin() + 1, words.end());
    if (keyword == "VERSION") {
    } else if (keyword == "VIEWPOINT") {
      text.viewpoint = parse_viewpoint(path, where, words);
    } else if (keyword == "FIELDS" || keyword == "COLUMNS") {
      text.names = rest;
    } else if (keyword == "SIZE") {
      text.sizes = rest;
      text.sizes_line = header_lines.number();
    } else if (keyword == "TYPE") {
      text.types = rest;
      text.types_line = header_lines.number();
    } else if (keyword == "COUNT") {
      text.counts = rest;
      text.counts_line = header_lines.number();
    } else if (keyword == "WIDTH") {
      text.width = single_count(path, where, words);
    } else if (keyword == "HEIGHT") {
      text.height = single_count(path, where, words);
      text.height_line = header_lines.number();
    } else if (keyword == "POINTS") {
      text.points = single_count(path, where, words);
      text.points_line = header_lines.number();
    } else if (keyword == "DATA") {
      if (words.size() != 2) fail(path, where + "expected 'DATA ascii|binary|binary_compressed'");
      text.data = detail::lookup_or_fail(kPcdData, words[1], path, where + "unknown DATA encoding");
      text.line_count = header_lines.number();
      return text;
    } else {
      fail(path,
           where + "unknown header keyword " + detail::quoted(keyword) + " (not a PCD file?)");
    }
  }
}

std::string at_line(std::size_t line) {
  return line == 0 ? std::string() : "line " + std::to_string(line) + ": ";
}

// The fields with their types and offsets, from FIELDS, SIZE, TYPE and COUNT.
void make_fields(const std::filesystem::path& path, const HeaderText& text, PcdHeader& header) {
  if (text.names.empty()) fail(path, "header has no FIELDS line");
  const auto check_entries = [&](const std::vector<std::string>& list, const char* what,
                                 std::size_t line) {
    if (list.size() != text.names.size()) {
      fail(path, at_line(line) + what + " has " + std::to_string(list.size()) +
                     " entries but FIELDS has " + std::to_string(text.names.size()));
    }
  };
  check_entries(text.sizes, "SIZE", text.sizes_line);
  check_entries(text.types, "TYPE", text.types_line);
  if (!text.counts.empty()) check_entries(text.counts, "COUNT", text.counts_line);

  for (std::size_t i = 0; i < text.names.size(); ++i) {
    PcdField field;
    field.name = text.names[i];
    std::uint64_t size = 0;
    std::uint64_t count = 1;
    if (!detail::parse_u64(text.sizes[i], size)) {
      fail(path, at_line(text.sizes_line) + "bad SIZE " + detail::quoted(text.sizes[i]) +
                     " for field '" + field.name + "'");
    }
    if (text.types[i].size() != 1 || !to_scalar_type(text.types[i][0], size, field.type)) {
      fail(path, at_line(text.types_line) + "unsupported TYPE " + detail::quoted(text.types[i]) +
                     " with SIZE " + text.sizes[i] + " for field '" + field.name + "'");
    }
    if (!text.counts.empty() &&
        (!detail::parse_u64(text.counts[i], count) || count == 0 || count > kMaxFieldCount)) {
      fail(path, at_line(text.counts_line) + "bad COUNT " + detail::quoted(text.counts[i]) +
                     " for field '" + field.name + "'");
    }
    field.count = static_cast<std::size_t>(count);
    field.offset = header.point_bytes;
    header.point_bytes += static_cast<std::size_t>(size) * field.count;
    header.point_values += field.count;
    header.fields.push_back(std::move(field));
  }
}

PcdHeader parse_pcd_header(detail::LineReader& lines) {
  const std::filesystem::path& path = lines.input().path();
  const HeaderText text = read_header_text(lines);
  PcdHeader header;
  header.data = text.data;
  header.line_count = text.line_count;
  header.viewpoint = text.viewpoint;
  make_fields(path, text, header);
  if (text.width) {
    const std::uint64_t h = text.height.value_or(1);
    if (h != 0 && *text.width > std::numeric_limits<std::uint64_t>::max() / h) {
      fail(path, at_line(text.height_line) + "WIDTH * HEIGHT overflows");
    }
    if (text.points && *text.points != *text.width * h) {
      fail(path, at_line(text.points_line) + "POINTS " + std::to_string(*text.points) +
                     " does not equal WIDTH * HEIGHT = " + std::to_string(*text.width) + " * " +
                     std::to_string(h));
    }
    header.width = *text.width;
    header.height = h;
  } else if (text.points) {
    header.width = *text.points;  // an old header: unorganized
  } else {
    fail(path, "header has neither POINTS nor WIDTH");
  }
  header.points = header.width * header.height;
  return header;
}

// PCL writes host byte order, i.e. little-endian on every platform it is used on.
constexpr bool kSwap = detail::kHostIsBigEndian;

// Indices into header.fields of x y z and, when `normals`, normal_x/y/z.
struct FieldIndex {
  std::array<std::size_t, 6> index{};
  bool normals = false;
};

void read_ascii(detail::LineReader& lines, const PcdHeader& header, const FieldIndex& layout,
                CloudBuilder& builder) {
  const std::filesystem::path& path = lines.input().path();
  // Every value takes at least a character and a separator (+ 1: the last line may lack its '\n').
  const std::uint64_t left = lines.input().remaining();
  const std::size_t min_bytes = 2 * header.point_values;
  if (header.points > (left + 1) / min_bytes) {
    fail(path, "header announces " + std::to_string(header.points) + " points, but the " +
                   std::to_string(left) + " bytes after line " + std::to_string(header.line_count) +
                   " can hold at most " + std::to_string((left + 1) / min_bytes) +
                   " (truncated file?)");
  }
  // The per-line buffer below has point_values entries, which only the bound above (a file holding
  // at least one point) ties to the file's size: with no point announced, COUNTs of 2^24 would
  // allocate gigabytes for nothing.
  if (header.points == 0) return;
  builder.reserve(static_cast<std::size_t>(header.points));
  // Value position on the line of each field's first value.
  std::vector<std::size_t> first_value(header.fields.size());
  for (std::size_t f = 1; f < header.fields.size(); ++f) {
    first_value[f] = first_value[f - 1] + header.fields[f - 1].count;
  }
  std::array<std::size_t, 6> column{};
  for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) {
    column[k] = first_value[layout.index[k]];
  }

  std::vector<double> values(header.point_values);
  std::string_view line;
  for (std::uint64_t i = 0; i < header.points; ++i) {
    do {
      if (!lines.next(line, detail::kMaxRecordLineBytes)) {
        fail(path, "truncated data: the header announces " + std::to_string(header.points) +
                       " points, the file ends after " + std::to_string(i) + " (line " +
                       std::to_string(lines.number()) + ")");
      }
    } while (detail::is_blank(line));
    detail::check_line_length(path, line, lines.number(), detail::kMaxRecordLineBytes);
    // Built only on error: one string per point would dominate the parse time.
    const auto where = [&] { return "line " + std::to_string(lines.number()) + ": "; };
    std::size_t pos = 0;
    for (std::size_t v = 0; v < values.size(); ++v) {
      const auto token = detail::next_number(line, pos, detail::kSpace, values[v]);
      if (token == detail::Token::kEnd) {
        fail(path, where() + "too few values (expected " + std::to_string(values.size()) + ")");
      }
      if (token == detail::Token::kNotANumber) {
        fail(path, where() + "bad number " +
                       detail::quoted(detail::next_token(line, pos, detail::kSpace)));
      }
    }
    if (!detail::next_token(line, pos, detail::kSpace).empty()) {
      fail(path, where() + "too many values (expected " + std::to_string(values.size()) + ")");
    }
    const auto val = [&](std::size_t k) {
      return detail::as_stored(values[column[k]], header.fields[layout.index[k]].type);
    };
    if (layout.normals) {
      builder.add(val(0), val(1), val(2), val(3), val(4), val(5));
    } else {
      builder.add(val(0), val(1), val(2));
    }
  }
}

void read_binary(detail::BlockReader& in, const PcdHeader& header, const FieldIndex& layout,
                 CloudBuilder& builder) {
  const std::uint64_t left = in.remaining();
  if (header.points > left / header.point_bytes) {
    fail(in.path(), "header announces " + std::to_string(header.points) + " points of " +
                        std::to_string(header.point_bytes) + " bytes at byte offset " +
                        std::to_string(in.offset()) + ", but only " + std::to_string(left) +
                        " bytes remain (truncated file?)");
  }
  builder.reserve(static_cast<std::size_t>(header.points));
  detail::RecordLayout records{header.point_bytes, {}, layout.normals};
  for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) {
    const PcdField& field = header.fields[layout.index[k]];
    records.fields[k] = {field.offset, field.type};
  }
  detail::decode_records<kSwap>(in, header.points, records, builder, "binary data");
}

// binary_compressed: uint32 compressed size, uint32 uncompressed size, then one LZF stream that
// expands to the fields one after another, each holding all points' values (PCL's
// pcl::io::PCDReader::readBodyBinary). Decoded as a stream, each column straight into the cloud.
void read_compressed(detail::BlockReader& in, const PcdHeader& header, const FieldIndex& layout,
                     CloudBuilder& builder) {
  const std::filesystem::path& path = in.path();
  const std::uint64_t left = in.remaining();
  const std::string at = " at byte offset " + std::to_string(in.offset());
  const std::string_view sizes = in.peek(8);
  if (left < 8 || sizes.size() < 8) {
    fail(path, "binary_compressed data shorter than its 8-byte size header" + at);
  }
  const auto compressed = detail::load<std::uint32_t, kSwap>(sizes.data());
  const auto uncompressed = detail::load<std::uint32_t, kSwap>(sizes.data() + 4);
  in.consume(8);
  if (compressed > left - 8) {
    fail(path, "compressed size " + std::to_string(compressed) + at + " exceeds the " +
                   std::to_string(left - 8) + " bytes remaining (truncated file?)");
  }
  if (header.points > std::numeric_limits<std::uint64_t>::max() / header.point_bytes ||
      uncompressed != header.points * header.point_bytes) {
    fail(path, "uncompressed size " + std::to_string(uncompressed) + at +
                   " does not match POINTS * point size = " + std::to_string(header.points) +
                   " * " + std::to_string(header.point_bytes));
  }
  // The longest LZF back-reference, 3 bytes, expands to 264: no valid stream inflates by more than
  // 88 times, so a larger claim is a lie, caught before the points are allocated.
  if (uncompressed > std::uint64_t{88} * compressed) {
    fail(path, "uncompressed size " + std::to_string(uncompressed) + at + " is impossible for " +
                   std::to_string(compressed) + " bytes of LZF data");
  }
  builder.allocate(static_cast<std::size_t>(header.points));
  // The columns of the components, in stream order: field f's column starts at points * offset.
  struct Column {
    std::uint64_t begin, end;
    std::size_t component, size;
    ScalarType type;
  };
  std::vector<Column> columns;
  for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) {
    const PcdField& field = header.fields[layout.index[k]];
    const std::size_t size = detail::scalar_size(field.type);
    const std::uint64_t begin = header.points * field.offset;
    columns.push_back({begin, begin + header.points * size, k, size, field.type});
  }
  std::sort(columns.begin(), columns.end(),
            [](const Column& a, const Column& b) { return a.begin < b.begin; });
  std::size_t c = 0;  // the column being filled, or the next one
  const detail::LzfSink scatter = [&](const char* data, std::size_t size, std::uint64_t offset) {
    std::size_t used = 0;
    while (used < size) {
      const std::uint64_t at_byte = offset + used;
      while (c < columns.size() && at_byte >= columns[c].end) ++c;
      if (c == columns.size()) return size;  // the rest holds no column of interest
      const Column& column = columns[c];
      if (at_byte < column.begin) {
        used +=
            static_cast<std::size_t>(std::min<std::uint64_t>(size - used, column.begin - at_byte));
        continue;
      }
      const auto first = static_cast<std::size_t>((at_byte - column.begin) / column.size);
      const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(
          (size - used) / column.size, (column.end - at_byte) / column.size));
      if (n == 0) return used;  // a value split across pieces: it comes again with the next one
      for (std::size_t i = 0; i < n; ++i) {
        builder.set(first + i, column.component,
                    detail::load_scalar<kSwap>(data + used + i * column.size, column.type));
      }
      used += n * column.size;
    }
    return used;
  };
  const detail::LzfResult result =
      detail::lzf_decompress_stream(in, compressed, uncompressed, scatter);
  if (!result.ok) {
    fail(path, "LZF data" + at + " is corrupt (expanded to " + std::to_string(result.produced) +
                   " of " + std::to_string(uncompressed) + " bytes)");
  }
}

FieldIndex field_index(const std::filesystem::path& path, const PcdHeader& header) {
  static constexpr std::array<std::string_view, 6> kNames = {"x",        "y",        "z",
                                                             "normal_x", "normal_y", "normal_z"};
  FieldIndex layout;
  layout.normals = true;
  for (std::size_t k = 0; k < 6; ++k) {
    layout.index[k] = header.fields.size();
    for (std::size_t f = 0; f < header.fields.size(); ++f) {
      if (header.fields[f].name == kNames[k]) {
        layout.index[k] = f;
        break;
      }
    }
    const bool found =
        layout.index[k] < header.fields.size() && header.fields[layout.index[k]].count == 1;
    if (k < 3 && !found) {
      fail(path, layout.index[k] < header.fields.size()
                     ? "field '" + std::string(kNames[k]) + "' must have COUNT 1"
                     : "no field '" + std::string(kNames[k]) + "' (FIELDS must include x y z)");
    }
    if (k >= 3) layout.normals = layout.normals && found;
  }
  return layout;
}

}  // namespace

namespace detail {

PointCloud read_pcd(BlockReader& in, ReadInfo& info) {
  LineReader lines(in);
  const PcdHeader header = parse_pcd_header(lines);
  const FieldIndex layout = field_index(in.path(), header);
  CloudBuilder builder(in.path(), layout.normals);
  if (header.height > 1) builder.keep_indices();
  switch (header.data) {
    case PcdData::kAscii:
      read_ascii(lines, header, layout, builder);
      break;
    case PcdData::kBinary:
      read_binary(in, header, layout, builder);
      break;
    case PcdData::kBinaryCompressed:
      read_compressed(in, header, layout, builder);
      break;
  }
  info.width = static_cast<std::size_t>(header.width);
  info.height = static_cast<std::size_t>(header.height);
  info.viewpoint = header.viewpoint;
  PointCloud cloud = builder.finish();
  info.dropped_non_finite = builder.dropped();
  info.indices = builder.take_indices();
  return cloud;
}

}  // namespace detail

namespace {

// The header of a file holding x y z (and the normals) as float32.
std::string pcd_header(bool normals, std::size_t width, std::size_t height,
                       const Viewpoint& viewpoint, PcdEncoding encoding) {
  std::string header = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  header += normals ? "FIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\n"
                      "TYPE F F F F F F\nCOUNT 1 1 1 1 1 1\n"
                    : "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  header += "WIDTH " + std::to_string(width) + "\nHEIGHT " + std::to_string(height) + "\nVIEWPOINT";
  const Eigen::Quaterniond& q = viewpoint.orientation;
  for (const double v : {viewpoint.position.x(), viewpoint.position.y(), viewpoint.position.z(),
                         q.w(), q.x(), q.y(), q.z()}) {
    header += ' ';
    detail::append_general(header, v, 17);  // exact
  }
  header += "\nPOINTS " + std::to_string(width * height) + "\nDATA ";
  header += encoding == PcdEncoding::kAscii    ? "ascii\n"
            : encoding == PcdEncoding::kBinary ? "binary\n"
                                               : "binary_compressed\n";
  return header;
}

// binary_compressed, one column per field (see read_compressed). The columns are compressed a
// block at a time and written as they come, the sizes patched in at the end: concatenated LZF
// streams are one valid stream (every reference stays inside its own block), so memory stays at
// one block whatever the cloud's size.
template <typename Kept, typename Value>
void write_compressed(std::ostream& out, const std::string& header, std::size_t size,
                      std::size_t fields, const Kept& kept, const Value& value) {
  constexpr std::size_t kBlock = std::size_t{1} << 20;
  out.write(header.data(), std::ssize(header));
  const std::streampos sizes_at = out.tellp();
  out.write("\0\0\0\0\0\0\0\0", 8);
  std::string raw, packed(kBlock + kBlock / 16 + 64, '\0');
  std::uint64_t raw_bytes = 0, packed_bytes = 0;
  const auto compress = [&] {
    if (raw.empty()) return;
    const unsigned int n = lzf_compress(raw.data(), static_cast<unsigned int>(raw.size()),
                                        packed.data(), static_cast<unsigned int>(packed.size()));
    // Incompressible input grows by one control byte per 32 literals: the buffer always suffices.
    if (n == 0) throw std::logic_error("write_pcd: LZF compression failed");
    out.write(packed.data(), n);
    raw_bytes += raw.size();
    packed_bytes += n;
    raw.clear();
  };
  raw.reserve(kBlock);
  for (std::size_t f = 0; f < fields; ++f) {
    for (std::size_t i = 0; i < size; ++i) {
      if (!kept(i)) continue;
      detail::append_bytes(raw, value(i, f), kSwap);
      if (raw.size() >= kBlock) compress();
    }
  }
  compress();
  std::string sizes;
  detail::append_bytes(sizes, static_cast<std::uint32_t>(packed_bytes), kSwap);
  detail::append_bytes(sizes, static_cast<std::uint32_t>(raw_bytes), kSwap);
  out.seekp(sizes_at);
  out.write(sizes.data(), std::ssize(sizes));
}

}  // namespace

void write_pcd(const std::filesystem::path& path, const PointCloud& cloud, PcdEncoding encoding,
               const PcdLayout& layout) {
  const bool organized = layout.width != 0 || layout.height != 0;
  if (organized &&
      (layout.width == 0 || layout.height == 0 || layout.width != cloud.size() / layout.height ||
       layout.width * layout.height != cloud.size())) {
    throw std::invalid_argument(
        "write_pcd: an organized layout of " + std::to_string(layout.width) + " x " +
        std::to_string(layout.height) + " points for a cloud of " + std::to_string(cloud.size()));
  }
  // Unorganized, a point without finite coordinates carries nothing; organized, it holds its pixel.
  const auto kept = [&](std::size_t i) { return organized || cloud.positions[i].allFinite(); };
  std::size_t n = cloud.size();
  if (!organized)
    n = static_cast<std::size_t>(
        std::count_if(cloud.positions.begin(), cloud.positions.end(),
                      [](const Eigen::Vector3d& p) { return p.allFinite(); }));
  const bool normals = cloud.has_normals();
  const std::size_t fields = normals ? 6 : 3;
  const std::string header = pcd_header(normals, organized ? layout.width : n,
                                        organized ? layout.height : 1, layout.viewpoint, encoding);
  const auto value = [&](std::size_t i, std::size_t f) {
    return detail::to_float(f < 3 ? cloud.positions[i][static_cast<int>(f)]
                                  : cloud.normals[i][static_cast<int>(f - 3)]);
  };

  if (encoding == PcdEncoding::kBinaryCompressed) {
    if (std::uint64_t{n} * fields * sizeof(float) > std::numeric_limits<std::uint32_t>::max()) {
      throw OutputError(path, "cannot write: " + std::to_string(n) +
                                  " points exceed binary_compressed's 4 GiB limit (use binary)");
    }
    write_atomically(path, [&](std::ostream& out) {
      write_compressed(out, header, cloud.size(), fields, kept, value);
    });
    return;
  }
  write_atomically(path, [&](std::ostream& out) {
    detail::ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += header;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (!kept(i)) continue;
      for (std::size_t f = 0; f < fields; ++f) {
        if (encoding == PcdEncoding::kAscii) {
          detail::append_shortest(buffer, value(i, f));
          buffer += f + 1 < fields ? ' ' : '\n';
        } else {
          detail::append_bytes(buffer, value(i, f), kSwap);
        }
      }
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace align3d::io
