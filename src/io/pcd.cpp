// PCD, the Point Cloud Library's format (pointclouds.org, "The PCD (Point Cloud Data) file format",
// v0.7; older headers omit COUNT, spell FIELDS as COLUMNS, or give only WIDTH): a text header, then
// the points as text lines, packed little-endian records (binary), or LZF-compressed columns
// (binary_compressed).
#include <lzf.h>

#include <cmath>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <string>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace {

using detail::CloudBuilder;
using detail::fail;
using detail::quoted;
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
  std::uint64_t points = 0;
  std::size_t point_bytes = 0;   // binary record size
  std::size_t point_values = 0;  // values per ascii line
  PcdData data = PcdData::kAscii;
  std::size_t data_offset = 0;  // of the first byte after the DATA line
  std::size_t line_count = 0;   // header lines; ascii data starts on the next
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

PcdHeader parse_header(const std::filesystem::path& path, std::string_view data) {
  detail::LineCursor lines(data.data(), data.data() + data.size());
  std::vector<std::string_view> names, sizes, types, counts;
  std::optional<std::uint64_t> width, height, points;
  // Where each keyword was seen, for the errors found once the whole header is known.
  std::size_t sizes_line = 0, types_line = 0, counts_line = 0, points_line = 0, height_line = 0;
  PcdHeader header;
  std::string_view line;
  for (;;) {
    if (!lines.next(line)) fail(path, "header ends without a DATA line");
    if (static_cast<std::size_t>(line.data() + line.size() - data.data()) >
        detail::kMaxHeaderBytes) {
      fail(path, "header longer than 1 MiB without a DATA line");
    }
    auto words = detail::split_words(line);
    if (words.empty() || words[0].front() == '#') continue;
    const std::string where = "line " + std::to_string(lines.number()) + ": ";
    const std::string_view keyword = words[0];
    const std::vector<std::string_view> rest(words.begin() + 1, words.end());
    if (keyword == "VERSION" || keyword == "VIEWPOINT") {
      // Neither changes how the points are read: align3d does not apply the sensor pose.
    } else if (keyword == "FIELDS" || keyword == "COLUMNS") {
      names = rest;
    } else if (keyword == "SIZE") {
      sizes = rest;
      sizes_line = lines.number();
    } else if (keyword == "TYPE") {
      types = rest;
      types_line = lines.number();
    } else if (keyword == "COUNT") {
      counts = rest;
      counts_line = lines.number();
    } else if (keyword == "WIDTH") {
      width = single_count(path, where, words);
    } else if (keyword == "HEIGHT") {
      height = single_count(path, where, words);
      height_line = lines.number();
    } else if (keyword == "POINTS") {
      points = single_count(path, where, words);
      points_line = lines.number();
    } else if (keyword == "DATA") {
      if (words.size() != 2) fail(path, where + "expected 'DATA ascii|binary|binary_compressed'");
      if (words[1] == "ascii") {
        header.data = PcdData::kAscii;
      } else if (words[1] == "binary") {
        header.data = PcdData::kBinary;
      } else if (words[1] == "binary_compressed") {
        header.data = PcdData::kBinaryCompressed;
      } else {
        fail(path, where + "unknown DATA encoding " + quoted(words[1]));
      }
      break;
    } else {
      fail(path, where + "unknown header keyword " + quoted(keyword) + " (not a PCD file?)");
    }
  }
  header.data_offset = static_cast<std::size_t>(lines.position() - data.data());
  header.line_count = lines.number();

  if (names.empty()) fail(path, "header has no FIELDS line");
  const auto at = [](std::size_t line) {
    return line == 0 ? std::string() : "line " + std::to_string(line) + ": ";
  };
  const auto check_entries = [&](const std::vector<std::string_view>& list, const char* what,
                                 std::size_t line) {
    if (list.size() != names.size()) {
      fail(path, at(line) + what + " has " + std::to_string(list.size()) +
                     " entries but FIELDS has " + std::to_string(names.size()));
    }
  };
  check_entries(sizes, "SIZE", sizes_line);
  check_entries(types, "TYPE", types_line);
  if (!counts.empty()) check_entries(counts, "COUNT", counts_line);

  for (std::size_t i = 0; i < names.size(); ++i) {
    PcdField field;
    field.name = names[i];
    std::uint64_t size = 0;
    std::uint64_t count = 1;
    if (!detail::parse_u64(sizes[i], size)) {
      fail(path,
           at(sizes_line) + "bad SIZE " + quoted(sizes[i]) + " for field '" + field.name + "'");
    }
    if (types[i].size() != 1 || !to_scalar_type(types[i][0], size, field.type)) {
      fail(path, at(types_line) + "unsupported TYPE " + quoted(types[i]) + " with SIZE " +
                     std::string(sizes[i]) + " for field '" + field.name + "'");
    }
    if (!counts.empty() &&
        (!detail::parse_u64(counts[i], count) || count == 0 || count > kMaxFieldCount)) {
      fail(path,
           at(counts_line) + "bad COUNT " + quoted(counts[i]) + " for field '" + field.name + "'");
    }
    field.count = static_cast<std::size_t>(count);
    field.offset = header.point_bytes;
    header.point_bytes += static_cast<std::size_t>(size) * field.count;
    header.point_values += field.count;
    header.fields.push_back(std::move(field));
  }

  if (width) {
    const std::uint64_t h = height.value_or(1);
    if (h != 0 && *width > std::numeric_limits<std::uint64_t>::max() / h) {
      fail(path, at(height_line) + "WIDTH * HEIGHT overflows");
    }
    if (points && *points != *width * h) {
      fail(path, at(points_line) + "POINTS " + std::to_string(*points) +
                     " does not equal WIDTH * HEIGHT = " + std::to_string(*width) + " * " +
                     std::to_string(h));
    }
    header.points = *width * h;
  } else if (points) {
    header.points = *points;
  } else {
    fail(path, "header has neither POINTS nor WIDTH");
  }
  return header;
}

