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
#include <numeric>
#include <span>

#include "align3d/error.hpp"
#include "detail/candidate_grid.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr std::uint32_t kLeafSize = 4;  // triangles per leaf at most (unless they cannot be split)
constexpr int kBins = 16;               // SAH bins per axis
constexpr std::size_t kRun = 256;       // points a batch task walks in order (warm starts)
constexpr int kSahDepth = 64;           // deeper ranges are halved by count (build_node)
constexpr int kStack = 128;             // > the deepest tree, kSahDepth + 32

// A node's box in float, rounded outwards, so it still contains its triangles: 24 bytes instead
// of 48, and every lower bound computed from it stays a lower bound.
struct Node {
  float lo[3], hi[3];
  std::uint32_t first;  // leaf: first triangle (leaf order); internal: left child (right = +1)
  std::uint32_t count;  // leaf: its triangles; 0: internal
};

// A triangle as the queries use it, in leaf order.
struct Tri {
  Eigen::Vector3d a, ab, ac, normal;
  Eigen::Vector3d centre;  // of a sphere holding the triangle: the centroid,
  double radius;           // and the distance to its farthest corner
  std::uint32_t index;     // in the cleaned mesh
};

struct Box {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  void grow(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void grow(const Box& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  double half_area() const {
    if (!(hi.x() >= lo.x())) return 0;
    const Eigen::Vector3d d = hi - lo;
    return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
  }
};

float round_down(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) <= v ? f : std::nextafter(f, -std::numeric_limits<float>::max());
}
float round_up(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) >= v ? f : std::nextafter(f, std::numeric_limits<float>::max());
}

double sq_box_distance(const Node& n, const Eigen::Vector3d& q) {
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
  std::vector<Tri> tris;                        // leaf order
  std::vector<std::uint32_t> leaf_position;     // mesh triangle → its place in `tris`
  std::vector<Eigen::Vector3d> face_normals;    // mesh order
  std::vector<Eigen::Vector3d> edge_normals;    // 3 per triangle, mesh order
  std::vector<Eigen::Vector3d> vertex_normals;  // angle-weighted
  detail::CandidateGrid grid;                   // lists positions in `tris`

  void build();
  void build_node(std::uint32_t node, std::uint32_t begin, std::uint32_t end, int depth,
                  std::vector<std::uint32_t>& order, const std::vector<Box>& boxes,
                  const std::vector<Eigen::Vector3d>& centres);
  void compute_pseudo_normals();
  void test(const Eigen::Vector3d& q, const Tri& t, SurfacePoint& best) const;
  void test_cell(const Eigen::Vector3d& q, std::span<const std::uint32_t> cell,
                 SurfacePoint& best) const;
  void search(const Eigen::Vector3d& q, SurfacePoint& best) const;
  void nearest(const Eigen::Vector3d& q, SurfacePoint& best, std::uint32_t hint) const;
};

