// OFF (Geomview's "Object File Format"), text only: a header keyword [ST][C][N]OFF (optional in
// the format; the prefixes announce texture coordinates, colours and normals after each vertex's
// x y z, which are ignored), the counts "vertices faces edges" (on the keyword's line or the next),
// one vertex per line, then one face per line: its corner count k, k 0-based vertex indices and an
// optional colour (ignored). '#' starts a comment; blank lines are skipped.
#include <charconv>
#include <string>
#include <vector>

#include "align3d/io/atomic_file.hpp"
#include "io_detail.hpp"
#include "mesh_readers.hpp"

namespace align3d::io {
namespace {

using detail::fail;
using detail::line_prefix;
using detail::LineReader;
using detail::quoted;

// The next line that holds data, its comment cut off; false at the end of the file.
bool next_data(LineReader& lines, std::string_view& line) {
  while (lines.next(line, detail::kMaxRecordLineBytes)) {
    detail::check_line_length(lines.input().path(), line, lines.number(),
                              detail::kMaxRecordLineBytes);
    line = line.substr(0, line.find('#'));
    if (!detail::is_blank(line)) return true;
  }
  return false;
}

// Refuses a header keyword other than [ST][C][N]OFF.
void check_keyword(const std::filesystem::path& path, std::string_view keyword,
                   std::size_t number) {
  std::string_view rest = keyword;
  for (const std::string_view prefix : {"ST", "C", "N"}) {
    if (rest.starts_with(prefix)) rest.remove_prefix(prefix.size());
  }
  if (rest.starts_with("4") || rest.starts_with("n")) {
    fail(path, line_prefix(number) + quoted(keyword) + ": only 3-dimensional OFF is supported");
  }
  if (rest != "OFF") {
    fail(path, "not an OFF file (line " + std::to_string(number) + " starts with " +
                   quoted(keyword) + ", not OFF, COFF or NOFF)");
  }
}

struct OffCounts {
  std::uint64_t vertices = 0, faces = 0;
  std::size_t line = 0;  // where they were read
};

OffCounts parse_off_header(LineReader& lines) {
  const std::filesystem::path& path = lines.input().path();
  std::string_view line;
  if (!next_data(lines, line)) fail(path, "not an OFF file (it holds no header)");
  std::size_t pos = 0;
  const std::string_view keyword = detail::next_token(line, pos, detail::kSpace);
  std::uint64_t unused = 0;
  if (detail::parse_u64(keyword, unused)) {
    pos = 0;  // no keyword: the counts come first
  } else {
    check_keyword(path, keyword, lines.number());
    std::size_t peek = pos;
    if (detail::next_token(line, peek, detail::kSpace) == "BINARY") {
      fail(path, line_prefix(lines.number()) + "binary OFF is not supported (only text OFF)");
    }
    if (detail::is_blank(line.substr(pos))) {
      if (!next_data(lines, line)) fail(path, "the file ends before the OFF counts");
      pos = 0;
    }
  }
  OffCounts counts;
  counts.line = lines.number();
  for (std::uint64_t* count : {&counts.vertices, &counts.faces}) {
    const std::string_view token = detail::next_token(line, pos, detail::kSpace);
    if (!detail::parse_u64(token, *count)) {
      fail(path, line_prefix(counts.line) + "expected the counts 'vertices faces edges', found " +
                     quoted(token));
    }
  }
  return counts;  // the edge count, if any, is not needed
}

// The integer after `line`'s position `pos`; what it is is named in errors.
std::int64_t parse_integer(const std::filesystem::path& path, std::string_view line,
                           std::size_t& pos, std::size_t number, const std::string& what) {
  const std::string_view token = detail::next_token(line, pos, detail::kSpace);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec == std::errc::result_out_of_range) {
    fail(path, line_prefix(number) + what + " " + quoted(token) + " out of range");
  }
  if (token.empty() || ec != std::errc() || end != token.data() + token.size()) {
    fail(path, line_prefix(number) + "bad " + what + " " + quoted(token));
  }
  return value;
}

void read_vertices(LineReader& lines, std::uint64_t count, detail::MeshBuilder& builder) {
  const std::filesystem::path& path = lines.input().path();
  std::string_view line;
  for (std::uint64_t i = 0; i < count; ++i) {
    if (!next_data(lines, line)) {
      fail(path, "truncated file: the header announces " + std::to_string(count) +
                     " vertices, the file ends after " + std::to_string(i));
    }
    std::array<double, 3> xyz{};
    std::size_t pos = 0;
    for (std::size_t k = 0; k < 3; ++k) {
      const auto token = detail::next_number(line, pos, detail::kSpace, xyz[k]);
      if (token == detail::Token::kEnd) {
        fail(path,
             line_prefix(lines.number()) + "expected 3 coordinates, found " + std::to_string(k));
      }
      if (token == detail::Token::kNotANumber) {
        fail(path, line_prefix(lines.number()) + "bad number " +
                       quoted(detail::next_token(line, pos, detail::kSpace)));
      }
    }
    builder.add_vertex(xyz[0], xyz[1], xyz[2]);  // colours or normals after x y z are ignored
  }
  builder.vertices_done();
}

void read_faces(LineReader& lines, std::uint64_t count, detail::MeshBuilder& builder) {
  const std::filesystem::path& path = lines.input().path();
  std::vector<std::int64_t> corners;
  std::string_view line;
  for (std::uint64_t f = 0; f < count; ++f) {
    if (!next_data(lines, line)) {
      fail(path, "truncated file: the header announces " + std::to_string(count) +
                     " faces, the file ends after " + std::to_string(f));
    }
    std::size_t pos = 0;
    const std::int64_t corner_count =
        parse_integer(path, line, pos, lines.number(), "corner count");
    if (corner_count < 0) {
      fail(path,
           line_prefix(lines.number()) + "negative corner count " + std::to_string(corner_count));
    }
    corners.clear();
    for (std::int64_t k = 0; k < corner_count; ++k) {
      if (detail::is_blank(line.substr(pos))) {
        fail(path, line_prefix(lines.number()) + "the face announces " +
                       std::to_string(corner_count) + " corners, the line holds " +
                       std::to_string(k));
      }
      corners.push_back(parse_integer(path, line, pos, lines.number(), "vertex index"));
    }
    builder.add_face(corners, {lines.number(), f});  // a colour after the corners is ignored
  }
}

}  // namespace

