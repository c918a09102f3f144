#include "align3d/io/mesh_io.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <stdexcept>
#include <string>

#include "align3d/error.hpp"
#include "cad_exchange.hpp"
#include "io_detail.hpp"
#include "mesh_readers.hpp"

namespace align3d::io {
namespace detail {

namespace {

// Triangles index vertices with 32 bits (mesh.hpp).
constexpr std::size_t kMaxVertices = std::numeric_limits<std::uint32_t>::max();

// Faces up to this many corners are checked for a repeated one pair by pair; larger ones (rare, but
// a hostile file can make one corner list as long as the file) are sorted instead.
constexpr std::size_t kPairwiseCorners = 8;

}  // namespace

void MeshBuilder::reserve(std::uint64_t vertices, std::uint64_t triangles) {
  try {
    mesh_.vertices.reserve(static_cast<std::size_t>(vertices));
    mesh_.triangles.reserve(static_cast<std::size_t>(triangles));
  } catch (const std::bad_alloc&) {
    const double bytes = static_cast<double>(vertices) * sizeof(Eigen::Vector3d) +
                         static_cast<double>(triangles) * sizeof(mesh_.triangles[0]);
    // PLY reserves each element as it reaches it: name only what was asked for.
    const std::string v = std::to_string(vertices) + " vertices";
    const std::string t = std::to_string(triangles) + " triangles";
    const std::string what = vertices == 0 ? t : triangles == 0 ? v : v + " and " + t;
    fail_out_of_memory(
        path_, what + " (" +
                   std::to_string(static_cast<std::uint64_t>(std::ceil(bytes / (1 << 20)))) +
                   " MiB)");
  }
}

void MeshBuilder::add_vertex(double x, double y, double z) {
  if (mesh_.vertices.size() == kMaxVertices) {
    fail(path_, "more than " + std::to_string(kMaxVertices) + " vertices (indices are 32-bit)");
  }
  if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
    non_finite_.push_back(static_cast<std::uint32_t>(mesh_.vertices.size()));
  }
  mesh_.vertices.emplace_back(x, y, z);
}

void MeshBuilder::fail_at(const FaceLocation& where, const std::string& problem) const {
  fail(path_, describe_(where) + ": " + problem);
}

bool MeshBuilder::is_finite(std::uint32_t vertex) const {
  return non_finite_.empty() || !std::binary_search(non_finite_.begin(), non_finite_.end(), vertex);
}

void MeshBuilder::check_range(std::int64_t index, const FaceLocation& where) const {
  if (index >= 0 && static_cast<std::uint64_t>(index) < mesh_.vertices.size()) return;
  // Shown as the file numbers it (OBJ from 1); a negative index can only come from a signed PLY
  // list and is shown as it is.
  const std::string shown = index < 0
                                ? std::to_string(index)
                                : std::to_string(static_cast<std::uint64_t>(index) + index_base_);
  fail_at(where, "vertex index " + shown + " out of range (the file has " +
                     std::to_string(mesh_.vertices.size()) + " vertices)");
}

void MeshBuilder::check_finite(std::size_t first_triangle, std::size_t triangles,
                               const FaceLocation& where) const {
  if (non_finite_.empty()) return;
  for (std::size_t t = first_triangle; t < first_triangle + triangles; ++t) {
    for (const std::uint32_t v : mesh_.triangles[t]) {
      if (!is_finite(v)) {
        fail_at(where, "vertex " + std::to_string(v + index_base_) +
                           " has a NaN or Inf coordinate and is used by a triangle");
      }
    }
  }
}

void MeshBuilder::add_face(std::span<const std::int64_t> corners, const FaceLocation& where) {
  // Range first: an index out of range is an error even in a face that is then dropped.
  std::int64_t largest = -1;
  for (const std::int64_t c : corners) {
    if (c < 0) check_range(c, where);
    largest = std::max(largest, c);
  }
  const bool ahead = largest >= static_cast<std::int64_t>(mesh_.vertices.size());
  if (ahead && vertices_done_) check_range(largest, where);

  bool repeated = false;
  if (corners.size() <= kPairwiseCorners) {
    for (std::size_t i = 0; i < corners.size() && !repeated; ++i) {
      repeated = std::find(corners.begin() + static_cast<std::ptrdiff_t>(i) + 1, corners.end(),
                           corners[i]) != corners.end();
    }
  } else {
    sorted_.assign(corners.begin(), corners.end());
    std::sort(sorted_.begin(), sorted_.end());
    repeated = std::adjacent_find(sorted_.begin(), sorted_.end()) != sorted_.end();
  }
  const std::size_t first = mesh_.triangles.size();
  if (repeated || corners.size() < 3) {
    ++dropped_faces_;
  } else {
    // Indices not yet known to be in range may be truncated here; finish() then fails on them.
    const auto c0 = static_cast<std::uint32_t>(corners[0]);
    for (std::size_t i = 1; i + 1 < corners.size(); ++i) {
      mesh_.triangles.push_back(
          {c0, static_cast<std::uint32_t>(corners[i]), static_cast<std::uint32_t>(corners[i + 1])});
    }
  }
  if (ahead) {
    pending_.push_back({where, largest, first, mesh_.triangles.size() - first});
  } else {
    check_finite(first, mesh_.triangles.size() - first, where);
  }
}

TriangleMesh MeshBuilder::finish() {
  for (const Pending& p : pending_) {
    check_range(p.largest, p.where);
    check_finite(p.first_triangle, p.triangles, p.where);
  }
  pending_ = {};
  if (!non_finite_.empty()) {
    // No triangle uses these (checked above and in add_face): remove them, so that every vertex of
    // the result is finite, and shift the indices above each one down.
    const auto shift = [&](std::uint32_t v) {
      return static_cast<std::uint32_t>(
          std::lower_bound(non_finite_.begin(), non_finite_.end(), v) - non_finite_.begin());
    };
    std::size_t kept = 0;
    for (std::size_t i = 0; i < mesh_.vertices.size(); ++i) {
      if (is_finite(static_cast<std::uint32_t>(i))) mesh_.vertices[kept++] = mesh_.vertices[i];
    }
    mesh_.vertices.resize(kept);
    for (auto& triangle : mesh_.triangles) {
      for (auto& v : triangle) v -= shift(v);
    }
    non_finite_ = {};
  }
  return std::move(mesh_);
}

}  // namespace detail

