// STL, binary and ASCII. Binary: an 80-byte header, a uint32 facet count n, then n records of 50
// bytes (a float32 normal, three float32 corners, a uint16 attribute), little-endian, so that the
// file has exactly 84 + 50·n bytes. ASCII: "solid name", then "facet normal ... / outer loop /
// vertex x y z (×3) / endloop / endfacet" blocks, then "endsolid name". Many binary exporters start
// their header with "solid" too, so the size decides first, the text only when the size does not
// fit.
#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "io_detail.hpp"
#include "mesh_readers.hpp"

namespace align3d::io {
namespace {

using detail::BlockReader;
using detail::FaceLocation;
using detail::fail;
using detail::MeshBuilder;
using detail::quoted;

constexpr std::size_t kHeaderBytes = 84;  // the 80-byte header and the facet count
constexpr std::size_t kFacetBytes = 50;
// Bytes looked at to tell a binary file from text: a binary header is 80 bytes, its first facet
// follows.
constexpr std::size_t kSniffBytes = 512;
// ASCII STL lines are short ("vertex" and three numbers); a longer one is binary data or garbage.
constexpr std::size_t kMaxLineBytes = std::size_t{64} << 10;

// Text starts with "solid" (after any blanks) and has no control bytes other than white space in
// its first kSniffBytes: binary floats and counts almost always contain some.
bool looks_like_text(std::string_view head) {
  const std::size_t first = head.find_first_not_of(" \t\r\n\v\f");
  if (first == std::string_view::npos || head.substr(first, 5) != "solid") return false;
  for (const char c : head) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && !detail::is_space(c) && c != '\n') || u == 0x7f) return false;
  }
  return true;
}

// STL's vertex indices are the reader's own (three per facet), so a non-finite corner is named by
// its place in the facet, not left to MeshBuilder, which would name the index. `facet()` gives the
// facet's location; called only on error, as a string per facet would cost more than the parse.
template <typename Facet>
void check_corners(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& corners,
                   const Facet& facet) {
  for (std::size_t k = 0; k < corners.size(); ++k) {
    if (!corners[k].allFinite()) {
      fail(path, facet() + ": corner " + std::to_string(k + 1) + " has a NaN or Inf coordinate");
    }
  }
}

TriangleMesh read_binary(BlockReader& in, std::uint64_t facets, MeshReadInfo& info) {
  const auto describe = [](const FaceLocation& where) {
    return "byte offset " + std::to_string(where.position) + " (facet " +
           std::to_string(where.face) + ")";
  };
  MeshBuilder builder(in.path(), describe);
  builder.reserve(3 * facets, facets);
  in.consume(kHeaderBytes);
  constexpr bool kSwap = detail::kHostIsBigEndian;
  std::array<std::int64_t, 3> corners{};
  std::vector<Eigen::Vector3d> points(3);
  for (std::uint64_t f = 0; f < facets;) {
    const std::string_view data = in.peek(kFacetBytes);
    if (data.size() < kFacetBytes) {  // the file shrank while being read
      fail(in.path(), "truncated data at byte offset " + std::to_string(in.offset()) + " (facet " +
                          std::to_string(f) + ")");
    }
    const auto n =
        static_cast<std::size_t>(std::min<std::uint64_t>(facets - f, data.size() / kFacetBytes));
    for (std::size_t i = 0; i < n; ++i) {
      const FaceLocation where{kHeaderBytes + kFacetBytes * (f + i), f + i};
      const char* corner = data.data() + i * kFacetBytes + 12;  // past the normal
      for (std::size_t k = 0; k < 3; ++k, corner += 12) {
        points[k] = {detail::load<float, kSwap>(corner), detail::load<float, kSwap>(corner + 4),
                     detail::load<float, kSwap>(corner + 8)};
        corners[k] = static_cast<std::int64_t>(3 * (f + i) + k);
      }
      check_corners(in.path(), points, [&] { return describe(where); });
      for (const auto& p : points) builder.add_vertex(p.x(), p.y(), p.z());
      builder.add_face(corners, where);
    }
    in.consume(n * kFacetBytes);
    f += n;
  }
  info.format = "stl-binary";
  info.dropped_faces = builder.dropped_faces();
  return builder.finish();
}

