// PLY, as described by Greg Turk's "The PLY Polygon File Format" (the de-facto spec): a text header
// declaring elements (name, record count) and their properties (scalar or list), then the records
// of each element in header order, as text lines or packed little/big-endian binary. A point cloud
// is the vertex element's x y z (nx ny nz); a mesh adds the face element's lists of corner indices.
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>

#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io_detail.hpp"
#include "mesh_readers.hpp"

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

PlyHeader parse_ply_header(detail::LineReader& lines) {
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

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

std::size_t find_element(const PlyHeader& header, std::string_view name) {
  for (std::size_t e = 0; e < header.elements.size(); ++e) {
    if (header.elements[e].name == name) return e;
  }
  return kNone;
}

// The face element's list of corner indices: "vertex_indices" (the spec's name) or "vertex_index"
// (some exporters'); kNone if there is none.
std::size_t find_corner_list(const PlyElement& face) {
  for (const std::string_view name : {"vertex_indices", "vertex_index"}) {
    for (std::size_t i = 0; i < face.properties.size(); ++i) {
      if (face.properties[i].name == name) return i;
    }
  }
  return kNone;
}

// What a reader takes from the body: the vertex element's x y z (nx ny nz) and, for a mesh, the
// face element's corner lists. Every element up to the last of these is read (the others checked
// and skipped); reading stops there, as later elements cannot change the result.
struct BodyPlan {
  std::size_t vertex = kNone;  // element indices
  VertexLayout layout;
  std::size_t face = kNone;
  std::size_t corner_list = kNone;  // property index within the face element

  std::size_t last() const { return face == kNone ? vertex : std::max(vertex, face); }
};

BodyPlan plan_body(const std::filesystem::path& path, const PlyHeader& header, bool faces) {
  BodyPlan plan;
  plan.vertex = find_element(header, "vertex");
  if (plan.vertex == kNone) fail(path, "no vertex element in the header");
  plan.layout = vertex_layout(path, header.elements[plan.vertex]);
  if (!faces) return plan;
  plan.face = find_element(header, "face");
  if (plan.face == kNone) fail(path, "no face element in the header (a point cloud, not a mesh)");
  const PlyElement& face = header.elements[plan.face];
  plan.corner_list = find_corner_list(face);
  if (plan.corner_list == kNone) {
    fail(path, "element 'face' has no property 'vertex_indices' (or 'vertex_index')");
  }
  const PlyProperty& list = face.properties[plan.corner_list];
  if (!list.is_list) {
    fail(path, "property '" + list.name + "' of element 'face' is not a list");
  }
  if (!detail::is_integer(list.type)) {
    fail(path, "property '" + list.name +
                   "' of element 'face' must hold integers (it is a list "
                   "of floating-point values)");
  }
  return plan;
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

// A corner index of any integer type (plan_body refuses the others). A uint64 beyond int64's range
// is out of range anyway, and kept so.
template <bool kSwap>
std::int64_t load_index(const char* p, ScalarType type) {
  return detail::visit_scalar(type, [&](auto t) -> std::int64_t {
    using T = decltype(t);
    if constexpr (std::is_floating_point_v<T>) {
      return -1;
    } else if constexpr (std::is_same_v<T, std::uint64_t>) {
      const T value = detail::load<T, kSwap>(p);
      return value > static_cast<T>(std::numeric_limits<std::int64_t>::max())
                 ? std::numeric_limits<std::int64_t>::max()
                 : static_cast<std::int64_t>(value);
    } else {
      return static_cast<std::int64_t>(detail::load<T, kSwap>(p));
    }
  });
}

// Reads `count` list items of `type` into `items`, as many at a time as the buffer holds.
template <bool kSwap, typename Truncated>
void load_items(detail::BlockReader& in, std::uint64_t count, ScalarType type,
                std::vector<std::int64_t>& items, const Truncated& truncated) {
  const std::size_t item_size = detail::scalar_size(type);
  const std::size_t batch = std::max<std::size_t>(1, in.capacity() / item_size);
  for (std::uint64_t left = count; left > 0;) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(left, batch));
    const std::string_view data = in.peek(n * item_size);
    if (data.size() < n * item_size) truncated();
    for (std::size_t j = 0; j < n; ++j) {
      items.push_back(load_index<kSwap>(data.data() + j * item_size, type));
    }
    in.consume(n * item_size);
    left -= n;
  }
}