// Where one point's component lives: start + i * stride for point i. Covers both the interleaved
// records of binary (stride = record size) and the columns of binary_compressed (stride = value
// size), so one loop decodes both.
struct Column {
  const char* start = nullptr;
  std::size_t stride = 0;
  ScalarType type = ScalarType::kFloat32;
};

template <bool kSwap>
void decode_columns(const std::array<Column, 6>& c, bool normals, std::uint64_t points,
                    CloudBuilder& builder) {
  const auto get = [&](std::size_t k, std::uint64_t i) {
    return detail::load_scalar<kSwap>(c[k].start + i * c[k].stride, c[k].type);
  };
  for (std::uint64_t i = 0; i < points; ++i) {
    if (normals) {
      builder.add(get(0, i), get(1, i), get(2, i), get(3, i), get(4, i), get(5, i));
    } else {
      builder.add(get(0, i), get(1, i), get(2, i));
    }
  }
}

// PCL writes host byte order, i.e. little-endian on every platform it is used on.
constexpr bool kSwap = detail::kHostIsBigEndian;

void read_ascii(const std::filesystem::path& path, std::string_view file, const PcdHeader& header,
                const std::array<std::size_t, 6>& index, bool normals, CloudBuilder& builder) {
  detail::LineCursor lines(file.data() + header.data_offset, file.data() + file.size(),
                           header.line_count + 1);
  // Every value takes at least a character and a separator (+ 1: the last line may lack its '\n').
  const auto left = static_cast<std::size_t>(lines.end() - lines.position());
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
  for (std::size_t k = 0; k < (normals ? 6u : 3u); ++k) column[k] = first_value[index[k]];

  std::vector<double> values(header.point_values);
  std::string_view line;
  for (std::uint64_t i = 0; i < header.points; ++i) {
    do {
      if (!lines.next(line)) {
        fail(path, "truncated data: the header announces " + std::to_string(header.points) +
                       " points, the file ends after " + std::to_string(i) + " (line " +
                       std::to_string(lines.number()) + ")");
      }
    } while (line.find_first_not_of(" \t\r\v\f") == std::string_view::npos);
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
        fail(path, where() + "bad number " + quoted(detail::next_token(line, pos, detail::kSpace)));
      }
    }
    if (!detail::next_token(line, pos, detail::kSpace).empty()) {
      fail(path, where() + "too many values (expected " + std::to_string(values.size()) + ")");
    }
    const auto val = [&](std::size_t k) {
      return detail::as_stored(values[column[k]], header.fields[index[k]].type);
    };
    if (normals) {
      builder.add(val(0), val(1), val(2), val(3), val(4), val(5));
    } else {
      builder.add(val(0), val(1), val(2));
    }
  }
}