namespace {

using detail::lower_extension;

std::string shown_extension(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  return ext.empty() ? std::string("(no extension)") : "'" + ext + "'";
}

}  // namespace

std::optional<MeshFormat> mesh_format(const std::filesystem::path& path) {
  static constexpr std::pair<std::string_view, MeshFormat> kExtensions[] = {
      {".stl", MeshFormat::kStl},   {".obj", MeshFormat::kObj},   {".ply", MeshFormat::kPly},
      {".off", MeshFormat::kOff},   {".step", MeshFormat::kStep}, {".stp", MeshFormat::kStep},
      {".iges", MeshFormat::kIges}, {".igs", MeshFormat::kIges},
  };
  return detail::lookup(kExtensions, lower_extension(path));
}

bool has_cad_exchange() { return detail::occt_available(); }

bool is_mesh_file(const std::filesystem::path& path) {
  const std::optional<MeshFormat> format = mesh_format(path);
  if (!format) return false;
  switch (*format) {
    case MeshFormat::kStl:
    case MeshFormat::kObj:
    case MeshFormat::kOff:
      return true;
    case MeshFormat::kStep:
    case MeshFormat::kIges:
      return has_cad_exchange();
    case MeshFormat::kPly:
      break;
  }
  try {
    const auto file = detail::open_file(path, std::numeric_limits<std::uint64_t>::max());
    detail::BlockReader in(path, *file);
    return detail::ply_declares_faces(in);
  } catch (const Error&) {
    return false;  // the point-cloud reader, which reads the same header, says what is wrong
  }
}

TriangleMesh read_mesh(const std::filesystem::path& path, const MeshReadSettings& settings,
                       MeshReadInfo* info) {
  const std::optional<MeshFormat> format = mesh_format(path);
  if (!format) {
    detail::fail(path, "unknown mesh format " + shown_extension(path) +
                           " (expected .stl, .obj, .ply, .off, .step, .stp, .iges or .igs)");
  }
  MeshReadInfo read;
  TriangleMesh mesh;
  if (*format == MeshFormat::kStep || *format == MeshFormat::kIges) {
    mesh = detail::read_cad_exchange(path, *format, settings, read);
  } else {
    // No size limit: the file is streamed (block_reader.hpp), so only the mesh grows with it.
    const auto file = detail::open_file(path, std::numeric_limits<std::uint64_t>::max());
    detail::BlockReader in(path, *file);
    try {
      switch (*format) {
        case MeshFormat::kStl:
          mesh = detail::read_stl(in, read);
          break;
        case MeshFormat::kObj:
          mesh = detail::read_obj(in, read);
          break;
        case MeshFormat::kOff:
          mesh = detail::read_off(in, read);
          break;
        case MeshFormat::kPly:
          mesh = detail::read_ply_mesh(in, read);
          break;
        case MeshFormat::kStep:
        case MeshFormat::kIges:
          break;  // read above
      }
    } catch (const std::bad_alloc&) {
      // Allocations that a count announces are reported where they are made (MeshBuilder); this
      // catches the others: a text file's vertices and faces grow as they are read.
      detail::fail_out_of_memory(path,
                                 "the mesh read up to byte offset " + std::to_string(in.offset()));
    }
  }
  if (info != nullptr) *info = read;
  if (mesh.empty()) {
    const std::size_t dropped = read.dropped_faces;
    detail::fail(path, dropped == 0 ? std::string("contains no triangles")
                                    : "contains no triangles (all " + std::to_string(dropped) +
                                          " faces had fewer than 3 corners or a repeated corner)");
  }
  return mesh;
}

void write_mesh(const std::filesystem::path& path, const TriangleMesh& mesh) {
  const std::optional<MeshFormat> format = mesh_format(path);
  if (!format) {
    throw OutputError(path, "cannot write: unknown mesh format " + shown_extension(path) +
                                " (expected .stl, .obj, .ply or .off)");
  }
  // A bad index is the caller's bug, not the file's: refuse before anything is written.
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (const std::uint32_t v : mesh.triangles[t]) {
      if (v >= mesh.vertices.size()) {
        throw std::invalid_argument("write_mesh: triangle " + std::to_string(t) + " uses vertex " +
                                    std::to_string(v) + ", but the mesh has " +
                                    std::to_string(mesh.vertices.size()) + " vertices");
      }
    }
  }
  switch (*format) {
    case MeshFormat::kStl:
      return detail::write_stl(path, mesh);
    case MeshFormat::kObj:
      return detail::write_obj(path, mesh);
    case MeshFormat::kPly:
      return detail::write_ply_mesh(path, mesh);
    case MeshFormat::kOff:
      return detail::write_off(path, mesh);
    case MeshFormat::kStep:
    case MeshFormat::kIges:
      break;
  }
  throw OutputError(path,
                    "cannot write: align3d reads STEP and IGES but does not write them "
                    "(write .stl, .obj, .ply or .off)");
}

}  // namespace align3d::io