// Reads one record of an element that has list properties, property by property, storing the
// value of property i in values[component[i]] when component[i] < 6. Lists are skipped unread, each
// count checked against what the file holds first, so a lying count is an error, never a long
// read; except the list of property `kept_list`, whose items go to `items` (a face's corners).
template <bool kSwap>
void walk_record(detail::BlockReader& in, const PlyElement& element, std::uint64_t record,
                 const std::vector<std::size_t>& component, std::array<double, 6>& values,
                 std::size_t kept_list = kNone, std::vector<std::int64_t>* items = nullptr) {
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
    if (i == kept_list) {
      items->clear();
      load_items<kSwap>(in, count, property.type, *items, truncated);
    } else if (in.skip(count * item_size) < count * item_size) {
      truncated();
    }
  }
}

// The number of bytes a record of `element` takes at least, after checking that the element's
// records can fit in what the file has left: a count the file cannot hold is refused before
// anything is allocated for it. `element` has properties.
std::size_t check_binary_count(detail::BlockReader& in, const PlyElement& element) {
  const std::size_t min_bytes = element.min_record_bytes();
  const std::uint64_t left = in.remaining();
  if (element.count > left / min_bytes) {
    fail(in.path(), "element '" + element.name + "' announces " + std::to_string(element.count) +
                        " records of " + (element.has_list() ? "at least " : "") +
                        std::to_string(min_bytes) + " bytes at byte offset " +
                        std::to_string(in.offset()) + ", but only " + std::to_string(left) +
                        " bytes remain (truncated file?)");
  }
  return min_bytes;
}

template <bool kSwap>
void skip_binary_element(detail::BlockReader& in, const PlyElement& element,
                         std::size_t min_bytes) {
  if (!element.has_list()) {
    const std::uint64_t bytes = element.count * min_bytes;
    if (in.skip(bytes) < bytes) {
      fail(in.path(), "truncated data at byte offset " + std::to_string(in.offset()) +
                          " (element '" + element.name + "')");
    }
    return;
  }
  const std::vector<std::size_t> component(element.properties.size(), 6);
  std::array<double, 6> unused{};
  for (std::uint64_t r = 0; r < element.count; ++r) {
    walk_record<kSwap>(in, element, r, component, unused);
  }
}

// The vertex element: sink.vertex(v) for each record, v holding x y z (nx ny nz) by component;
// records without lists go to sink.packed_vertices in bulk.
template <bool kSwap, typename Sink>
void read_binary_vertices(detail::BlockReader& in, const PlyElement& element,
                          const VertexLayout& layout, std::size_t min_bytes, Sink& sink) {
  const std::size_t components = layout.normals ? 6 : 3;
  sink.reserve_vertices(element.count);
  // A record longer than the buffer cannot be decoded from it; PLY headers are too short to
  // declare one (kMaxHeaderBytes), but walking it would still be right.
  if (!element.has_list() && min_bytes <= in.capacity()) {
    detail::RecordLayout records{min_bytes, {}, layout.normals};
    for (std::size_t k = 0; k < components; ++k) {
      for (std::size_t i = 0; i < layout.index[k]; ++i) {
        records.fields[k].offset += detail::scalar_size(element.properties[i].type);
      }
      records.fields[k].type = element.properties[layout.index[k]].type;
    }
    sink.template packed_vertices<kSwap>(in, element.count, records,
                                         "element '" + element.name + "'");
    return;
  }
  std::vector<std::size_t> component(element.properties.size(), 6);
  for (std::size_t k = 0; k < components; ++k) component[layout.index[k]] = k;
  std::array<double, 6> v{};
  for (std::uint64_t r = 0; r < element.count; ++r) {
    walk_record<kSwap>(in, element, r, component, v);
    sink.vertex(v);
  }
}

template <bool kSwap, typename Sink>
void read_binary(detail::BlockReader& in, const PlyHeader& header, const BodyPlan& plan,
                 Sink& sink) {
  std::vector<std::int64_t> corners;
  for (std::size_t e = 0; e <= plan.last(); ++e) {
    const PlyElement& element = header.elements[e];
    if (element.properties.empty()) continue;  // records of zero bytes
    const std::size_t min_bytes = check_binary_count(in, element);
    if (e == plan.vertex) {
      read_binary_vertices<kSwap>(in, element, plan.layout, min_bytes, sink);
      sink.vertices_done();
    } else if (e == plan.face) {
      sink.reserve_faces(element.count);
      const std::vector<std::size_t> component(element.properties.size(), 6);
      std::array<double, 6> unused{};
      for (std::uint64_t r = 0; r < element.count; ++r) {
        const detail::FaceLocation where{in.offset(), r};
        walk_record<kSwap>(in, element, r, component, unused, plan.corner_list, &corners);
        sink.face(corners, where);
      }
    } else {
      skip_binary_element<kSwap>(in, element, min_bytes);
    }
  }
}

// ---- ascii ----