void read_binary(const std::filesystem::path& path, std::string_view file, const PcdHeader& header,
                 const std::array<std::size_t, 6>& index, bool normals, CloudBuilder& builder) {
  const char* p = file.data() + header.data_offset;
  const auto left = file.size() - header.data_offset;
  if (header.points > left / header.point_bytes) {
    fail(path, "header announces " + std::to_string(header.points) + " points of " +
                   std::to_string(header.point_bytes) + " bytes at byte offset " +
                   std::to_string(header.data_offset) + ", but only " + std::to_string(left) +
                   " bytes remain (truncated file?)");
  }
  builder.reserve(static_cast<std::size_t>(header.points));
  std::array<Column, 6> columns{};
  for (std::size_t k = 0; k < (normals ? 6u : 3u); ++k) {
    const PcdField& field = header.fields[index[k]];
    columns[k] = {p + field.offset, header.point_bytes, field.type};
  }
  decode_columns<kSwap>(columns, normals, header.points, builder);
}

// binary_compressed: uint32 compressed size, uint32 uncompressed size, then one LZF stream that
// expands to the fields one after another, each holding all points' values (PCL's
// pcl::io::PCDReader::readBodyBinary).
void read_compressed(const std::filesystem::path& path, std::string_view file,
                     const PcdHeader& header, const std::array<std::size_t, 6>& index, bool normals,
                     CloudBuilder& builder) {
  const char* p = file.data() + header.data_offset;
  const auto left = file.size() - header.data_offset;
  const std::string at = " at byte offset " + std::to_string(header.data_offset);
  if (left < 8) fail(path, "binary_compressed data shorter than its 8-byte size header" + at);
  const auto compressed = detail::load<std::uint32_t, kSwap>(p);
  const auto uncompressed = detail::load<std::uint32_t, kSwap>(p + 4);
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
  // 88 times, so a larger claim is a lie, caught before it is allocated.
  if (uncompressed > std::uint64_t{88} * compressed) {
    fail(path, "uncompressed size " + std::to_string(uncompressed) + at + " is impossible for " +
                   std::to_string(compressed) + " bytes of LZF data");
  }
  std::unique_ptr<char[]> buffer;
  try {
    buffer = std::make_unique_for_overwrite<char[]>(uncompressed);
  } catch (const std::bad_alloc&) {
    fail(path, "not enough memory to decompress " + std::to_string(uncompressed) + " bytes");
  }
  // liblzf checks every back-reference and run against both buffers and returns 0 on corruption.
  const unsigned int produced =
      uncompressed == 0 ? 0 : lzf_decompress(p + 8, compressed, buffer.get(), uncompressed);
  if (produced != uncompressed) {
    fail(path, "LZF data" + at + " is corrupt (expanded to " + std::to_string(produced) + " of " +
                   std::to_string(uncompressed) + " bytes)");
  }
  builder.reserve(static_cast<std::size_t>(header.points));
  std::array<Column, 6> columns{};
  for (std::size_t k = 0; k < (normals ? 6u : 3u); ++k) {
    const PcdField& field = header.fields[index[k]];
    // field.offset = bytes of the preceding fields per point = their columns' size / points.
    columns[k] = {buffer.get() + header.points * field.offset, detail::scalar_size(field.type),
                  field.type};
  }
  decode_columns<kSwap>(columns, normals, header.points, builder);
}

}  // namespace

