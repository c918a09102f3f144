// PLY, as described by Greg Turk's "The PLY Polygon File Format" (the de-facto spec): a text header
// declaring elements (name, record count) and their properties (scalar or list), then the records
// of each element in header order, as text lines or packed little/big-endian binary.
#include <cmath>
#include <string>
#include <type_traits>
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
constexpr std::pair<std::string_view, PlyFormat> kPlyFormats[] = {
    {"ascii", PlyFormat::kAscii},
    {"binary_little_endian", PlyFormat::kBinaryLittleEndian},
    {"binary_big_endian", PlyFormat::kBinaryBigEndian}};

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
  std::size_t line_count = 0;  // header lines; ascii data starts on the next
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
  const auto found = detail::lookup(kTypes, name);
  if (found) type = *found;
  return found.has_value();
}

std::string_view trim_right(std::string_view s) {
  while (!s.empty() && detail::is_space(s.back())) s.remove_suffix(1);
  return s;
}

// "property <type> <name>" or "property list <count type> <item type> <name>".
PlyProperty parse_property(const std::filesystem::path& path, const std::string& where,
                           const std::vector<std::string_view>& words) {
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
  return property;
}

PlyHeader parse_header(detail::LineReader& lines) {
  const std::filesystem::path& path = lines.input().path();
  if (lines.input().peek(3).substr(0, 3) != "ply") {
    fail(path, "not a PLY file (it does not start with 'ply')");
  }
  detail::HeaderLines header_lines(lines, "an end_header line");
  header_lines.next();
  if (trim_right(header_lines.line()) != "ply") {
    fail(path, "not a PLY file (the first line is not 'ply')");
  }
  PlyHeader header;
  bool have_format = false;
  for (;;) {
    const auto& words = header_lines.next();
    if (words.empty()) continue;
    const std::string where = header_lines.where();
    const std::string_view keyword = words[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      if (words.size() != 3) fail(path, where + "expected 'format <encoding> 1.0'");
      header.format =
          detail::lookup_or_fail(kPlyFormats, words[1], path, where + "unknown PLY format");
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
      header.elements.back().properties.push_back(parse_property(path, where, words));
    } else {
      fail(path, where + "unknown header keyword " + quoted(keyword) + " (missing end_header?)");
    }
  }
  if (!have_format) fail(path, "header has no format line");
  header.line_count = header_lines.number();
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

std::string record_name(const PlyElement& element, std::uint64_t record) {
  return "element '" + element.name + "', record " + std::to_string(record);
}

// A list count; false if it is negative (or of a floating-point type, which the header refuses).
template <bool kSwap>
bool load_count(const char* p, ScalarType type, std::uint64_t& count) {
  return detail::visit_scalar(type, [&](auto t) {
    using T = decltype(t);
    if constexpr (std::is_floating_point_v<T>) {
      return false;
    } else {
      const T value = detail::load<T, kSwap>(p);
      if constexpr (std::is_signed_v<T>) {
        if (value < 0) return false;
      }
      count = static_cast<std::uint64_t>(value);
      return true;
    }
  });
}

// Reads one record of an element that has list properties, property by property, storing the
// value of property i in values[component[i]] when component[i] < 6. Lists are skipped unread
// (align3d uses no list), each count checked against what the file holds first, so a lying count is
// an error, never a long read.
template <bool kSwap>
void walk_record(detail::BlockReader& in, const PlyElement& element, std::uint64_t record,
                 const std::vector<std::size_t>& component, std::array<double, 6>& values) {
  const auto truncated = [&] {
    fail(in.path(), "truncated data at byte offset " + std::to_string(in.offset()) + " (" +
                        record_name(element, record) + ")");
  };
  for (std::size_t i = 0; i < element.properties.size(); ++i) {
    const PlyProperty& property = element.properties[i];
    if (!property.is_list) {
      const std::size_t size = detail::scalar_size(property.type);
      const std::string_view data = in.peek(size);
      if (data.size() < size) truncated();
      if (component[i] < 6)
        values[component[i]] = detail::load_scalar<kSwap>(data.data(), property.type);
      in.consume(size);
      continue;
    }
    const std::size_t count_size = detail::scalar_size(property.count_type);
    const std::string_view data = in.peek(count_size);
    if (data.size() < count_size) truncated();
    const std::string at = " at byte offset " + std::to_string(in.offset()) + " (element '" +
                           element.name + "', property '" + property.name + "')";
    std::uint64_t count = 0;
    if (!load_count<kSwap>(data.data(), property.count_type, count)) {
      fail(in.path(), "negative list count" + at);
    }
    in.consume(count_size);
    const std::size_t item_size = detail::scalar_size(property.type);
    if (count > in.remaining() / item_size) {
      fail(in.path(), "list count " + std::to_string(count) + at + " exceeds the " +
                          std::to_string(in.remaining()) + " bytes remaining");
    }
    if (in.skip(count * item_size) < count * item_size) truncated();
  }
}

template <bool kSwap>
void read_binary(detail::BlockReader& in, const PlyHeader& header, std::size_t vertex_index,
                 const VertexLayout& layout, CloudBuilder& builder) {
  // Elements after the vertex element cannot change the points, so reading stops there.
  for (std::size_t e = 0; e <= vertex_index; ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = e == vertex_index;
    if (element.properties.empty()) continue;  // records of zero bytes
    const std::size_t min_bytes = element.min_record_bytes();
    const std::uint64_t left = in.remaining();
    if (element.count > left / min_bytes) {
      fail(in.path(), "element '" + element.name + "' announces " + std::to_string(element.count) +
                          " records of " + (element.has_list() ? "at least " : "") +
                          std::to_string(min_bytes) + " bytes at byte offset " +
                          std::to_string(in.offset()) + ", but only " + std::to_string(left) +
                          " bytes remain (truncated file?)");
    }
    if (is_vertex) builder.reserve(static_cast<std::size_t>(element.count));
    if (!element.has_list()) {
      const std::uint64_t bytes = element.count * min_bytes;
      if (!is_vertex) {
        if (in.skip(bytes) < bytes) {
          fail(in.path(), "truncated data at byte offset " + std::to_string(in.offset()) +
                              " (element '" + element.name + "')");
        }
        continue;
      }
      detail::RecordLayout records{min_bytes, {}, layout.normals};
      for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) {
        for (std::size_t i = 0; i < layout.index[k]; ++i) {
          records.fields[k].offset += detail::scalar_size(element.properties[i].type);
        }
        records.fields[k].type = element.properties[layout.index[k]].type;
      }
      detail::decode_records<kSwap>(in, element.count, records, builder,
                                    "element '" + element.name + "'");
      continue;
    }
    std::vector<std::size_t> component(element.properties.size(), 6);
    if (is_vertex) {
      for (std::size_t k = 0; k < (layout.normals ? 6u : 3u); ++k) component[layout.index[k]] = k;
    }
    std::array<double, 6> v{};
    for (std::uint64_t r = 0; r < element.count; ++r) {
      walk_record<kSwap>(in, element, r, component, v);
      if (!is_vertex) continue;
      if (layout.normals) {
        builder.add(v[0], v[1], v[2], v[3], v[4], v[5]);
      } else {
        builder.add(v[0], v[1], v[2]);
      }
    }
  }
}

