// Exact queries on a triangle mesh: the closest point on the surface, the signed distance and ray
// casting, through a bounding-volume hierarchy over the triangles (and, for points near the
// surface, a grid of candidate triangles). Built once per mesh; any number of threads may query it
// at once (every query is const and allocation-free).
//
// Closest point: the exact nearest point of the nearest triangle (Ericson, Real-Time Collision
// Detection 5.1.5), with the feature it lies on: the triangle's interior, one of its edges or one
// of its corners. Distances are true (not squared) unless the name says sq_.
//
// Sign (Bærentzen and Aanæs 2005, "Signed distance computation using the angle weighted
// pseudonormal"): a query point is outside the material when (q − c)·n > 0, where c is its closest
// point and n the pseudo-normal of the feature c lies on: the face normal inside a triangle, the
// sum of the two face normals on an edge, and on a corner the sum of the incident face normals
// weighted by their angles at it. For a closed, consistently wound mesh this is the right side
// everywhere, at sharp edges and corners too, where the face normal of the nearest triangle is
// not (a point beyond a convex corner lies "behind" two of its three faces). The mesh is cleaned
// first (clean_mesh, mesh.hpp); where it stays open or non-manifold the sign near the hole is a
// guess, which topology() lets the caller warn about.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

#include "align3d/mesh.hpp"

namespace align3d {

constexpr std::uint32_t kNoTriangle = std::numeric_limits<std::uint32_t>::max();

// Where on its triangle a closest point lies.
enum class MeshFeature : std::uint8_t {
  kFace,     // the interior
  kEdge0,    // edge a-b (corners 0-1), excluding its ends
  kEdge1,    // edge b-c
  kEdge2,    // edge c-a
  kVertex0,  // corner a
  kVertex1,  // corner b
  kVertex2,  // corner c
};
const char* to_string(MeshFeature f);

struct SurfacePoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // the closest point on the surface
  double sq_distance = std::numeric_limits<double>::infinity();
  std::uint32_t triangle =
      kNoTriangle;  // index into MeshIndex::mesh().triangles; none: kNoTriangle
  MeshFeature feature = MeshFeature::kFace;

  bool found() const { return triangle != kNoTriangle; }
};

struct RayHit {
  double t = std::numeric_limits<double>::infinity();  // origin + t·direction
  std::uint32_t triangle = kNoTriangle;
  double u = 0, v = 0;  // barycentric: point = (1 − u − v)·a + u·b + v·c
};

class MeshIndex {
 public:
  // Cleans a copy of the mesh (clean_mesh) and builds the hierarchy and the pseudo-normals.
  // Throws DataError(what, …) for a mesh that fails check_mesh or has no triangle of non-zero
  // area left. `threads`: for the build (0: all cores); the index does not depend on it.
  explicit MeshIndex(const TriangleMesh& mesh, int threads = 0, const std::string& what = "mesh");
  ~MeshIndex();
  MeshIndex(const MeshIndex&) = delete;
  MeshIndex& operator=(const MeshIndex&) = delete;

  const TriangleMesh& mesh() const;  // the cleaned mesh the queries refer to
  const MeshRepair& repair() const;
  const MeshTopology& topology() const;  // of the cleaned mesh
  double diagonal() const;               // bounding_box_diagonal of the mesh

  // The closest surface point to q closer than √sq_limit; false (and `out` untouched) when none.
  bool closest(const Eigen::Vector3d& q, SurfacePoint& out,
               double sq_limit = std::numeric_limits<double>::infinity()) const;

  // out[i] = the closest surface point to T·points[i] within `bound` (true distance; infinity: no
  // bound), not found() when none. Points are visited in their order, each search starting from
  // the previous point's triangle (the same exact answers, far less searching when consecutive
  // points are close: the callers keep theirs in spatial_order). Runs on `threads` threads (0: all
  // cores); the result does not depend on it.
  void closest_points(const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& T,
                      double bound, int threads, std::vector<SurfacePoint>& out) const;
  // The same searches visited in `order` (a permutation of the points' indices, such as
  // spatial_order(points), kdtree.hpp), each answer handed to sink(i, T·points[i], closest) instead
  // of stored (closest not found() when none): a caller writing its own per-point results needs
  // no array of SurfacePoints. The sink is called once per point, from up to `threads` threads at
  // once.
  using SurfaceSink = std::function<void(std::size_t, const Eigen::Vector3d&, const SurfacePoint&)>;
  void closest_points(const std::vector<Eigen::Vector3d>& points,
                      const std::vector<std::uint32_t>& order, const Eigen::Isometry3d& T,
                      double bound, int threads, const SurfaceSink& sink) const;
  // The same, the order chosen here: the points' own when it is already coherent (coherent_order),
  // spatial_order(points) otherwise. A scanner's raster needs no sort: the 2 M points of
  // bench/compare_inspect.py took 330–350 ms in their raster order, 400–430 ms sorted (the sort
  // itself 30 ms; the answers written in input order, not scattered).
  void closest_points(const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& T,
                      double bound, int threads, const SurfaceSink& sink) const;
  // Whether `points` are spatially coherent in their own order: the median step between
  // consecutive points (4 096 pairs spread over the input) is at most the candidate grid's cell,
  // so that consecutive searches start from the same or a neighbouring cell. A shuffled cloud's
  // steps are the object's size.
  bool coherent_order(const std::vector<Eigen::Vector3d>& points) const;

  // Unit normal of triangle t ((b − a) × (c − a) normalised).
  const Eigen::Vector3d& face_normal(std::uint32_t t) const;
  // The angle-weighted pseudo-normal of the feature p lies on (unit; see above).
  Eigen::Vector3d pseudo_normal(const SurfacePoint& p) const;
  // ±√sq_distance: + outside the material, − inside (see above); `q` is the query p answers.
  double signed_distance(const Eigen::Vector3d& q, const SurfacePoint& p) const;

  // The first triangle the ray origin + t·direction crosses with t_min < t < t_max (either side
  // of the triangle; the direction need not be unit length). False when none.
  bool intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, RayHit& hit,
                 double t_min = 0, double t_max = std::numeric_limits<double>::infinity()) const;

  // Bytes held by the index (mesh copy, hierarchy, grid, normals).
  std::size_t memory_bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace align3d