namespace detail {

PointCloud read_pcd(const std::filesystem::path& path, std::string_view data,
                    std::size_t& dropped) {
  const PcdHeader header = parse_header(path, data);
  static constexpr std::array<std::string_view, 6> kNames = {"x",        "y",        "z",
                                                             "normal_x", "normal_y", "normal_z"};
  std::array<std::size_t, 6> index{};
  bool normals = true;
  for (std::size_t k = 0; k < 6; ++k) {
    index[k] = header.fields.size();
    for (std::size_t f = 0; f < header.fields.size(); ++f) {
      if (header.fields[f].name == kNames[k]) {
        index[k] = f;
        break;
      }
    }
    const bool found = index[k] < header.fields.size() && header.fields[index[k]].count == 1;
    if (k < 3 && !found) {
      fail(path, index[k] < header.fields.size()
                     ? "field '" + std::string(kNames[k]) + "' must have COUNT 1"
                     : "no field '" + std::string(kNames[k]) + "' (FIELDS must include x y z)");
    }
    if (k >= 3) normals = normals && found;
  }

  CloudBuilder builder(normals);
  switch (header.data) {
    case PcdData::kAscii:
      read_ascii(path, data, header, index, normals, builder);
      break;
    case PcdData::kBinary:
      read_binary(path, data, header, index, normals, builder);
      break;
    case PcdData::kBinaryCompressed:
      read_compressed(path, data, header, index, normals, builder);
      break;
  }
  return builder.finish(dropped);
}

}  // namespace detail

void write_pcd(const std::filesystem::path& path, const PointCloud& cloud, PcdEncoding encoding) {
  const bool normals = cloud.has_normals();
  const std::size_t n = cloud.size();
  const std::size_t fields = normals ? 6 : 3;
  std::string header = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  header += normals ? "FIELDS x y z normal_x normal_y normal_z\nSIZE 4 4 4 4 4 4\n"
                      "TYPE F F F F F F\nCOUNT 1 1 1 1 1 1\n"
                    : "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  header += "WIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
            std::to_string(n) + "\nDATA ";
  header += encoding == PcdEncoding::kAscii    ? "ascii\n"
            : encoding == PcdEncoding::kBinary ? "binary\n"
                                               : "binary_compressed\n";
  const auto value = [&](std::size_t i, std::size_t f) {
    return detail::to_float(f < 3 ? cloud.positions[i][static_cast<int>(f)]
                                  : cloud.normals[i][static_cast<int>(f - 3)]);
  };

  if (encoding == PcdEncoding::kBinaryCompressed) {
    // Compressed up front so that a failure leaves no temporary file behind.
    const std::uint64_t raw_bytes = std::uint64_t{n} * fields * sizeof(float);
    if (raw_bytes > std::numeric_limits<std::uint32_t>::max()) {
      throw OutputError(path.string() + ": cannot write: " + std::to_string(n) +
                        " points exceed binary_compressed's 4 GiB limit (use binary)");
    }
    std::string columns;
    columns.reserve(raw_bytes);
    for (std::size_t f = 0; f < fields; ++f) {
      for (std::size_t i = 0; i < n; ++i) detail::append_bytes(columns, value(i, f), kSwap);
    }
    // Incompressible input grows by one control byte per 32 literals, plus a little slack.
    std::string packed(raw_bytes + raw_bytes / 16 + 64, '\0');
    const unsigned int packed_bytes =
        raw_bytes == 0 ? 0
                       : lzf_compress(columns.data(), static_cast<unsigned int>(raw_bytes),
                                      packed.data(), static_cast<unsigned int>(packed.size()));
    if (raw_bytes != 0 && packed_bytes == 0) {
      throw OutputError(path.string() + ": cannot write: LZF compression failed");
    }
    write_atomically(path, [&](std::ostream& out) {
      std::string prefix = header;
      detail::append_bytes(prefix, static_cast<std::uint32_t>(packed_bytes), kSwap);
      detail::append_bytes(prefix, static_cast<std::uint32_t>(raw_bytes), kSwap);
      out.write(prefix.data(), static_cast<std::streamsize>(prefix.size()));
      out.write(packed.data(), static_cast<std::streamsize>(packed_bytes));
    });
    return;
  }

  write_atomically(path, [&](std::ostream& out) {
    detail::ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += header;
    for (std::size_t i = 0; i < n; ++i) {
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