// Parses one text record of `element` into `values` (by property; a list's values are checked and
// skipped, as are all values of elements other than the vertex), except the list of property
// `kept_list`, whose items (integers) go to `items`.
void parse_ascii_record(const std::filesystem::path& path, std::string_view line,
                        std::size_t number, const PlyElement& element, bool is_vertex,
                        std::vector<double>& values, std::size_t kept_list = kNone,
                        std::vector<std::int64_t>* items = nullptr) {
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
    if (i == kept_list) items->clear();
    for (auto k = static_cast<std::size_t>(number_value); k > 0; --k) {
      const std::size_t item_pos = pos;
      const std::string_view item = detail::next_token(line, pos, detail::kSpace);
      if (item.empty()) {
        fail(path, where() + "too few values for list '" + property.name + "' (announced " +
                       std::to_string(static_cast<std::size_t>(number_value)) + ")");
      }
      if (i != kept_list) continue;
      std::int64_t index = 0;
      const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), index);
      if (ec == std::errc::result_out_of_range) {
        index = item[0] == '-' ? std::numeric_limits<std::int64_t>::min()
                               : std::numeric_limits<std::int64_t>::max();
      } else if (ec != std::errc() || end != item.data() + item.size()) {
        pos = item_pos;
        bad("bad vertex index");
      }
      items->push_back(index);
    }
  }
  if (!detail::next_token(line, pos, detail::kSpace).empty()) {
    fail(path, where() + "too many values for element '" + element.name + "' (expected " +
                   std::to_string(element.properties.size()) + " properties)");
  }
}

template <typename Sink>
void read_ascii(detail::LineReader& lines, const PlyHeader& header, const BodyPlan& plan,
                Sink& sink) {
  const std::filesystem::path& path = lines.input().path();
  std::vector<double> values;
  std::vector<std::int64_t> corners;
  for (std::size_t e = 0; e <= plan.last(); ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = e == plan.vertex;
    const bool is_face = e == plan.face;
    if (element.properties.empty()) continue;
    if (is_vertex || is_face) {
      // Every value takes at least one character and one separator (the last line may lack its
      // newline, hence the + 1).
      const std::uint64_t left = lines.input().remaining();
      const std::size_t min_bytes = 2 * element.properties.size();
      if (element.count > (left + 1) / min_bytes) {
        fail(path, "element '" + element.name + "' announces " + std::to_string(element.count) +
                       " records, but the " + std::to_string(left) + " bytes after line " +
                       std::to_string(header.line_count) + " can hold at most " +
                       std::to_string((left + 1) / min_bytes) + " (truncated file?)");
      }
      if (is_vertex) {
        sink.reserve_vertices(element.count);
        values.resize(element.properties.size());
      } else {
        sink.reserve_faces(element.count);
      }
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
      if (is_face) {
        parse_ascii_record(path, line, lines.number(), element, false, values, plan.corner_list,
                           &corners);
        sink.face(corners, {lines.number(), r});
        continue;
      }
      parse_ascii_record(path, line, lines.number(), element, is_vertex, values);
      if (!is_vertex) continue;
      std::array<double, 6> v{};
      for (std::size_t k = 0; k < (plan.layout.normals ? 6u : 3u); ++k) {
        const std::size_t i = plan.layout.index[k];
        v[k] = detail::as_stored(values[i], element.properties[i].type);
      }
      sink.vertex(v);
    }
    if (is_vertex) sink.vertices_done();
  }
}

// ---- what the body goes to ----

// A point cloud: vertices only (plan.face is kNone, so face() is never called).
class CloudSink {
 public:
  CloudSink(CloudBuilder& builder, bool normals) : builder_(builder), normals_(normals) {}
  void reserve_vertices(std::uint64_t count) { builder_.reserve(static_cast<std::size_t>(count)); }
  void reserve_faces(std::uint64_t) {}
  void vertices_done() {}
  void vertex(const std::array<double, 6>& v) {
    if (normals_) {
      builder_.add(v[0], v[1], v[2], v[3], v[4], v[5]);
    } else {
      builder_.add(v[0], v[1], v[2]);
    }
  }
  template <bool kSwap>
  void packed_vertices(detail::BlockReader& in, std::uint64_t count,
                       const detail::RecordLayout& records, const std::string& what) {
    detail::decode_records<kSwap>(in, count, records, builder_, what);
  }
  void face(const std::vector<std::int64_t>&, const detail::FaceLocation&) {}

 private:
  CloudBuilder& builder_;
  bool normals_;
};

