// The hierarchy is our own, not Embree's or CGAL's AABB tree: bench/mesh_bench.cpp measures the
// three side by side on the same queries (bench/README.md). Embree's point query is the engine of
// Open3D's RaycastingScene (single precision, a callback per candidate); CGAL's tree works in
// exact-predicate kernels or Simple_cartesian<double> and carries no warm start. Ours answers in
// double precision, tests a leaf's triangles against a plane bound before the exact closest-point
// routine, and starts each search of a batch from the previous point's triangle.
#include "align3d/mesh_index.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>

#include "align3d/error.hpp"
#include "align3d/kdtree.hpp"
#include "detail/bvh_build.hpp"
#include "detail/candidate_grid.hpp"
#include "detail/parallel.hpp"
#include "detail/uninitialized.hpp"

namespace align3d {
namespace detail {

// A triangle as the queries use it, in leaf order. In a named namespace, not the anonymous one:
// MeshIndex::Impl holds them, and GCC warns of a member whose type has internal linkage once this
// file is not the main file, as in a unity build (-Wsubobject-linkage).
struct MeshIndexTriangle {
  Eigen::Vector3d a, ab, ac, normal;
  std::uint32_t index;  // in the cleaned mesh
};

}  // namespace detail
namespace {

constexpr std::uint32_t kLeafSize = 4;  // triangles per leaf at most (unless they cannot be split)
constexpr std::size_t kRun = 256;       // points a batch task walks in order (warm starts)
constexpr int kStack = detail::kMaxDepth + 1;  // query stacks: one entry per level at most

using Node = detail::BvhNode;
using Tri = detail::MeshIndexTriangle;

// A triangle's bounding box in float, rounded outwards (the grid's candidates are culled by it).
using TriBox = detail::BvhBox;

// The squared distance from q to box b (a node or a triangle's box): a lower bound of any distance
// to what b holds.
template <class B>
double sq_box_distance(const B& n, const Eigen::Vector3d& q) {
  double d = 0;
  for (int k = 0; k < 3; ++k) {
    const double below = static_cast<double>(n.lo[k]) - q[k];
    const double above = q[k] - static_cast<double>(n.hi[k]);
    const double e = std::max({below, above, 0.0});
    d += e * e;
  }
  return d;
}

// The closest point of triangle (a, a + ab, a + ac) to p and the feature it lies on: Ericson,
// Real-Time Collision Detection, 5.1.5, by Voronoi regions of the corners, edges and face.
MeshFeature closest_on_triangle(const Eigen::Vector3d& p, const Tri& t, Eigen::Vector3d& c) {
  const Eigen::Vector3d ap = p - t.a;
  const double d1 = t.ab.dot(ap), d2 = t.ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return c = t.a, MeshFeature::kVertex0;
  const Eigen::Vector3d bp = ap - t.ab;
  const double d3 = t.ab.dot(bp), d4 = t.ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return c = t.a + t.ab, MeshFeature::kVertex1;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return c = t.a + (d1 / (d1 - d3)) * t.ab, MeshFeature::kEdge0;
  const Eigen::Vector3d cp = ap - t.ac;
  const double d5 = t.ab.dot(cp), d6 = t.ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c = t.a + t.ac, MeshFeature::kVertex2;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return c = t.a + (d2 / (d2 - d6)) * t.ac, MeshFeature::kEdge2;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return c = t.a + t.ab + w * (t.ac - t.ab), MeshFeature::kEdge1;
  }
  const double denom = 1.0 / (va + vb + vc);
  c = t.a + (vb * denom) * t.ab + (vc * denom) * t.ac;
  return MeshFeature::kFace;
}

}  // namespace

struct MeshIndex::Impl {
  TriangleMesh mesh;
  MeshRepair repair;
  MeshTopology topology;
  double diagonal = 0;
  std::vector<Node> nodes;
  detail::UninitializedVector<Tri> tris;                     // leaf order
  detail::UninitializedVector<TriBox> tri_boxes;             // leaf order
  detail::UninitializedVector<std::uint32_t> leaf_position;  // mesh triangle → place in `tris`
  std::vector<Eigen::Vector3d> face_normals;                 // mesh order
  std::vector<std::array<std::uint32_t, 3>> neighbours;      // across each edge (analyse_adjacency)
  std::vector<Eigen::Vector3d> vertex_normals;               // angle-weighted
  detail::CandidateGrid grid;                                // lists positions in `tris`

