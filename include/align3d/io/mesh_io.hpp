// Reading and writing triangle meshes (CAD models). The format is chosen by the file extension
// (case-insensitive):
//   .stl              binary or ASCII, told apart by content: binary when the size is exactly
//                     84 + 50 × the header's facet count, else ASCII if it starts with "solid" and
//                     holds no binary bytes ("solid" alone proves nothing: many binary headers
//                     start with it). Every facet's corners, normals ignored (the winding decides,
//                     mesh.hpp); several solids in one file are read one after the other
//   .obj              Wavefront: v x y z [w] and f with 1-based, negative (relative) and v/vt/vn
//                     indices; faces may precede their vertices; '\' continues a line; other
//                     statements (vt, vn, g, usemtl, l, ...) skipped
//   .ply              a vertex element (x y z) and a face element (vertex_indices or vertex_index,
//                     any integer list count and index type), ascii or binary of either byte order,
//                     in any element order
//   .off              text OFF (also COFF, NOFF, STOFF headers, or none): counts, one vertex per
//                     line (extra values ignored), one face per line (a trailing colour ignored)
//   .step .stp .iges .igs  through OpenCASCADE when align3d was built with ALIGN3D_OCCT (every
//                     solid and face of the file, in millimetres converted from the file's own
//                     unit, tessellated to MeshReadSettings' chord tolerance; read in a child
//                     process, so that OpenCASCADE crashing on a corrupted file is an IoError,
//                     not the caller's end); without it an IoError says so
// Any other extension is an IoError.
//
// Contract, as for the point readers (point_cloud_io.hpp): a missing, unreadable, malformed or
// truncated file throws IoError "<path>: <problem>" naming the line (text) or byte offset (binary);
// counts a header announces are checked against the file's size before anything is allocated; an
// index out of range, a non-finite vertex used by a triangle, or a file with no triangle is an
// IoError too. Running out of memory is a DataError naming the file. A polygon of n > 3 corners is
// fanned into the n − 2 triangles (c0, ci, ci+1), right for the convex polygons exporters write; a
// face with fewer than 3 corners or a repeated corner index is dropped and counted
// (MeshReadInfo::dropped_faces). Vertices are returned as the file has them (STL: three per facet,
// unwelded; clean_mesh welds), except that non-finite vertices no triangle uses are removed (the
// others renumbered), so that the result passes check_mesh; triangles come in file order.
// Text coordinates are read as float64, except PLY float properties (rounded to float32, as the
// binary file would hold them).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "align3d/mesh.hpp"

namespace align3d::io {

struct MeshReadSettings {
  // STEP/IGES: the largest distance between the tessellation and the exact surface (data units);
  // 0: kDefaultChordFraction × the model's bounding-box diagonal. Angular deflection is
  // kAngularDeflection radians either way.
  double chord_tolerance = 0;
};
inline constexpr double kDefaultChordFraction = 1e-4;
inline constexpr double kAngularDeflection = 0.2;

struct MeshReadInfo {
  std::string format;             // "stl-binary", "stl-ascii", "obj", "ply", "off", "step", "iges"
  double chord_tolerance = 0;     // STEP/IGES: the tolerance used (data units); 0 otherwise
  std::size_t dropped_faces = 0;  // faces with fewer than 3 corners or a repeated corner
};

enum class MeshFormat { kStl, kObj, kPly, kOff, kStep, kIges };
// The mesh format that `path`'s extension names, or nullopt.
std::optional<MeshFormat> mesh_format(const std::filesystem::path& path);

// Whether align3d can read a mesh from `path`: its extension is .stl .obj .off (whether or not the
// file exists: the reader then says what is wrong), .step .stp .iges .igs with OCCT, or .ply and
// the file's header declares a face element with at least one face and a vertex_indices (or
// vertex_index) list. For .ply it reads the header only, and is false when the file cannot be
// opened or its header is malformed (the point-cloud reader then says why).
bool is_mesh_file(const std::filesystem::path& path);

// Whether this build reads STEP and IGES (ALIGN3D_OCCT).
bool has_cad_exchange();

TriangleMesh read_mesh(const std::filesystem::path& path, const MeshReadSettings& settings = {},
                       MeshReadInfo* info = nullptr);

// Writes by extension, atomically (OutputError on failure; nothing left at the destination):
// .stl binary (float32 corners and facet normals; a coordinate beyond float32's range is an
// OutputError), .ply binary little-endian (float64 vertices, uchar-counted uint32 face lists),
// .obj, .off (%.17g, which reads back to the same doubles). STEP, IGES and unknown extensions are
// an OutputError. An index out of range is std::invalid_argument (a bug in the caller), before
// anything is written.
void write_mesh(const std::filesystem::path& path, const TriangleMesh& mesh);

}  // namespace align3d::io