// ---- ascii ----

// Parses one text record of `element` into `values` (by property; a list's values are checked and
// skipped, as are all values of elements other than the vertex).
void parse_ascii_record(const std::filesystem::path& path, std::string_view line,
                        std::size_t number, const PlyElement& element, bool is_vertex,
                        std::vector<double>& values) {
  // Built only on error: one string per record would dominate the parse time.
  const auto where = [&] { return "line " + std::to_string(number) + ": "; };
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
    double number_value = 0.0;
    const std::size_t token_pos = pos;
    const auto token = detail::next_number(line, pos, detail::kSpace, number_value);
    if (token == detail::Token::kEnd) too_few();
    const auto bad = [&](const std::string& what) {
      fail(path, where() + what + " " + quoted(detail::next_token(line, pos, detail::kSpace)) +
                     " for property '" + property.name + "'");
    };
    if (token == detail::Token::kNotANumber) {
      bad(property.is_list ? "bad list count" : "bad number");
    }
    if (!property.is_list) {
      values[i] = number_value;
      continue;
    }
    // A count beyond the line's length fails below at the line's end; the bound only keeps the
    // conversion to an integer defined.
    if (!(number_value >= 0.0) || number_value != std::floor(number_value) ||
        number_value > static_cast<double>(line.size())) {
      pos = token_pos;
      bad("bad list count");
    }
    for (auto k = static_cast<std::size_t>(number_value); k > 0; --k) {
      if (detail::next_token(line, pos, detail::kSpace).empty()) {
        fail(path, where() + "too few values for list '" + property.name + "' (announced " +
                       std::to_string(static_cast<std::size_t>(number_value)) + ")");
      }
    }
  }
  if (!detail::next_token(line, pos, detail::kSpace).empty()) {
    fail(path, where() + "too many values for element '" + element.name + "' (expected " +
                   std::to_string(element.properties.size()) + " properties)");
  }
}

void read_ascii(detail::LineReader& lines, const PlyHeader& header, std::size_t vertex_index,
                const VertexLayout& layout, CloudBuilder& builder) {
  const std::filesystem::path& path = lines.input().path();
  std::vector<double> values;
  for (std::size_t e = 0; e <= vertex_index; ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = e == vertex_index;
    if (element.properties.empty()) continue;
    if (is_vertex) {
      // Every value takes at least one character and one separator (the last line may lack its
      // newline, hence the + 1).
      const std::uint64_t left = lines.input().remaining();
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
        if (!lines.next(line, detail::kMaxRecordLineBytes)) {
          fail(path, "truncated data: element '" + element.name + "' announces " +
                         std::to_string(element.count) + " records, the file ends after " +
                         std::to_string(r) + " (line " + std::to_string(lines.number()) + ")");
        }
      } while (detail::is_blank(line));
      detail::check_line_length(path, line, lines.number(), detail::kMaxRecordLineBytes);
      parse_ascii_record(path, line, lines.number(), element, is_vertex, values);
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

PointCloud read_ply(BlockReader& in, ReadInfo& info) {
  LineReader lines(in);
  const PlyHeader header = parse_header(lines);
  std::size_t vertex_index = header.elements.size();
  for (std::size_t e = 0; e < header.elements.size(); ++e) {
    if (header.elements[e].name == "vertex") {
      vertex_index = e;
      break;
    }
  }
  if (vertex_index == header.elements.size()) fail(in.path(), "no vertex element in the header");
  const VertexLayout layout = vertex_layout(in.path(), header.elements[vertex_index]);

  CloudBuilder builder(in.path(), layout.normals);
  switch (header.format) {
    case PlyFormat::kAscii:
      read_ascii(lines, header, vertex_index, layout, builder);
      break;
    case PlyFormat::kBinaryLittleEndian:
      read_binary<kHostIsBigEndian>(in, header, vertex_index, layout, builder);
      break;
    case PlyFormat::kBinaryBigEndian:
      read_binary<!kHostIsBigEndian>(in, header, vertex_index, layout, builder);
      break;
  }
  info.width = header.elements[vertex_index].count;
  info.height = 1;
  PointCloud cloud = builder.finish();
  info.dropped_non_finite = builder.dropped();
  return cloud;
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