  std::vector<std::uint32_t> build(int threads);  // returns the leaf order (tris → mesh)
  void compute_pseudo_normals(int threads);
  Eigen::Vector3d edge_normal(std::uint32_t t, int k) const;
  void test(const Eigen::Vector3d& q, const Tri& t, SurfacePoint& best) const;
  void test_cell(const Eigen::Vector3d& q, std::span<const std::uint32_t> cell,
                 SurfacePoint& best) const;
  void search(const Eigen::Vector3d& q, SurfacePoint& best) const;
  void nearest(const Eigen::Vector3d& q, SurfacePoint& best, std::uint32_t hint) const;

  // The batch queries: the k-th point visited is points[index_of(k)]; runs of kRun visited
  // points go to a thread each, every search warm from the previous answer of its run.
  template <class IndexOf, class Sink>
  void batch(std::size_t n, IndexOf&& index_of, const std::vector<Eigen::Vector3d>& points,
             const Eigen::Isometry3d& T, double bound, int threads, Sink&& sink) const {
    const double sq_bound = std::isfinite(bound) ? bound * bound * (1 + 1e-12)
                                                 : std::numeric_limits<double>::infinity();
    parallel_tasks((n + kRun - 1) / kRun, threads, [&](std::size_t run) {
      std::uint32_t previous = kNoTriangle;
      const std::size_t end = std::min(n, (run + 1) * kRun);
      for (std::size_t k = run * kRun; k < end; ++k) {
        const std::size_t i = index_of(k);
        const Eigen::Vector3d q = T * points[i];
        SurfacePoint best;
        best.sq_distance = sq_bound;
        nearest(q, best, previous);
        if (!best.found()) best.sq_distance = std::numeric_limits<double>::infinity();
        sink(i, q, best);
        if (best.found()) previous = best.triangle;
      }
    });
  }
};

// The hint (the previous query's triangle) first, for a tight bound; then the grid's candidates:
// when they hold an answer within the grid's reach it is exact (candidate_grid.hpp), and so is
// "none" when the limit is within the reach. Otherwise the hierarchy, bounded by what was found
// so far.
void MeshIndex::Impl::nearest(const Eigen::Vector3d& q, SurfacePoint& best,
                              std::uint32_t hint) const {
  if (hint != kNoTriangle) test(q, tris[leaf_position[hint]], best);  // a tight bound first
  std::span<const std::uint32_t> cell;
  if (grid.candidates(q, cell)) {
    test_cell(q, cell, best);
    if (best.sq_distance <= grid.reach() * grid.reach()) return;
  }
  search(q, best);
}

void MeshIndex::Impl::test(const Eigen::Vector3d& q, const Tri& t, SurfacePoint& best) const {
  const double plane = t.normal.dot(q - t.a);  // the plane's distance bounds the triangle's
  if (plane * plane > best.sq_distance) return;
  Eigen::Vector3d c;
  const MeshFeature f = closest_on_triangle(q, t, c);
  const double sq = (q - c).squaredNorm();
  // The lexicographic minimum of (distance, triangle): the answer does not depend on the order
  // triangles are tested in (warm starts, threads).
  if (sq < best.sq_distance ||
      (sq == best.sq_distance && best.found() && t.index < best.triangle)) {
    best.point = c;
    best.sq_distance = sq;
    best.triangle = t.index;
    best.feature = f;
  }
}

// A cell's candidates lie side by side on the surface, nearly in one plane, so their planes rarely
// rule them out; their boxes do: a triangle whose box lies farther than the best answer cannot
// hold a closer point (strictly farther, so that ties are still compared).
void MeshIndex::Impl::test_cell(const Eigen::Vector3d& q, std::span<const std::uint32_t> cell,
                                SurfacePoint& best) const {
  for (std::uint32_t i : cell)
    if (sq_box_distance(tri_boxes[i], q) <= best.sq_distance) test(q, tris[i], best);
}

