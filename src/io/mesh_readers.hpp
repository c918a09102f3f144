// Private to src/io (not installed): the per-format triangle-mesh readers and writers behind
// mesh_io.hpp, and the builder that applies its reader contract. The readers take a BlockReader, so
// the fuzzers and tests run them on memory as well as on files (block_reader.hpp); they return what
// the file holds, an empty mesh included (read_mesh refuses that).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "align3d/io/mesh_io.hpp"
#include "align3d/mesh.hpp"
#include "block_reader.hpp"

namespace align3d::io::detail {

// Where a face was read: a line number (text) or a byte offset (binary), and the face's 1-based
// number among the file's faces. Formatted by the reader (MeshBuilder::Describe), only on error.
struct FaceLocation {
  std::uint64_t position = 0;
  std::uint64_t face = 0;
};

// Collects vertices and faces while parsing, and applies mesh_io.hpp's contract:
// - a face with fewer than 3 corners or a repeated corner index is dropped and counted;
// - a larger polygon is fanned from its first corner: (c0, ci, ci+1). Exact for convex polygons,
//   which is what exporters write; a concave one may get triangles outside it;
// - a corner index out of range, or a kept triangle using a vertex with a NaN or Inf coordinate, is
//   an IoError "<path>: <location>: <problem>";
// - vertices with a NaN or Inf coordinate that no triangle uses are removed at finish() (the others
//   renumbered), so that the mesh passes check_mesh (mesh.hpp).
// A face whose corners the reader has not reached yet (an OBJ or PLY file may list faces before
// their vertices) is checked at finish(), still naming its location.
class MeshBuilder {
 public:
  using Describe = std::function<std::string(const FaceLocation&)>;

  // `index_base` is added to indices shown in messages: 1 for OBJ, whose indices start at 1.
  MeshBuilder(const std::filesystem::path& path, Describe describe, std::uint64_t index_base = 0)
      : path_(path), describe_(std::move(describe)), index_base_(index_base) {}

  // Only call with counts already checked against the bytes the file holds. Running out of memory
  // is fail_out_of_memory.
  void reserve(std::uint64_t vertices, std::uint64_t triangles);

  void add_vertex(double x, double y, double z);
  std::size_t vertex_count() const { return mesh_.vertices.size(); }
  // No more vertices follow: faces are checked as they come rather than at finish().
  void vertices_done() { vertices_done_ = true; }

  // A face by its corners' 0-based vertex indices (a negative one is out of range).
  void add_face(std::span<const std::int64_t> corners, const FaceLocation& where);
  std::size_t dropped_faces() const { return dropped_faces_; }

  TriangleMesh finish();

 private:
  struct Pending {  // a face that refers to vertices not read yet
    FaceLocation where;
    std::int64_t largest = 0;  // its largest corner index
    std::size_t first_triangle = 0, triangles = 0;
  };
  [[noreturn]] void fail_at(const FaceLocation& where, const std::string& problem) const;
  bool is_finite(std::uint32_t vertex) const;
  void check_range(std::int64_t index, const FaceLocation& where) const;
  void check_finite(std::size_t first_triangle, std::size_t triangles,
                    const FaceLocation& where) const;

  const std::filesystem::path& path_;
  Describe describe_;
  std::uint64_t index_base_;
  TriangleMesh mesh_;
  std::vector<std::uint32_t> non_finite_;  // ascending indices of vertices with NaN or Inf
  std::vector<Pending> pending_;
  std::vector<std::int64_t> sorted_;  // scratch: the corners of a large face, sorted
  bool vertices_done_ = false;
  std::size_t dropped_faces_ = 0;
};

// The format readers, from the file's first byte; they fill `info` (format, dropped_faces).
TriangleMesh read_stl(BlockReader& in, MeshReadInfo& info);
TriangleMesh read_obj(BlockReader& in, MeshReadInfo& info);
TriangleMesh read_off(BlockReader& in, MeshReadInfo& info);
TriangleMesh read_ply_mesh(BlockReader& in, MeshReadInfo& info);

// Whether a PLY header declares a face element with at least one record and a vertex_indices (or
// vertex_index) list. Reads the header only; IoError if it is malformed.
bool ply_declares_faces(BlockReader& in);

// The writers (mesh_io.hpp's write_mesh), atomically. The mesh's indices must be in range.
void write_stl(const std::filesystem::path& path, const TriangleMesh& mesh);
void write_obj(const std::filesystem::path& path, const TriangleMesh& mesh);
void write_off(const std::filesystem::path& path, const TriangleMesh& mesh);
void write_ply_mesh(const std::filesystem::path& path, const TriangleMesh& mesh);

}  // namespace align3d::io::detail