// Where the ASCII parser is: which keyword may come next.
enum class AsciiState { kOutside, kSolid, kFacet, kLoop, kLoopDone };

const char* expected(AsciiState state) {
  switch (state) {
    case AsciiState::kOutside:
      return "'solid'";
    case AsciiState::kSolid:
      return "'facet' or 'endsolid'";
    case AsciiState::kFacet:
      return "'outer loop'";
    case AsciiState::kLoop:
      return "'vertex' or 'endloop'";
    case AsciiState::kLoopDone:
      return "'endfacet'";
  }
  return "";
}

// The three numbers after "vertex".
std::array<double, 3> parse_vertex(const std::filesystem::path& path, std::string_view line,
                                   std::size_t pos, std::size_t number) {
  std::array<double, 3> xyz{};
  const auto where = [&] { return "line " + std::to_string(number) + ": "; };
  for (std::size_t k = 0; k < 3; ++k) {
    const auto token = detail::next_number(line, pos, detail::kSpace, xyz[k]);
    if (token == detail::Token::kEnd) {
      fail(path, where() + "expected 3 numbers after 'vertex', found " + std::to_string(k));
    }
    if (token == detail::Token::kNotANumber) {
      fail(path, where() + "bad number " + quoted(detail::next_token(line, pos, detail::kSpace)));
    }
  }
  if (!detail::next_token(line, pos, detail::kSpace).empty()) {
    fail(path, where() + "more than 3 numbers after 'vertex'");
  }
  return xyz;
}

TriangleMesh read_ascii(BlockReader& in, MeshReadInfo& info) {
  const std::filesystem::path& path = in.path();
  const auto describe = [](const FaceLocation& where) {
    return "line " + std::to_string(where.position) + " (facet " + std::to_string(where.face) + ")";
  };
  MeshBuilder builder(path, describe);
  detail::LineReader lines(in);
  AsciiState state = AsciiState::kOutside;
  std::vector<std::int64_t> corners;    // of the current facet's loop: a polygon, usually 3
  std::vector<Eigen::Vector3d> points;  // their coordinates
  FaceLocation facet;
  std::uint64_t facets = 0;
  std::string_view line;
  while (lines.next(line, kMaxLineBytes)) {
    detail::check_line_length(path, line, lines.number(), kMaxLineBytes);
    std::size_t pos = 0;
    const std::string_view keyword = detail::next_token(line, pos, detail::kSpace);
    if (keyword.empty()) continue;
    AsciiState next = state;
    if (keyword == "solid" && state == AsciiState::kOutside) {
      next = AsciiState::kSolid;  // the rest is the solid's name
    } else if (keyword == "endsolid" && state == AsciiState::kSolid) {
      next = AsciiState::kOutside;
    } else if (keyword == "facet" && state == AsciiState::kSolid) {
      next = AsciiState::kFacet;  // the normal is ignored: the winding decides (mesh.hpp)
      facet = {lines.number(), facets++};
    } else if (keyword == "outer" && state == AsciiState::kFacet &&
               detail::next_token(line, pos, detail::kSpace) == "loop") {
      next = AsciiState::kLoop;
    } else if (keyword == "vertex" && state == AsciiState::kLoop) {
      const auto xyz = parse_vertex(path, line, pos, lines.number());
      corners.push_back(static_cast<std::int64_t>(builder.vertex_count()));
      points.emplace_back(xyz[0], xyz[1], xyz[2]);
      builder.add_vertex(xyz[0], xyz[1], xyz[2]);
    } else if (keyword == "endloop" && state == AsciiState::kLoop) {
      next = AsciiState::kLoopDone;
    } else if (keyword == "endfacet" && state == AsciiState::kLoopDone) {
      next = AsciiState::kSolid;
      // A loop of fewer than 3 corners is dropped, its corners unused: they may be anything.
      if (corners.size() >= 3) check_corners(path, points, [&] { return describe(facet); });
      builder.add_face(corners, facet);
      corners.clear();
      points.clear();
    } else {
      fail(path, "line " + std::to_string(lines.number()) + ": unexpected " + quoted(keyword) +
                     " (expected " + expected(state) + ")");
    }
    state = next;
  }
  if (state != AsciiState::kOutside) {
    fail(path, "truncated file: it ends after line " + std::to_string(lines.number()) + ", where " +
                   expected(state) + " should follow");
  }
  info.format = "stl-ascii";
  info.dropped_faces = builder.dropped_faces();
  return builder.finish();
}

