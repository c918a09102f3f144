// PLY, as described by Greg Turk's "The PLY Polygon File Format" (the de-facto spec): a text header
// declaring elements (name, record count) and their properties (scalar or list), then the records
// of each element in header order, as text lines or packed little/big-endian binary.
#include <cmath>
#include <string>
#include <utility>

#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace {

using detail::CloudBuilder;
using detail::fail;
using detail::quoted;
using detail::ScalarType;

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

struct PlyProperty {
  std::string name;
  ScalarType type = ScalarType::kFloat32;  // a scalar's type, or a list's item type
  bool is_list = false;
  ScalarType count_type = ScalarType::kUint8;  // lists only
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;

  bool has_list() const {
    for (const auto& p : properties) {
      if (p.is_list) return true;
    }
    return false;
  }
  // Binary size of a record whose lists are all empty: a lower bound for every record, so
  // count * min_record_bytes() larger than the data left proves the file truncated or lying.
  std::size_t min_record_bytes() const {
    std::size_t bytes = 0;
    for (const auto& p : properties) {
      bytes += detail::scalar_size(p.is_list ? p.count_type : p.type);
    }
    return bytes;
  }
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  std::size_t data_offset = 0;  // of the first byte after end_header's line
  std::size_t line_count = 0;   // header lines; ascii data starts on the next
};

// Both the original names (char, uchar, ...) and the sized ones (int8, uint8, ...) are in use.
bool parse_type(std::string_view name, ScalarType& type) {
  static constexpr std::pair<std::string_view, ScalarType> kTypes[] = {
      {"char", ScalarType::kInt8},      {"int8", ScalarType::kInt8},
      {"uchar", ScalarType::kUint8},    {"uint8", ScalarType::kUint8},
      {"short", ScalarType::kInt16},    {"int16", ScalarType::kInt16},
      {"ushort", ScalarType::kUint16},  {"uint16", ScalarType::kUint16},
      {"int", ScalarType::kInt32},      {"int32", ScalarType::kInt32},
      {"uint", ScalarType::kUint32},    {"uint32", ScalarType::kUint32},
      {"float", ScalarType::kFloat32},  {"float32", ScalarType::kFloat32},
      {"double", ScalarType::kFloat64}, {"float64", ScalarType::kFloat64},
  };
  for (const auto& [type_name, t] : kTypes) {
    if (name == type_name) {
      type = t;
      return true;
    }
  }
  return false;
}

std::string_view trim_right(std::string_view s) {
  while (!s.empty() && detail::is_space(s.back())) s.remove_suffix(1);
  return s;
}