// The grid's candidates first: when they hold an answer within the grid's reach it is exact
// (candidate_grid.hpp), and so is "none" when the limit is within the reach. Otherwise the hint
// (the previous query's triangle) and the hierarchy, bounded by what was found so far.
void MeshIndex::Impl::nearest(const Eigen::Vector3d& q, SurfacePoint& best,
                              std::uint32_t hint) const {
  std::span<const std::uint32_t> cell;
  if (grid.candidates(q, cell)) {
    if (hint != kNoTriangle) test(q, tris[leaf_position[hint]], best);  // a tight bound first
    test_cell(q, cell, best);
    if (best.sq_distance <= grid.reach() * grid.reach()) return;
  }
  if (hint != kNoTriangle) test(q, tris[leaf_position[hint]], best);
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
// rule them out; the spheres around them do: a triangle whose sphere is farther than the best
// answer cannot hold a closer point.
void MeshIndex::Impl::test_cell(const Eigen::Vector3d& q, std::span<const std::uint32_t> cell,
                                SurfacePoint& best) const {
  double limit = std::sqrt(best.sq_distance);
  for (std::uint32_t i : cell) {
    const Tri& t = tris[i];
    const double reach = t.radius + limit;
    if ((q - t.centre).squaredNorm() > reach * reach) continue;
    const std::uint32_t before = best.triangle;
    test(q, t, best);
    if (best.triangle != before) limit = std::sqrt(best.sq_distance);
  }
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

void MeshIndex::Impl::build() {
  const std::size_t n = mesh.triangles.size();
  std::vector<Box> boxes(n);
  std::vector<Eigen::Vector3d> centres(n);
  for (std::size_t t = 0; t < n; ++t) {
    for (std::uint32_t v : mesh.triangles[t]) boxes[t].grow(mesh.vertices[v]);
    centres[t] = 0.5 * (boxes[t].lo + boxes[t].hi);
  }
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  nodes.reserve(2 * n / kLeafSize + 2);
  nodes.push_back({});
  build_node(0, 0, static_cast<std::uint32_t>(n), 0, order, boxes, centres);
  tris.resize(n);
  leaf_position.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const auto& f = mesh.triangles[order[i]];
    const Eigen::Vector3d& a = mesh.vertices[f[0]];
    const Eigen::Vector3d& b = mesh.vertices[f[1]];
    const Eigen::Vector3d& c = mesh.vertices[f[2]];
    const Eigen::Vector3d centre = (a + b + c) / 3;
    const double radius =
        std::sqrt(std::max(
            {(a - centre).squaredNorm(), (b - centre).squaredNorm(), (c - centre).squaredNorm()})) *
        (1 + 1e-12);
    tris[i] = {a, b - a, c - a, face_normals[order[i]], centre, radius, order[i]};
    leaf_position[order[i]] = i;
  }
}

// Binned surface-area heuristic (Wald 2007) over the centres, on all three axes; a range whose
// centres coincide, or any range below kSahDepth, is cut in the middle of the list, so the tree is
// at most kSahDepth + 32 deep and the queries' fixed stacks (kStack) cannot overflow.
void MeshIndex::Impl::build_node(std::uint32_t node, std::uint32_t begin, std::uint32_t end,
                                 int depth, std::vector<std::uint32_t>& order,
                                 const std::vector<Box>& boxes,
                                 const std::vector<Eigen::Vector3d>& centres) {
  Box box, centre_box;
  for (std::uint32_t i = begin; i < end; ++i) {
    box.grow(boxes[order[i]]);
    centre_box.grow(centres[order[i]]);
  }
  for (int k = 0; k < 3; ++k) {
    nodes[node].lo[k] = round_down(box.lo[k]);
    nodes[node].hi[k] = round_up(box.hi[k]);
  }
  const std::uint32_t count = end - begin;
  if (count <= kLeafSize) {
    nodes[node].first = begin;
    nodes[node].count = count;
    return;
  }
  double best_cost = std::numeric_limits<double>::infinity();
  int best_axis = -1, best_split = 0;
  for (int axis = 0; axis < 3 && depth < kSahDepth; ++axis) {
    const double lo = centre_box.lo[axis], extent = centre_box.hi[axis] - lo;
    if (!(extent > 0)) continue;
    std::array<Box, kBins> bin_box;
    std::array<std::uint32_t, kBins> bin_count{};
    auto bin_of = [&](std::uint32_t t) {
      return std::min(kBins - 1, static_cast<int>(kBins * (centres[t][axis] - lo) / extent));
    };
    for (std::uint32_t i = begin; i < end; ++i) {
      const int b = bin_of(order[i]);
      bin_box[b].grow(boxes[order[i]]);
      ++bin_count[b];
    }
    std::array<double, kBins> right_cost{};
    Box right;
    std::uint32_t right_n = 0;
    for (int b = kBins - 1; b > 0; --b) {
      right.grow(bin_box[b]);
      right_n += bin_count[b];
      right_cost[b] = right.half_area() * right_n;
    }
    Box left;
    std::uint32_t left_n = 0;
    for (int b = 0; b < kBins - 1; ++b) {
      left.grow(bin_box[b]);
      left_n += bin_count[b];
      const double cost = left.half_area() * left_n + right_cost[b + 1];
      if (left_n > 0 && left_n < count && cost < best_cost) {
        best_cost = cost;
        best_axis = axis;
        best_split = b;
      }
    }
  }
  std::uint32_t mid;
  if (best_axis < 0) {  // by count, along the centres' longest axis
    mid = begin + count / 2;
    Eigen::Index axis = 0;
    (centre_box.hi - centre_box.lo).maxCoeff(&axis);
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](std::uint32_t a, std::uint32_t b) {
                       return centres[a][axis] < centres[b][axis] ||
                              (centres[a][axis] == centres[b][axis] && a < b);
                     });
  } else {
    const double lo = centre_box.lo[best_axis];
    const double extent = centre_box.hi[best_axis] - lo;
    auto* split = std::partition(order.data() + begin, order.data() + end, [&](std::uint32_t t) {
      return std::min(kBins - 1, static_cast<int>(kBins * (centres[t][best_axis] - lo) / extent)) <=
             best_split;
    });
    mid = static_cast<std::uint32_t>(split - order.data());
  }
  const auto left = static_cast<std::uint32_t>(nodes.size());
  nodes.push_back({});
  nodes.push_back({});
  nodes[node].first = left;
  nodes[node].count = 0;
  build_node(left, begin, mid, depth + 1, order, boxes, centres);
  build_node(left + 1, mid, end, depth + 1, order, boxes, centres);
}