// Writes a float32, little-endian.
void put(std::string& out, double value) {
  detail::append_bytes(out, detail::to_float(value), detail::kHostIsBigEndian);
}

}  // namespace

namespace detail {

TriangleMesh read_stl(BlockReader& in, MeshReadInfo& info) {
  const std::uint64_t size = in.remaining();
  const std::string_view head = in.peek(std::min(kSniffBytes, in.capacity()));
  std::uint64_t facets = 0;
  if (head.size() >= kHeaderBytes) {
    facets = load<std::uint32_t, kHostIsBigEndian>(head.data() + 80);
    if (size == kHeaderBytes + kFacetBytes * facets) return read_binary(in, facets, info);
  }
  if (looks_like_text(head.substr(0, std::min(head.size(), kSniffBytes)))) {
    return read_ascii(in, info);
  }
  if (size < kHeaderBytes) {
    fail(in.path(), "not an STL file: " + std::to_string(size) +
                        " bytes are too few for binary STL (84 at least), and it is not ASCII "
                        "STL (which starts with 'solid')");
  }
  fail(in.path(),
       "binary STL announces " + std::to_string(facets) + " facets, which take 84 + 50 × " +
           std::to_string(facets) + " = " + std::to_string(kHeaderBytes + kFacetBytes * facets) +
           " bytes, but the file has " + std::to_string(size) + " (truncated, or not an STL file)");
}

void write_stl(const std::filesystem::path& path, const TriangleMesh& mesh) {
  if (mesh.triangles.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw OutputError(path,
                      "cannot write: binary STL holds at most 4294967295 triangles, the mesh "
                      "has " +
                          std::to_string(mesh.triangles.size()));
  }
  // float32 would turn a larger coordinate into Inf, which no reader accepts.
  constexpr double kMax = std::numeric_limits<float>::max();
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (!(mesh.vertices[i].cwiseAbs().maxCoeff() <= kMax)) {
      throw OutputError(path, "cannot write: vertex " + std::to_string(i) +
                                  " is not finite or beyond float32's range, which STL stores");
    }
  }
  write_atomically(path, [&](std::ostream& out) {
    detail::ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    // Not "solid ...": a binary header that starts so makes some readers take it for text.
    std::string header = "binary STL written by align3d";
    header.resize(80, ' ');
    buffer += header;
    detail::append_bytes(buffer, static_cast<std::uint32_t>(mesh.triangles.size()),
                         detail::kHostIsBigEndian);
    for (const auto& triangle : mesh.triangles) {
      const Eigen::Vector3d& a = mesh.vertices[triangle[0]];
      const Eigen::Vector3d& b = mesh.vertices[triangle[1]];
      const Eigen::Vector3d& c = mesh.vertices[triangle[2]];
      const Eigen::Vector3d normal = (b - a).cross(c - a).stableNormalized();
      for (const Eigen::Vector3d* v : {&normal, &a, &b, &c}) {
        for (int k = 0; k < 3; ++k) put(buffer, (*v)[k]);
      }
      buffer.append(2, '\0');  // the attribute byte count
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace detail
}  // namespace align3d::io