// Depth-first, nearer child first; a subtree is skipped when its box lies farther than the best
// answer so far (strictly, so that ties are still compared).
void MeshIndex::Impl::search(const Eigen::Vector3d& q, SurfacePoint& best) const {
  std::uint32_t stack[kStack];
  int top = 0;
  if (sq_box_distance(nodes[0], q) > best.sq_distance) return;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes[stack[--top]];
    if (n.count > 0) {
      for (std::uint32_t i = n.first; i < n.first + n.count; ++i) test(q, tris[i], best);
      continue;
    }
    const double dl = sq_box_distance(nodes[n.first], q);
    const double dr = sq_box_distance(nodes[n.first + 1], q);
    const bool left_first = dl <= dr;
    const double d_near = left_first ? dl : dr, d_far = left_first ? dr : dl;
    // Re-checked when popped: the best answer may have improved meanwhile.
    if (d_far <= best.sq_distance) stack[top++] = n.first + (left_first ? 1 : 0);
    if (d_near <= best.sq_distance) stack[top++] = n.first + (left_first ? 0 : 1);
  }
}

std::vector<std::uint32_t> MeshIndex::Impl::build(int threads) {
  const std::size_t n = mesh.triangles.size();
  detail::UninitializedVector<TriBox> boxes(n);  // mesh order
  parallel_for(n, threads, [&](std::size_t t) {
    const auto& f = mesh.triangles[t];
    const Eigen::Vector3d lo =
        mesh.vertices[f[0]].cwiseMin(mesh.vertices[f[1]]).cwiseMin(mesh.vertices[f[2]]);
    const Eigen::Vector3d hi =
        mesh.vertices[f[0]].cwiseMax(mesh.vertices[f[1]]).cwiseMax(mesh.vertices[f[2]]);
    for (int k = 0; k < 3; ++k) {
      boxes[t].lo[k] = detail::round_down(lo[k]);
      boxes[t].hi[k] = detail::round_up(hi[k]);
    }
  });
  detail::Bvh bvh = detail::build_bvh(boxes, kLeafSize, threads);
  nodes = std::move(bvh.nodes);
  const std::vector<std::uint32_t>& order = bvh.order;
  tris.resize(n);
  tri_boxes.resize(n);
  leaf_position.resize(n);
  parallel_for(n, threads, [&](std::size_t i) {
    const auto& f = mesh.triangles[order[i]];
    const Eigen::Vector3d& a = mesh.vertices[f[0]];
    tris[i] = {a, mesh.vertices[f[1]] - a, mesh.vertices[f[2]] - a, face_normals[order[i]],
               order[i]};
    tri_boxes[i] = boxes[order[i]];
    leaf_position[order[i]] = static_cast<std::uint32_t>(i);
  });
  return std::move(bvh.order);
}

// Face normals and vertex pseudo-normals, Σ αᵢ nᵢ over the incident faces with αᵢ the face's
// angle at the vertex (Bærentzen and Aanæs 2005, eq. 2). Edge pseudo-normals are found when asked
// (edge_normal): stored, they were 72 bytes a triangle, for one lookup a query.
void MeshIndex::Impl::compute_pseudo_normals(int threads) {
  const std::size_t n = mesh.triangles.size();
  face_normals.resize(n);
  detail::UninitializedVector<std::array<double, 3>> angles(n);  // each corner's angle
  parallel_for(n, threads, [&](std::size_t t) {
    const auto& f = mesh.triangles[t];
    const std::array<Eigen::Vector3d, 3> p = {mesh.vertices[f[0]], mesh.vertices[f[1]],
                                              mesh.vertices[f[2]]};
    face_normals[t] = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
      angles[t][k] = std::atan2(u.cross(v).norm(), u.dot(v));
    }
  });
  vertex_normals.assign(mesh.vertices.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t < n; ++t)  // in triangle order: the same sums at any thread count
    for (int k = 0; k < 3; ++k)
      vertex_normals[mesh.triangles[t][k]] += angles[t][k] * face_normals[t];
  for (Eigen::Vector3d& v : vertex_normals)
    if (v.squaredNorm() > 0) v.normalize();
}

// The sum of the two faces' normals (a boundary or non-manifold edge takes its own face's).
Eigen::Vector3d MeshIndex::Impl::edge_normal(std::uint32_t t, int k) const {
  const std::uint32_t o = neighbours[t][k];
  Eigen::Vector3d e = face_normals[t];
  if (o != kNoTriangle) e += face_normals[o];
  // Two faces folded flat onto each other have no edge normal; the face's own stands in.
  return e.squaredNorm() > 1e-24 ? e.normalized() : face_normals[t];
}

const char* to_string(MeshFeature f) {
  switch (f) {
    case MeshFeature::kFace:
      return "face";
    case MeshFeature::kEdge0:
    case MeshFeature::kEdge1:
    case MeshFeature::kEdge2:
      return "edge";
    case MeshFeature::kVertex0:
    case MeshFeature::kVertex1:
    case MeshFeature::kVertex2:
      return "vertex";
  }
  return "?";
}