namespace detail {

TriangleMesh read_off(BlockReader& in, MeshReadInfo& info) {
  const std::filesystem::path& path = in.path();
  LineReader lines(in);
  const OffCounts counts = parse_off_header(lines);
  // A vertex line takes 6 bytes at least ("0 0 0\n"), a face line 2 ("0\n"); the last line may lack
  // its newline, hence the + 1.
  const std::uint64_t left = in.remaining() + 1;
  if (counts.vertices > left / 6 || counts.faces > (left - 6 * counts.vertices) / 2) {
    fail(path, line_prefix(counts.line) + "announces " + std::to_string(counts.vertices) +
                   " vertices and " + std::to_string(counts.faces) + " faces, but the " +
                   std::to_string(in.remaining()) +
                   " bytes after it cannot hold them (truncated file?)");
  }
  MeshBuilder builder(
      path, [](const FaceLocation& where) { return "line " + std::to_string(where.position); });
  builder.reserve(counts.vertices, counts.faces);
  read_vertices(lines, counts.vertices, builder);
  read_faces(lines, counts.faces, builder);
  info.format = "off";
  info.dropped_faces = builder.dropped_faces();
  return builder.finish();
}

void write_off(const std::filesystem::path& path, const TriangleMesh& mesh) {
  write_atomically(path, [&](std::ostream& out) {
    ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += "OFF\n# written by align3d\n" + std::to_string(mesh.vertices.size()) + " " +
              std::to_string(mesh.triangles.size()) + " 0\n";
    for (const auto& v : mesh.vertices) {
      for (int k = 0; k < 3; ++k) {
        append_general(buffer, v[k], 17);
        buffer += k < 2 ? ' ' : '\n';
      }
      output.maybe_flush();
    }
    for (const auto& triangle : mesh.triangles) {
      buffer += '3';
      for (const std::uint32_t corner : triangle) {
        buffer += ' ';
        buffer += std::to_string(corner);
      }
      buffer += '\n';
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace detail
}  // namespace align3d::io