// A mesh: x y z and the faces' corners.
class MeshSink {
 public:
  explicit MeshSink(detail::MeshBuilder& builder) : builder_(builder) {}
  void reserve_vertices(std::uint64_t count) { builder_.reserve(count, 0); }
  void reserve_faces(std::uint64_t count) { builder_.reserve(0, count); }
  void vertices_done() { builder_.vertices_done(); }
  void vertex(const std::array<double, 6>& v) { builder_.add_vertex(v[0], v[1], v[2]); }
  // Records of fixed size, many decoded from the buffer at a time.
  template <bool kSwap>
  void packed_vertices(detail::BlockReader& in, std::uint64_t count,
                       const detail::RecordLayout& records, const std::string& what) {
    const std::size_t stride = records.stride;
    const auto& f = records.fields;
    for (std::uint64_t r = 0; r < count;) {
      const std::string_view data = in.peek(stride);
      if (data.size() < stride) {
        fail(in.path(),
             "truncated data at byte offset " + std::to_string(in.offset()) + " (" + what + ")");
      }
      const auto n =
          static_cast<std::size_t>(std::min<std::uint64_t>(count - r, data.size() / stride));
      for (std::size_t i = 0; i < n; ++i) {
        const char* record = data.data() + i * stride;
        builder_.add_vertex(detail::load_scalar<kSwap>(record + f[0].offset, f[0].type),
                            detail::load_scalar<kSwap>(record + f[1].offset, f[1].type),
                            detail::load_scalar<kSwap>(record + f[2].offset, f[2].type));
      }
      in.consume(n * stride);
      r += n;
    }
  }
  void face(const std::vector<std::int64_t>& corners, const detail::FaceLocation& where) {
    builder_.add_face(corners, where);
  }

 private:
  detail::MeshBuilder& builder_;
};

template <typename Sink>
void read_body(detail::LineReader& lines, const PlyHeader& header, const BodyPlan& plan,
               Sink& sink) {
  switch (header.format) {
    case PlyFormat::kAscii:
      read_ascii(lines, header, plan, sink);
      break;
    case PlyFormat::kBinaryLittleEndian:
      read_binary<detail::kHostIsBigEndian>(lines.input(), header, plan, sink);
      break;
    case PlyFormat::kBinaryBigEndian:
      read_binary<!detail::kHostIsBigEndian>(lines.input(), header, plan, sink);
      break;
  }
}

}  // namespace

namespace detail {

PointCloud read_ply(BlockReader& in, ReadInfo& info) {
  LineReader lines(in);
  const PlyHeader header = parse_ply_header(lines);
  const BodyPlan plan = plan_body(in.path(), header, false);
  CloudBuilder builder(in.path(), plan.layout.normals);
  CloudSink sink(builder, plan.layout.normals);
  read_body(lines, header, plan, sink);
  info.width = header.elements[plan.vertex].count;
  info.height = 1;
  PointCloud cloud = builder.finish();
  info.dropped_non_finite = builder.dropped();
  return cloud;
}

TriangleMesh read_ply_mesh(BlockReader& in, MeshReadInfo& info) {
  LineReader lines(in);
  const PlyHeader header = parse_ply_header(lines);
  const BodyPlan plan = plan_body(in.path(), header, true);
  const bool ascii = header.format == PlyFormat::kAscii;
  MeshBuilder builder(in.path(), [ascii](const FaceLocation& where) {
    return ascii ? "line " + std::to_string(where.position) + " (element 'face', record " +
                       std::to_string(where.face) + ")"
                 : "byte offset " + std::to_string(where.position) + " (element 'face', record " +
                       std::to_string(where.face) + ")";
  });
  MeshSink sink(builder);
  read_body(lines, header, plan, sink);
  info.format = "ply";
  info.dropped_faces = builder.dropped_faces();
  return builder.finish();
}

bool ply_declares_faces(BlockReader& in) {
  LineReader lines(in);
  const PlyHeader header = parse_ply_header(lines);
  const std::size_t face = find_element(header, "face");
  return face != kNone && header.elements[face].count > 0 &&
         find_corner_list(header.elements[face]) != kNone;
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

namespace detail {

void write_ply_mesh(const std::filesystem::path& path, const TriangleMesh& mesh) {
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment written by align3d\nelement vertex " +
      std::to_string(mesh.vertices.size()) +
      "\nproperty double x\nproperty double y\nproperty double z\nelement face " +
      std::to_string(mesh.triangles.size()) + "\nproperty list uchar uint vertex_indices\n" +
      "end_header\n";
  write_atomically(path, [&](std::ostream& out) {
    ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += header;
    for (const auto& v : mesh.vertices) {
      for (int k = 0; k < 3; ++k) append_bytes(buffer, v[k], kHostIsBigEndian);
      output.maybe_flush();
    }
    for (const auto& triangle : mesh.triangles) {
      buffer += '\x03';
      for (const std::uint32_t corner : triangle) append_bytes(buffer, corner, kHostIsBigEndian);
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace detail
}  // namespace align3d::io