MeshIndex::MeshIndex(const TriangleMesh& mesh, int threads, const std::string& what)
    : impl_(std::make_unique<Impl>()) {
  check_mesh(mesh, what);
  MeshAdjacency adjacency;
  impl_->mesh = clean_mesh(mesh, &impl_->repair, &adjacency, threads);
  if (impl_->mesh.triangles.empty())
    throw DataError(what, "no triangle of non-zero area (all " +
                              std::to_string(mesh.triangles.size()) + " are degenerate)");
  impl_->topology = adjacency.topology;
  const Eigen::AlignedBox3d box = bounding_box(impl_->mesh);  // the mesh is not empty
  impl_->diagonal = box.diagonal().norm();
  impl_->neighbours = std::move(adjacency.neighbours);
  impl_->compute_pseudo_normals(threads);
  const std::vector<std::uint32_t> order = impl_->build(threads);
  impl_->grid = detail::CandidateGrid(impl_->mesh, order, box, surface_area(impl_->mesh), threads);
}

MeshIndex::~MeshIndex() = default;

const TriangleMesh& MeshIndex::mesh() const { return impl_->mesh; }
const MeshRepair& MeshIndex::repair() const { return impl_->repair; }
const MeshTopology& MeshIndex::topology() const { return impl_->topology; }
double MeshIndex::diagonal() const { return impl_->diagonal; }

bool MeshIndex::closest(const Eigen::Vector3d& q, SurfacePoint& out, double sq_limit) const {
  SurfacePoint best;
  best.sq_distance = sq_limit;
  impl_->nearest(q, best, kNoTriangle);
  if (!best.found()) return false;
  out = best;
  return true;
}

void MeshIndex::closest_points(const std::vector<Eigen::Vector3d>& points,
                               const Eigen::Isometry3d& T, double bound, int threads,
                               std::vector<SurfacePoint>& out) const {
  out.resize(points.size());
  impl_->batch(
      points.size(), [](std::size_t k) { return k; }, points, T, bound, threads,
      [&](std::size_t i, const Eigen::Vector3d&, const SurfacePoint& p) { out[i] = p; });
}

void MeshIndex::closest_points(const std::vector<Eigen::Vector3d>& points,
                               const std::vector<std::uint32_t>& order, const Eigen::Isometry3d& T,
                               double bound, int threads, const SurfaceSink& sink) const {
  if (order.size() != points.size())
    throw std::invalid_argument("MeshIndex::closest_points: the order has " +
                                std::to_string(order.size()) + " indices for " +
                                std::to_string(points.size()) + " points");
  impl_->batch(
      points.size(), [&](std::size_t k) { return std::size_t{order[k]}; }, points, T, bound,
      threads, sink);
}

void MeshIndex::closest_points(const std::vector<Eigen::Vector3d>& points,
                               const Eigen::Isometry3d& T, double bound, int threads,
                               const SurfaceSink& sink) const {
  if (coherent_order(points)) {
    impl_->batch(
        points.size(), [](std::size_t k) { return k; }, points, T, bound, threads, sink);
  } else {
    closest_points(points, spatial_order(points, threads), T, bound, threads, sink);
  }
}

bool MeshIndex::coherent_order(const std::vector<Eigen::Vector3d>& points) const {
  constexpr std::size_t kPairs = 4096;
  if (impl_->grid.empty() || points.size() < 2) return points.size() < 2;
  const std::size_t pairs = std::min(kPairs, points.size() - 1);
  std::vector<double> step;  // NaN coordinates give NaN steps: not coherent
  step.reserve(pairs);
  for (std::size_t k = 0; k < pairs; ++k) {
    const std::size_t i = k * (points.size() - 1) / pairs;
    const double d = (points[i + 1] - points[i]).norm();
    step.push_back(std::isnan(d) ? std::numeric_limits<double>::infinity() : d);
  }
  std::nth_element(step.begin(), step.begin() + pairs / 2, step.end());
  return step[pairs / 2] <= impl_->grid.cell();
}

const Eigen::Vector3d& MeshIndex::face_normal(std::uint32_t t) const {
  return impl_->face_normals[t];
}

