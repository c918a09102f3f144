// The triangle mesh: a CAD model or a tessellated surface, in the caller's units (mm, m, ...).
//
// Winding: a triangle (a, b, c) faces the side its normal (b − a) × (c − a) points to, so a closed
// part whose triangles run counter-clockwise seen from outside has outward normals and a positive
// volume. Files do not always keep that promise (STL exporters mix windings, and STL repeats every
// vertex), so meshes are cleaned before use (clean_mesh): identical vertices welded, zero-area
// triangles dropped, each connected piece wound consistently and, when closed, outward.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // indices into vertices

  bool empty() const { return triangles.empty(); }
};

// T·mesh: vertices moved rigidly (T must be rigid, so windings keep their meaning).
TriangleMesh transformed(const TriangleMesh& mesh, const Eigen::Isometry3d& T);

// The axis-aligned bounding box of the vertices the triangles use (empty for no triangle), and its
// diagonal (0 for no triangle): the part's size, which the mesh defaults (chord tolerance,
// sampling, outlier distance) follow.
Eigen::AlignedBox3d bounding_box(const TriangleMesh& mesh);
double bounding_box_diagonal(const TriangleMesh& mesh);

double surface_area(const TriangleMesh& mesh);

// Throws DataError(what, …) when a vertex has a NaN or Inf coordinate, an index is out of range,
// or there is no triangle.
void check_mesh(const TriangleMesh& mesh, const std::string& what);

// How the triangles fit together, counted over undirected edges (two triangles share an edge when
// they share both its vertex indices: weld first, clean_mesh).
struct MeshTopology {
  std::size_t vertices = 0, triangles = 0;
  std::size_t boundary_edges = 0;      // used by one triangle: the surface is open there
  std::size_t non_manifold_edges = 0;  // used by three or more triangles
  // Used by two triangles that run along it in the same direction: their windings disagree, so at
  // least one of them faces the wrong way.
  std::size_t inconsistent_edges = 0;
  std::size_t components = 0;  // pieces connected through shared edges
  // Σ over triangles of a·(b × c) / 6: the enclosed volume when closed and outward (negative when
  // inward), meaningless when open.
  double signed_volume = 0;

  bool closed() const { return boundary_edges == 0 && non_manifold_edges == 0; }
};
MeshTopology analyse_topology(const TriangleMesh& mesh);

// For each triangle t and each of its edges k (corners k and k + 1 mod 3), the one other triangle
// that shares the edge, or UINT32_MAX when the edge is a boundary or non-manifold (shared by
// three or more triangles).
std::vector<std::array<std::uint32_t, 3>> edge_neighbours(const TriangleMesh& mesh);

// Both of the above from one pass over the edges (what MeshIndex needs), on `threads` threads (0:
// all cores; the result does not depend on it).
struct MeshAdjacency {
  MeshTopology topology;
  std::vector<std::array<std::uint32_t, 3>> neighbours;  // as edge_neighbours
};
MeshAdjacency analyse_adjacency(const TriangleMesh& mesh, int threads = 0);

// What clean_mesh changed.
struct MeshRepair {
  std::size_t welded_vertices = 0;      // vertices merged into an identical one
  std::size_t dropped_triangles = 0;    // zero area (two equal indices or collinear corners)
  std::size_t flipped_triangles = 0;    // re-wound to agree with their neighbours
  std::size_t inverted_components = 0;  // closed pieces turned outward (their volume was < 0)
  std::size_t inconsistent_edges = 0;   // of the welded input, before re-winding
};

// The mesh ready for distances and signs: vertices with identical coordinates welded (STL stores
// every triangle's corners apart), zero-area triangles and unused vertices dropped, and each piece
// connected through manifold edges wound like its largest-area triangle's neighbourhood by a
// breadth-first walk (the fewer triangles are flipped); a closed piece with negative volume is
// then flipped whole, so closed parts face outward. Open pieces keep the walk's winding (their
// outside is a guess; the caller warns). Deterministic. The input must pass check_mesh.
// `adjacency`, when given, receives analyse_adjacency of the cleaned mesh (found on the way).
// `threads`: 0 for all cores; the result does not depend on it.
TriangleMesh clean_mesh(const TriangleMesh& mesh, MeshRepair* repair = nullptr,
                        MeshAdjacency* adjacency = nullptr, int threads = 0);

// `count` points spread evenly by area over the triangles, each with its triangle's unit normal:
// every triangle gets ⌊its share⌋ or ⌈its share⌉ of the points (systematic sampling of the
// cumulative area, from a seeded offset), placed uniformly inside it. The same mesh, count and seed
// give the same points. Empty for count 0 or a mesh of zero area.
PointCloud sample_surface(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed = 1);

}  // namespace align3d
