// Wavefront OBJ, the geometry statements of its polygonal subset: "v x y z [w]" (w, or the colour
// some exporters append, ignored) and "f c1 c2 c3 ..." whose corners are "v", "v/vt", "v//vn" or
// "v/vt/vn": v counts from 1 in file order, or, negative, back from the last vertex defined so far
// (-1 is the latest). Everything else (vt, vn, groups, materials, lines, curves) does not change
// the triangles and is skipped. A line ending in a backslash continues on the next; '#' starts a
// comment.
#include <array>
#include <charconv>
#include <string>
#include <vector>

#include "align3d/io/atomic_file.hpp"
#include "io_detail.hpp"
#include "mesh_readers.hpp"

namespace align3d::io {
namespace {

using detail::BlockReader;
using detail::FaceLocation;
using detail::fail;
using detail::line_prefix;
using detail::MeshBuilder;
using detail::quoted;

// A statement continued with trailing backslashes, joined into `joined` (separated by a space).
std::string_view join_continued(detail::LineReader& lines, std::string_view line,
                                std::string& joined) {
  const std::size_t first = lines.number();
  joined.assign(line.substr(0, line.size() - 1));
  while (lines.next(line, detail::kMaxRecordLineBytes)) {
    detail::check_line_length(lines.input().path(), line, lines.number(),
                              detail::kMaxRecordLineBytes);
    joined += ' ';
    const bool more = !line.empty() && line.back() == '\\';
    joined.append(line.substr(0, line.size() - (more ? 1 : 0)));
    if (joined.size() > detail::kMaxRecordLineBytes) {
      fail(lines.input().path(), line_prefix(first) + "statement continued past " +
                                     std::to_string(detail::kMaxRecordLineBytes) + " bytes");
    }
    if (!more) break;
  }
  return joined;
}

void parse_vertex(const std::filesystem::path& path, std::string_view line, std::size_t pos,
                  std::size_t number, MeshBuilder& builder) {
  std::array<double, 3> xyz{};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto token = detail::next_number(line, pos, detail::kSpace, xyz[k]);
    if (token == detail::Token::kEnd) {
      fail(path,
           line_prefix(number) + "expected 3 coordinates after 'v', found " + std::to_string(k));
    }
    if (token == detail::Token::kNotANumber) {
      fail(path, line_prefix(number) + "bad number " +
                     quoted(detail::next_token(line, pos, detail::kSpace)));
    }
  }
  builder.add_vertex(xyz[0], xyz[1], xyz[2]);
}

// The 0-based vertex index of corner `token` ("v", "v/vt", "v//vn", "v/vt/vn"); the texture and
// normal references are not needed and not checked.
std::int64_t parse_corner(const std::filesystem::path& path, std::string_view token,
                          std::size_t number, std::size_t vertices) {
  const std::string_view text = token.substr(0, token.find('/'));
  std::int64_t index = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), index);
  if (ec == std::errc::result_out_of_range) {
    fail(path, line_prefix(number) + "vertex index " + quoted(text) +
                   " out of range (the file has " + std::to_string(vertices) + " vertices so far)");
  }
  if (ec != std::errc() || end != text.data() + text.size()) {
    fail(path, line_prefix(number) + "bad face corner " + quoted(token));
  }
  if (index == 0) fail(path, line_prefix(number) + "vertex index 0 (OBJ counts from 1)");
  if (index > 0) return index - 1;  // checked against the whole file's vertices by the builder
  // Relative: -1 is the vertex defined last before this line.
  if (-index > static_cast<std::int64_t>(vertices)) {
    fail(path, line_prefix(number) + "relative vertex index " + std::to_string(index) +
                   " reaches before the first vertex (" + std::to_string(vertices) +
                   " vertices so far)");
  }
  return static_cast<std::int64_t>(vertices) + index;
}

}  // namespace

namespace detail {

TriangleMesh read_obj(BlockReader& in, MeshReadInfo& info) {
  const std::filesystem::path& path = in.path();
  MeshBuilder builder(
      path, [](const FaceLocation& where) { return "line " + std::to_string(where.position); }, 1);
  LineReader lines(in);
  std::vector<std::int64_t> corners;
  std::string joined;
  std::uint64_t faces = 0;
  std::string_view line;
  while (lines.next(line, kMaxRecordLineBytes)) {
    check_line_length(path, line, lines.number(), kMaxRecordLineBytes);
    const std::size_t number = lines.number();
    if (!line.empty() && line.back() == '\\') line = join_continued(lines, line, joined);
    line = line.substr(0, line.find('#'));
    std::size_t pos = 0;
    const std::string_view keyword = next_token(line, pos, kSpace);
    if (keyword == "v") {
      parse_vertex(path, line, pos, number, builder);
    } else if (keyword == "f" || keyword == "fo") {  // "fo": the old name of "f"
      corners.clear();
      for (auto token = next_token(line, pos, kSpace); !token.empty();
           token = next_token(line, pos, kSpace)) {
        corners.push_back(parse_corner(path, token, number, builder.vertex_count()));
      }
      builder.add_face(corners, {number, faces++});
    }
  }
  info.format = "obj";
  info.dropped_faces = builder.dropped_faces();
  return builder.finish();
}

void write_obj(const std::filesystem::path& path, const TriangleMesh& mesh) {
  write_atomically(path, [&](std::ostream& out) {
    ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += "# written by align3d\n";
    for (const auto& v : mesh.vertices) {
      buffer += 'v';
      for (int k = 0; k < 3; ++k) {
        buffer += ' ';
        append_general(buffer, v[k], 17);
      }
      buffer += '\n';
      output.maybe_flush();
    }
    for (const auto& triangle : mesh.triangles) {
      buffer += 'f';
      for (const std::uint32_t corner : triangle) {
        buffer += ' ';
        buffer += std::to_string(std::uint64_t{corner} + 1);
      }
      buffer += '\n';
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace detail
}  // namespace align3d::io