Eigen::Vector3d MeshIndex::pseudo_normal(const SurfacePoint& p) const {
  const auto& f = impl_->mesh.triangles[p.triangle];
  switch (p.feature) {
    case MeshFeature::kFace:
      return impl_->face_normals[p.triangle];
    case MeshFeature::kEdge0:
    case MeshFeature::kEdge1:
    case MeshFeature::kEdge2:
      return impl_->edge_normal(p.triangle, static_cast<int>(p.feature) - 1);
    default:
      return impl_->vertex_normals[f[static_cast<int>(p.feature) - 4]];
  }
}

double MeshIndex::signed_distance(const Eigen::Vector3d& q, const SurfacePoint& p) const {
  const double d = std::sqrt(p.sq_distance);
  return (q - p.point).dot(pseudo_normal(p)) < 0 ? -d : d;
}

bool MeshIndex::intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                          RayHit& hit, double t_min, double t_max) const {
  const Impl& m = *impl_;
  const Eigen::Vector3d inv = direction.cwiseInverse();
  // Slab test of a node's box: the ray's parameter interval inside it, clipped to (t_min, best).
  auto enter = [&](const Node& n, double t_far) {
    double t0 = t_min, t1 = t_far;
    for (int k = 0; k < 3; ++k) {
      double a = (static_cast<double>(n.lo[k]) - origin[k]) * inv[k];
      double b = (static_cast<double>(n.hi[k]) - origin[k]) * inv[k];
      if (a > b) std::swap(a, b);
      if (std::isnan(a)) a = -std::numeric_limits<double>::infinity();  // 0·inf: inside the slab
      if (std::isnan(b)) b = std::numeric_limits<double>::infinity();
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    }
    return t0 <= t1 ? t0 : std::numeric_limits<double>::infinity();
  };
  RayHit best;
  best.t = t_max;
  std::uint32_t stack[kStack];
  int top = 0;
  if (enter(m.nodes[0], best.t) == std::numeric_limits<double>::infinity()) return false;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = m.nodes[stack[--top]];
    if (enter(n, best.t) == std::numeric_limits<double>::infinity()) continue;
    if (n.count > 0) {
      // Möller and Trumbore 1997; either side of the triangle counts.
      for (std::uint32_t i = n.first; i < n.first + n.count; ++i) {
        const Tri& t = m.tris[i];
        const Eigen::Vector3d pv = direction.cross(t.ac);
        const double det = t.ab.dot(pv);
        if (det == 0) continue;
        const double inv_det = 1.0 / det;
        const Eigen::Vector3d tv = origin - t.a;
        const double u = tv.dot(pv) * inv_det;
        if (u < 0 || u > 1) continue;
        const Eigen::Vector3d qv = tv.cross(t.ab);
        const double v = direction.dot(qv) * inv_det;
        if (v < 0 || u + v > 1) continue;
        const double s = t.ac.dot(qv) * inv_det;
        if (s > t_min && (s < best.t || (s == best.t && t.index < best.triangle)))
          best = {s, t.index, u, v};
      }
      continue;
    }
    const double tl = enter(m.nodes[n.first], best.t);
    const double tr = enter(m.nodes[n.first + 1], best.t);
    const bool left_first = tl <= tr;
    const double t_near = left_first ? tl : tr, t_far = left_first ? tr : tl;
    if (t_far != std::numeric_limits<double>::infinity())
      stack[top++] = n.first + (left_first ? 1 : 0);
    if (t_near != std::numeric_limits<double>::infinity())
      stack[top++] = n.first + (left_first ? 0 : 1);
  }
  if (best.triangle == kNoTriangle) return false;
  hit = best;
  return true;
}

std::size_t MeshIndex::memory_bytes() const {
  const Impl& m = *impl_;
  return sizeof(Impl) + m.mesh.vertices.capacity() * sizeof(Eigen::Vector3d) +
         m.mesh.triangles.capacity() * sizeof(m.mesh.triangles[0]) +
         m.nodes.capacity() * sizeof(Node) + m.tris.capacity() * sizeof(Tri) +
         m.tri_boxes.capacity() * sizeof(TriBox) +
         m.leaf_position.capacity() * sizeof(std::uint32_t) +
         (m.face_normals.capacity() + m.vertex_normals.capacity()) * sizeof(Eigen::Vector3d) +
         m.neighbours.capacity() * sizeof(m.neighbours[0]) + m.grid.memory_bytes();
}

}  // namespace align3d