PlyHeader parse_header(const std::filesystem::path& path, std::string_view data) {
  detail::LineCursor lines(data.data(), data.data() + data.size());
  std::string_view line;
  if (!lines.next(line) || trim_right(line) != "ply") {
    fail(path, "not a PLY file (the first line is not 'ply')");
  }
  PlyHeader header;
  bool have_format = false;
  for (;;) {
    if (!lines.next(line)) fail(path, "header ends without an end_header line");
    if (static_cast<std::size_t>(line.data() + line.size() - data.data()) >
        detail::kMaxHeaderBytes) {
      fail(path, "header longer than 1 MiB without end_header");
    }
    const auto words = detail::split_words(line);
    if (words.empty()) continue;
    const std::string where = "line " + std::to_string(lines.number()) + ": ";
    const std::string_view keyword = words[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      if (words.size() != 3) fail(path, where + "expected 'format <encoding> 1.0'");
      if (words[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (words[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else if (words[1] == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBigEndian;
      } else {
        fail(path, where + "unknown PLY format " + quoted(words[1]));
      }
      if (words[2] != "1.0" && words[2] != "1") {
        fail(path, where + "unsupported PLY version " + quoted(words[2]));
      }
      have_format = true;
    } else if (keyword == "element") {
      if (words.size() != 3) fail(path, where + "expected 'element <name> <count>'");
      PlyElement element;
      element.name = words[1];
      if (!detail::parse_u64(words[2], element.count)) {
        fail(path, where + "bad element count " + quoted(words[2]));
      }
      header.elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header.elements.empty()) fail(path, where + "property before any element");
      PlyProperty property;
      if (words.size() >= 2 && words[1] == "list") {
        if (words.size() != 5) {
          fail(path, where + "expected 'property list <count type> <item type> <name>'");
        }
        if (!parse_type(words[2], property.count_type)) {
          fail(path, where + "unknown property type " + quoted(words[2]));
        }
        if (!detail::is_integer(property.count_type)) {
          fail(path, where + "list count type must be an integer type, not " + quoted(words[2]));
        }
        if (!parse_type(words[3], property.type)) {
          fail(path, where + "unknown property type " + quoted(words[3]));
        }
        property.is_list = true;
        property.name = words[4];
      } else {
        if (words.size() != 3) fail(path, where + "expected 'property <type> <name>'");
        if (!parse_type(words[1], property.type)) {
          fail(path, where + "unknown property type " + quoted(words[1]));
        }
        property.name = words[2];
      }
      header.elements.back().properties.push_back(std::move(property));
    } else {
      fail(path, where + "unknown header keyword " + quoted(keyword) + " (missing end_header?)");
    }
  }
  if (!have_format) fail(path, "header has no format line");
  header.data_offset = static_cast<std::size_t>(lines.position() - data.data());
  header.line_count = lines.number();
  return header;
}

// Indices into the vertex element's properties of x, y, z and, when `normals`, nx, ny, nz.
struct VertexLayout {
  std::array<std::size_t, 6> index{};
  bool normals = false;
};

VertexLayout vertex_layout(const std::filesystem::path& path, const PlyElement& vertex) {
  const auto find = [&](std::string_view name) {
    for (std::size_t i = 0; i < vertex.properties.size(); ++i) {
      if (vertex.properties[i].name == name) return i;
    }
    return vertex.properties.size();
  };
  VertexLayout layout;
  static constexpr std::array<std::string_view, 6> kNames = {"x", "y", "z", "nx", "ny", "nz"};
  for (std::size_t k = 0; k < 3; ++k) {
    layout.index[k] = find(kNames[k]);
    if (layout.index[k] == vertex.properties.size()) {
      fail(path, "element 'vertex' has no property '" + std::string(kNames[k]) + "'");
    }
    if (vertex.properties[layout.index[k]].is_list) {
      fail(path, "property '" + std::string(kNames[k]) + "' of element 'vertex' is a list");
    }
  }
  layout.normals = true;
  for (std::size_t k = 3; k < 6; ++k) {
    layout.index[k] = find(kNames[k]);
    layout.normals = layout.normals && layout.index[k] < vertex.properties.size() &&
                     !vertex.properties[layout.index[k]].is_list;
  }
  return layout;
}

// ---- binary ----

struct BinaryData {
  const std::filesystem::path& path;
  const char* file_begin;
  const char* end;
  std::size_t offset(const char* p) const { return static_cast<std::size_t>(p - file_begin); }
  [[noreturn]] void truncated(const char* p, const PlyElement& element,
                              std::uint64_t record) const {
    fail(path, "truncated data at byte offset " + std::to_string(offset(p)) + " (element '" +
                   element.name + "', record " + std::to_string(record) + ")");
  }
};

// A list count; false if it is negative.
template <bool kSwap>
bool load_count(const char* p, ScalarType type, std::uint64_t& count) {
  std::int64_t signed_count = 0;
  switch (type) {
    case ScalarType::kUint8:
      count = detail::load<std::uint8_t, kSwap>(p);
      return true;
    case ScalarType::kUint16:
      count = detail::load<std::uint16_t, kSwap>(p);
      return true;
    case ScalarType::kUint32:
      count = detail::load<std::uint32_t, kSwap>(p);
      return true;
    case ScalarType::kUint64:
      count = detail::load<std::uint64_t, kSwap>(p);
      return true;
    case ScalarType::kInt8:
      signed_count = detail::load<std::int8_t, kSwap>(p);
      break;
    case ScalarType::kInt16:
      signed_count = detail::load<std::int16_t, kSwap>(p);
      break;
    case ScalarType::kInt32:
      signed_count = detail::load<std::int32_t, kSwap>(p);
      break;
    case ScalarType::kInt64:
      signed_count = detail::load<std::int64_t, kSwap>(p);
      break;
    case ScalarType::kFloat32:
    case ScalarType::kFloat64:
      return false;  // rejected by the header parser
  }
  count = static_cast<std::uint64_t>(signed_count);
  return signed_count >= 0;
}

// Walks one record of an element that has list properties, recording where each property starts;
// returns the first byte after the record. Every step is checked against the end of the data, so a
// lying list count is an error, never an over-read.
template <bool kSwap>
const char* walk_record(const BinaryData& data, const char* p, const PlyElement& element,
                        std::uint64_t record, const char** starts) {
  for (std::size_t i = 0; i < element.properties.size(); ++i) {
    const PlyProperty& property = element.properties[i];
    starts[i] = p;
    const auto left = static_cast<std::size_t>(data.end - p);
    if (!property.is_list) {
      if (left < detail::scalar_size(property.type)) data.truncated(p, element, record);
      p += detail::scalar_size(property.type);
      continue;
    }
    const std::size_t count_size = detail::scalar_size(property.count_type);
    if (left < count_size) data.truncated(p, element, record);
    std::uint64_t count = 0;
    if (!load_count<kSwap>(p, property.count_type, count)) {
      fail(data.path, "negative list count at byte offset " + std::to_string(data.offset(p)) +
                          " (element '" + element.name + "', property '" + property.name + "')");
    }
    const std::size_t item_size = detail::scalar_size(property.type);
    if (count > (left - count_size) / item_size) {
      fail(data.path, "list count " + std::to_string(count) + " at byte offset " +
                          std::to_string(data.offset(p)) + " (element '" + element.name +
                          "', property '" + property.name + "') exceeds the " +
                          std::to_string(left - count_size) + " bytes remaining");
    }
    p += count_size + count * item_size;
  }
  return p;
}

struct FixedField {
  std::size_t offset;
  ScalarType type;
};

// Records of a fixed stride: the common case. The per-value type switch is well predicted (the same
// types repeat in every record); a float32-only loop measured no faster, as the time goes to
// loading the file and filling the positions.
template <bool kSwap>
void decode_fixed(const char* p, std::uint64_t count, std::size_t stride,
                  const std::array<FixedField, 6>& f, bool normals, CloudBuilder& builder) {
  const auto get = [&](const char* record, std::size_t k) {
    return detail::load_scalar<kSwap>(record + f[k].offset, f[k].type);
  };
  for (std::uint64_t r = 0; r < count; ++r, p += stride) {
    if (normals) {
      builder.add(get(p, 0), get(p, 1), get(p, 2), get(p, 3), get(p, 4), get(p, 5));
    } else {
      builder.add(get(p, 0), get(p, 1), get(p, 2));
    }
  }
}

template <bool kSwap>
void read_binary(const std::filesystem::path& path, std::string_view file, const PlyHeader& header,
                 std::size_t vertex_index, const VertexLayout& layout, CloudBuilder& builder) {
  const BinaryData data{path, file.data(), file.data() + file.size()};
  const char* p = file.data() + header.data_offset;
  // Elements after the vertex element cannot change the points, so reading stops there.
  for (std::size_t e = 0; e <= vertex_index; ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = e == vertex_index;
    if (element.properties.empty()) continue;  // records of zero bytes
    const std::size_t min_bytes = element.min_record_bytes();
    const auto left = static_cast<std::size_t>(data.end - p);
    if (element.count > left / min_bytes) {
      fail(path, "element '" + element.name + "' announces " + std::to_string(element.count) +
                     " records of " + (element.has_list() ? "at least " : "") +
                     std::to_string(min_bytes) + " bytes at byte offset " +
                     std::to_string(data.offset(p)) + ", but only " + std::to_string(left) +
                     " bytes remain (truncated file?)");
    }
    if (is_vertex) builder.reserve(static_cast<std::size_t>(element.count));
    if (!element.has_list()) {
      if (is_vertex) {
        std::array<FixedField, 6> fields{};
        for (std::size_t k = 0; k < 6; ++k) {
          if (k >= 3 && !layout.normals) break;
          std::size_t offset = 0;
          for (std::size_t i = 0; i < layout.index[k]; ++i) {
            offset += detail::scalar_size(element.properties[i].type);
          }
          fields[k] = {offset, element.properties[layout.index[k]].type};
        }
        decode_fixed<kSwap>(p, element.count, min_bytes, fields, layout.normals, builder);
      }
      p += element.count * min_bytes;
      continue;
    }
    std::vector<const char*> starts(element.properties.size());
    const auto get = [&](std::size_t k) {
      return detail::load_scalar<kSwap>(starts[layout.index[k]],
                                        element.properties[layout.index[k]].type);
    };
    for (std::uint64_t r = 0; r < element.count; ++r) {
      p = walk_record<kSwap>(data, p, element, r, starts.data());
      if (!is_vertex) continue;
      if (layout.normals) {
        builder.add(get(0), get(1), get(2), get(3), get(4), get(5));
      } else {
        builder.add(get(0), get(1), get(2));
      }
    }
  }
}

// ---- ascii ----

bool is_blank(std::string_view line) {
  for (const char c : line) {
    if (!detail::is_space(c)) return false;
  }
  return true;
}

void read_ascii(const std::filesystem::path& path, std::string_view file, const PlyHeader& header,
                std::size_t vertex_index, const VertexLayout& layout, CloudBuilder& builder) {
  detail::LineCursor lines(file.data() + header.data_offset, file.data() + file.size(),
                           header.line_count + 1);
  std::vector<double> values;
  for (std::size_t e = 0; e <= vertex_index; ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = e == vertex_index;
    if (element.properties.empty()) continue;
    if (is_vertex) {
      // Every value takes at least one character and one separator (the last line may lack its
      // newline, hence the + 1).
      const auto left = static_cast<std::size_t>(lines.end() - lines.position());
      const std::size_t min_bytes = 2 * element.properties.size();
      if (element.count > (left + 1) / min_bytes) {
        fail(path, "element 'vertex' announces " + std::to_string(element.count) +
                       " records, but the " + std::to_string(left) + " bytes after line " +
                       std::to_string(header.line_count) + " can hold at most " +
                       std::to_string((left + 1) / min_bytes) + " (truncated file?)");
      }
      builder.reserve(static_cast<std::size_t>(element.count));
      values.resize(element.properties.size());
    }
    std::string_view line;
    for (std::uint64_t r = 0; r < element.count; ++r) {
      do {
        if (!lines.next(line)) {
          fail(path, "truncated data: element '" + element.name + "' announces " +
                         std::to_string(element.count) + " records, the file ends after " +
                         std::to_string(r) + " (line " + std::to_string(lines.number()) + ")");
        }
      } while (is_blank(line));
      detail::check_line_length(path, line, lines.number(), detail::kMaxRecordLineBytes);
      // Built only on error: one string per record would dominate the parse time.
      const auto where = [&] { return "line " + std::to_string(lines.number()) + ": "; };
      std::size_t pos = 0;
      for (std::size_t i = 0; i < element.properties.size(); ++i) {
        const PlyProperty& property = element.properties[i];
        const auto too_few = [&] {
          fail(path, where() + "too few values for element '" + element.name + "' (property '" +
                         property.name + "' missing)");
        };
        if (!property.is_list && !is_vertex) {
          // Other elements' values are skipped unparsed: only their number matters here.
          if (detail::next_token(line, pos, detail::kSpace).empty()) too_few();
          continue;
        }
        double number = 0.0;
        const std::size_t token_pos = pos;
        const auto token = detail::next_number(line, pos, detail::kSpace, number);
        if (token == detail::Token::kEnd) too_few();
        const auto bad = [&](const std::string& what) {
          fail(path, where() + what + " " + quoted(detail::next_token(line, pos, detail::kSpace)) +
                         " for property '" + property.name + "'");
        };
        if (token == detail::Token::kNotANumber) {
          bad(property.is_list ? "bad list count" : "bad number");
        }
        if (!property.is_list) {
          values[i] = number;
          continue;
        }
        // A count beyond the line's length fails below at the line's end; the bound only keeps the
        // conversion to an integer defined.
        if (!(number >= 0.0) || number != std::floor(number) ||
            number > static_cast<double>(line.size())) {
          pos = token_pos;
          bad("bad list count");
        }
        for (auto k = static_cast<std::size_t>(number); k > 0; --k) {
          if (detail::next_token(line, pos, detail::kSpace).empty()) {
            fail(path, where() + "too few values for list '" + property.name + "' (announced " +
                           std::to_string(static_cast<std::size_t>(number)) + ")");
          }
        }
      }
      if (!detail::next_token(line, pos, detail::kSpace).empty()) {
        fail(path, where() + "too many values for element '" + element.name + "' (expected " +
                       std::to_string(element.properties.size()) + " properties)");
      }
      if (!is_vertex) continue;
      const auto v = [&](std::size_t k) {
        const std::size_t i = layout.index[k];
        return detail::as_stored(values[i], element.properties[i].type);
      };
      if (layout.normals) {
        builder.add(v(0), v(1), v(2), v(3), v(4), v(5));
      } else {
        builder.add(v(0), v(1), v(2));
      }
    }
  }
}

}  // namespace

namespace detail {

PointCloud read_ply(const std::filesystem::path& path, std::string_view data,
                    std::size_t& dropped) {
  const PlyHeader header = parse_header(path, data);
  std::size_t vertex_index = header.elements.size();
  for (std::size_t e = 0; e < header.elements.size(); ++e) {
    if (header.elements[e].name == "vertex") {
      vertex_index = e;
      break;
    }
  }
  if (vertex_index == header.elements.size()) fail(path, "no vertex element in the header");
  const VertexLayout layout = vertex_layout(path, header.elements[vertex_index]);

  CloudBuilder builder(layout.normals);
  switch (header.format) {
    case PlyFormat::kAscii:
      read_ascii(path, data, header, vertex_index, layout, builder);
      break;
    case PlyFormat::kBinaryLittleEndian:
      read_binary<kHostIsBigEndian>(path, data, header, vertex_index, layout, builder);
      break;
    case PlyFormat::kBinaryBigEndian:
      read_binary<!kHostIsBigEndian>(path, data, header, vertex_index, layout, builder);
      break;
  }
  return builder.finish(dropped);
}

}  // namespace detail

void write_ply(const std::filesystem::path& path, const PointCloud& cloud, PlyEncoding encoding) {
  const bool normals = cloud.has_normals();
  std::string header = "ply\nformat ";
  header += encoding == PlyEncoding::kAscii                ? "ascii"
            : encoding == PlyEncoding::kBinaryLittleEndian ? "binary_little_endian"
                                                           : "binary_big_endian";
  header += " 1.0\ncomment written by align3d\nelement vertex " + std::to_string(cloud.size()) +
            "\nproperty float x\nproperty float y\nproperty float z\n";
  if (normals) header += "property float nx\nproperty float ny\nproperty float nz\n";
  header += "end_header\n";

  const bool swap = (encoding == PlyEncoding::kBinaryBigEndian) != detail::kHostIsBigEndian;
  write_atomically(path, [&](std::ostream& out) {
    detail::ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += header;
    const auto put = [&](const Eigen::Vector3d& v, char last) {
      for (int k = 0; k < 3; ++k) {
        const float value = detail::to_float(v[k]);
        if (encoding == PlyEncoding::kAscii) {
          detail::append_shortest(buffer, value);
          buffer += k < 2 ? ' ' : last;
        } else {
          detail::append_bytes(buffer, value, swap);
        }
      }
    };
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      put(cloud.positions[i], normals ? ' ' : '\n');
      if (normals) put(cloud.normals[i], '\n');
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace align3d::io