// Face normals; edge pseudo-normals, the sum of the two faces' normals (a boundary or
// non-manifold edge takes its own face's); vertex pseudo-normals, Σ αᵢ nᵢ over the incident faces
// with αᵢ the face's angle at the vertex (Bærentzen and Aanæs 2005, eq. 2).
void MeshIndex::Impl::compute_pseudo_normals() {
  const std::size_t n = mesh.triangles.size();
  face_normals.resize(n);
  vertex_normals.assign(mesh.vertices.size(), Eigen::Vector3d::Zero());
  for (std::size_t t = 0; t < n; ++t) {
    const auto& f = mesh.triangles[t];
    std::array<Eigen::Vector3d, 3> p = {mesh.vertices[f[0]], mesh.vertices[f[1]],
                                        mesh.vertices[f[2]]};
    face_normals[t] = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d u = p[(k + 1) % 3] - p[k], v = p[(k + 2) % 3] - p[k];
      const double angle = std::atan2(u.cross(v).norm(), u.dot(v));
      vertex_normals[f[k]] += angle * face_normals[t];
    }
  }
  for (Eigen::Vector3d& v : vertex_normals)
    if (v.squaredNorm() > 0) v.normalize();
  const std::vector<std::array<std::uint32_t, 3>> neighbour = edge_neighbours(mesh);
  edge_normals.resize(3 * n);
  for (std::size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t o = neighbour[t][k];
      Eigen::Vector3d e = face_normals[t];
      if (o != kNoTriangle) e += face_normals[o];
      // Two faces folded flat onto each other have no edge normal; the face's own stands in.
      edge_normals[3 * t + k] = e.squaredNorm() > 1e-24 ? e.normalized() : face_normals[t];
    }
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
  impl_->mesh = clean_mesh(mesh, &impl_->repair);
  if (impl_->mesh.triangles.empty())
    throw DataError(what, "no triangle of non-zero area (all " +
                              std::to_string(mesh.triangles.size()) + " are degenerate)");
  impl_->topology = analyse_topology(impl_->mesh);
  impl_->diagonal = bounding_box_diagonal(impl_->mesh);
  impl_->compute_pseudo_normals();
  impl_->build();
  std::vector<Eigen::Vector3d> a, b, c;
  for (const Tri& t : impl_->tris) {
    a.push_back(t.a);
    b.push_back(t.a + t.ab);
    c.push_back(t.a + t.ac);
  }
  impl_->grid = detail::CandidateGrid(a, b, c, surface_area(impl_->mesh), threads);
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
  const std::size_t n = points.size();
  out.resize(n);
  const double sq_bound =
      std::isfinite(bound) ? bound * bound * (1 + 1e-12) : std::numeric_limits<double>::infinity();
  const Impl& m = *impl_;
  parallel_tasks((n + kRun - 1) / kRun, threads, [&](std::size_t run) {
    std::uint32_t previous = kNoTriangle;
    const std::size_t end = std::min(n, (run + 1) * kRun);
    for (std::size_t i = run * kRun; i < end; ++i) {
      const Eigen::Vector3d q = T * points[i];
      SurfacePoint best;
      best.sq_distance = sq_bound;
      m.nearest(q, best, previous);
      if (!best.found()) best.sq_distance = std::numeric_limits<double>::infinity();
      out[i] = best;
      if (best.found()) previous = best.triangle;
    }
  });
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
      return impl_->edge_normals[3 * p.triangle + (static_cast<int>(p.feature) - 1)];
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
         m.leaf_position.capacity() * sizeof(std::uint32_t) +
         (m.face_normals.capacity() + m.edge_normals.capacity() + m.vertex_normals.capacity()) *
             sizeof(Eigen::Vector3d) +
         m.grid.memory_bytes();
}

}  // namespace align3d
