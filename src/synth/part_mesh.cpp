// The machined part of synth/part.hpp: validation, the CAD mesh (faces assembled from quads and
// ear-clipped planar faces with holes), the membership oracle and the feature list.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "align3d/synth/part.hpp"

namespace align3d::synth {
namespace {

constexpr double kMargin = 1;  // mm between features, and from features to the top's edge
constexpr std::size_t kMaxTriangles = 100'000'000;

// A vertex of a planar face in the face's plane (x, y), with its index in the mesh.
struct Point2 {
  Eigen::Vector2d p;
  std::uint32_t id;
};
using Loop = std::vector<Point2>;

// Twice the signed area of triangle abc: > 0 when a, b, c turn counter-clockwise.
double orient(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// p inside triangle abc or on its boundary (either winding).
bool in_triangle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                 const Eigen::Vector2d& p) {
  const double d1 = orient(a, b, p), d2 = orient(b, c, p), d3 = orient(c, a, p);
  const bool negative = std::min({d1, d2, d3}) < 0;
  const bool positive = std::max({d1, d2, d3}) > 0;
  return !(negative && positive);
}

// Whether direction d from vertex v points into the polygon's interior, the polygon running
// counter-clockwise u → v → w (interior on the left): between v→w and v→u, turning
// counter-clockwise.
bool in_wedge(const Eigen::Vector2d& u, const Eigen::Vector2d& v, const Eigen::Vector2d& w,
              const Eigen::Vector2d& d) {
  const Eigen::Vector2d e1 = w - v, e2 = u - v;
  if (cross(e1, e2) > 0) return cross(e1, d) > 0 && cross(d, e2) > 0;  // convex corner
  return cross(e1, d) > 0 || cross(d, e2) > 0;                         // reflex corner
}

// The vertex of `poly` (counter-clockwise) that m, a hole's rightmost vertex, can be joined to by
// a segment crossing no edge (Eberly 2008, "Triangulation by ear clipping", section 3): cast a ray
// from m along +x, take the nearest edge it hits and that edge's endpoint P of larger x; a reflex
// vertex inside the triangle (m, hit, P) would block the view, and the one of them closest in
// angle to the ray is visible instead. A vertex repeated by an earlier bridge is taken at the
// occurrence whose interior wedge faces m, so the bridges do not cross.
std::size_t bridge_vertex(const Loop& poly, const Eigen::Vector2d& m) {
  const std::size_t n = poly.size();
  double hit_x = std::numeric_limits<double>::infinity();
  std::size_t edge = n;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = poly[i].p;
    const Eigen::Vector2d& b = poly[(i + 1) % n].p;
    if (a.y() == b.y() || m.y() < std::min(a.y(), b.y()) || m.y() > std::max(a.y(), b.y()))
      continue;  // horizontal edges are met at their neighbours' endpoints
    const double x = a.x() + (m.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
    if (x >= m.x() && x < hit_x) {
      hit_x = x;
      edge = i;
    }
  }
  if (edge == n) throw std::logic_error("part mesh: a hole lies outside its face");
  const Eigen::Vector2d hit(hit_x, m.y());
  const Eigen::Vector2d& a = poly[edge].p;
  const Eigen::Vector2d& b = poly[(edge + 1) % n].p;
  Eigen::Vector2d target = (b == hit || (a != hit && b.x() > a.x())) ? b : a;
  if (target != hit) {
    double best_cos = -2, best_distance = 0;
    const Eigen::Vector2d blocked = target;
    for (std::size_t j = 0; j < n; ++j) {
      const Eigen::Vector2d& r = poly[j].p;
      if (r == blocked || orient(poly[(j + n - 1) % n].p, r, poly[(j + 1) % n].p) >= 0 ||
          !in_triangle(m, hit, blocked, r))
        continue;
      const double distance = (r - m).norm(), c = (r.x() - m.x()) / distance;
      if (c > best_cos || (c == best_cos && distance < best_distance)) {
        best_cos = c;
        best_distance = distance;
        target = r;
      }
    }
  }
  std::size_t first = n;
  for (std::size_t j = 0; j < n; ++j) {
    if (poly[j].p != target) continue;
    if (first == n) first = j;
    if (in_wedge(poly[(j + n - 1) % n].p, target, poly[(j + 1) % n].p, m - target)) return j;
  }
  return first;
}

// One counter-clockwise, weakly simple polygon: `outer` (counter-clockwise) with each hole
// (clockwise) spliced in through a bridge edge walked both ways, holes taken in order of their
// rightmost x, largest first (Eberly 2008, section 5).
Loop bridge_holes(Loop outer, std::vector<Loop> holes) {
  auto rightmost = [](const Loop& loop) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < loop.size(); ++i) {
      const Eigen::Vector2d &p = loop[i].p, &q = loop[best].p;
      if (p.x() > q.x() || (p.x() == q.x() && p.y() > q.y())) best = i;
    }
    return best;
  };
  std::stable_sort(holes.begin(), holes.end(), [&](const Loop& a, const Loop& b) {
    return a[rightmost(a)].p.x() > b[rightmost(b)].p.x();
  });
  for (const Loop& hole : holes) {
    const std::size_t m = rightmost(hole);
    const std::size_t j = bridge_vertex(outer, hole[m].p);
    Loop merged(outer.begin(), outer.begin() + static_cast<std::ptrdiff_t>(j) + 1);
    for (std::size_t t = 0; t <= hole.size(); ++t) merged.push_back(hole[(m + t) % hole.size()]);
    merged.insert(merged.end(), outer.begin() + static_cast<std::ptrdiff_t>(j), outer.end());
    outer = std::move(merged);
  }
  return outer;
}

// Shape quality of a triangle: 4√3·area / (sum of squared sides), 1 for an equilateral one.
double quality(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const double sq = (b - a).squaredNorm() + (c - b).squaredNorm() + (a - c).squaredNorm();
  return 2 * std::sqrt(3.0) * orient(a, b, c) / sq;
}

// Ear clipping of a counter-clockwise, weakly simple polygon (bridged holes allowed). An ear is a
// strictly convex corner whose triangle holds no other vertex, on its boundary included (copies of
// its own corners made by bridges excepted); the best-shaped ear is cut first. Cutting an ear
// changes only its neighbours' status, as blocking vertices are reflex and an ear's tip is not;
// the ear flags are recomputed in full once before giving up, for the degenerate cases.
std::vector<std::array<std::uint32_t, 3>> clip_ears(const Loop& poly) {
  const std::size_t n = poly.size();
  std::vector<std::size_t> prev(n), next(n);
  for (std::size_t i = 0; i < n; ++i) {
    prev[i] = (i + n - 1) % n;
    next[i] = (i + 1) % n;
  }
  std::vector<double> ear(n, -1);  // quality when an ear, −1 when not
  std::vector<bool> gone(n, false);
  auto evaluate = [&](std::size_t i) {
    const Eigen::Vector2d &a = poly[prev[i]].p, &b = poly[i].p, &c = poly[next[i]].p;
    ear[i] = -1;
    if (orient(a, b, c) <= 0) return;
    for (std::size_t j = next[next[i]]; j != prev[i]; j = next[j]) {
      const Eigen::Vector2d& q = poly[j].p;
      if (q != a && q != b && q != c && in_triangle(a, b, c, q)) return;
    }
    ear[i] = quality(a, b, c);
  };
  for (std::size_t i = 0; i < n; ++i) evaluate(i);
  std::vector<std::array<std::uint32_t, 3>> out;
  bool refreshed = false;
  for (std::size_t left = n; left > 3;) {
    std::size_t best = n;
    for (std::size_t i = 0; i < n; ++i)
      if (!gone[i] && ear[i] >= 0 && (best == n || ear[i] > ear[best])) best = i;
    if (best == n) {
      if (refreshed) throw std::logic_error("part mesh: ear clipping found no ear");
      for (std::size_t i = 0; i < n; ++i)
        if (!gone[i]) evaluate(i);
      refreshed = true;
      continue;
    }
    refreshed = false;
    const std::size_t a = prev[best], c = next[best];
    out.push_back({poly[a].id, poly[best].id, poly[c].id});
    gone[best] = true;
    next[a] = c;
    prev[c] = a;
    --left;
    evaluate(a);
    evaluate(c);
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (gone[i]) continue;
    if (orient(poly[prev[i]].p, poly[i].p, poly[next[i]].p) > 0)
      out.push_back({poly[prev[i]].id, poly[i].id, poly[next[i]].id});
    break;
  }
  return out;
}

// Collects triangles over unique vertices: a corner is looked up by its exact coordinates, so
// faces that compute a shared corner by the same expression share its index.
class MeshBuilder {
 public:
  std::uint32_t vertex(const Eigen::Vector3d& p) {
    const auto [it, added] = index_.try_emplace({p.x(), p.y(), p.z()},
                                                static_cast<std::uint32_t>(mesh_.vertices.size()));
    if (added) mesh_.vertices.push_back(p);
    return it->second;
  }
  // Triangle a, b, c wound so that its normal points along `outward`.
  void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c, const Eigen::Vector3d& outward) {
    const auto& v = mesh_.vertices;
    if ((v[b] - v[a]).cross(v[c] - v[a]).dot(outward) < 0) std::swap(b, c);
    mesh_.triangles.push_back({a, b, c});
  }
  // A planar convex quad with corners p0..p3 in order around it.
  void quad(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
            const Eigen::Vector3d& p3, const Eigen::Vector3d& outward) {
    const std::uint32_t a = vertex(p0), b = vertex(p1), c = vertex(p2), d = vertex(p3);
    triangle(a, b, c, outward);
    triangle(a, c, d, outward);
  }
  // A horizontal face at height z: `outer` counter-clockwise (x, y), minus the `holes` (each
  // counter-clockwise too), facing up or down.
  void horizontal_face(double z, const std::vector<Eigen::Vector2d>& outer,
                       const std::vector<std::vector<Eigen::Vector2d>>& holes, bool up) {
    auto loop = [&](const std::vector<Eigen::Vector2d>& points, bool reverse) {
      Loop l;
      for (const Eigen::Vector2d& p : points) l.push_back({p, vertex({p.x(), p.y(), z})});
      if (reverse) std::reverse(l.begin(), l.end());
      return l;
    };
    std::vector<Loop> hole_loops;
    for (const auto& h : holes) hole_loops.push_back(loop(h, true));
    const Eigen::Vector3d normal(0, 0, up ? 1 : -1);
    for (const auto& t : clip_ears(bridge_holes(loop(outer, false), std::move(hole_loops))))
      triangle(t[0], t[1], t[2], normal);
  }
  TriangleMesh take() { return std::move(mesh_); }

 private:
  TriangleMesh mesh_;
  std::map<std::array<double, 3>, std::uint32_t> index_;
};

// The corners of an axis-aligned rectangle, counter-clockwise from (lo.x, lo.y).
std::vector<Eigen::Vector2d> rectangle(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  return {{lo.x(), lo.y()}, {hi.x(), lo.y()}, {hi.x(), hi.y()}, {lo.x(), hi.y()}};
}

// Distance from p to the rectangle [lo, hi] (0 inside).
double rectangle_distance(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                          const Eigen::Vector2d& p) {
  return (p.cwiseMax(lo).cwiseMin(hi) - p).norm();
}

// Whether the disk lies in [lo, hi] with `margin` to spare.
bool disk_inside(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, const Eigen::Vector2d& c,
                 double r, double margin) {
  const Eigen::Vector2d d(r + margin, r + margin);
  return (c - d).cwiseMin(lo) == lo && (c + d).cwiseMax(hi) == hi;
}

void require_part(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("PartSettings: " + what);
}

}  // namespace

const char* to_string(PartFeatureKind kind) {
  switch (kind) {
    case PartFeatureKind::kConvexEdge:
      return "convex edge";
    case PartFeatureKind::kConcaveEdge:
      return "concave edge";
    case PartFeatureKind::kChamferEdge:
      return "chamfer edge";
    case PartFeatureKind::kHoleRim:
      return "hole rim";
    case PartFeatureKind::kFacetEdge:
      return "facet edge";
    case PartFeatureKind::kConvexCorner:
      return "convex corner";
    case PartFeatureKind::kChamferCorner:
      return "chamfer corner";
    case PartFeatureKind::kPocketFloorCorner:
      return "pocket floor corner";
    case PartFeatureKind::kPocketRimCorner:
      return "pocket rim corner";
    case PartFeatureKind::kRimVertex:
      return "rim vertex";
  }
  return "?";
}

PartModel::PartModel(const PartSettings& settings) : settings_(settings) {
  const PartSettings& s = settings_;
  require_part(s.block.minCoeff() > 0 && s.chamfer > 0 && s.pocket_depth > 0 && s.boss_radius > 0 &&
                   s.boss_height > 0,
               "sizes must be positive");
  require_part(s.circle_segments >= 8 && s.circle_segments <= 65536, "circle_segments: 8 to 65536");
  require_part(s.chamfer < s.block.z() && 2 * (s.chamfer + kMargin) < s.block.head<2>().minCoeff(),
               "the chamfer leaves no flat top");
  require_part(s.pocket_depth + kMargin <= s.block.z(), "the pocket is deeper than the block");
  const Eigen::Vector2d top_hi = s.block.head<2>() / 2 - Eigen::Vector2d::Constant(s.chamfer);
  const Eigen::Vector2d top_lo = -top_hi, m(kMargin, kMargin);
  require_part((s.pocket_max - s.pocket_min).minCoeff() > 0,
               "pocket_min must lie below pocket_max");
  require_part((s.pocket_min - m).cwiseMin(top_lo) == top_lo &&
                   (s.pocket_max + m).cwiseMax(top_hi) == top_hi,
               "the pocket must lie on the flat top");
  require_part(
      disk_inside(top_lo, top_hi, s.boss_centre, s.boss_radius, kMargin) &&
          rectangle_distance(s.pocket_min, s.pocket_max, s.boss_centre) >= s.boss_radius + kMargin,
      "the boss must stand on the flat top, clear of the pocket");
  for (std::size_t i = 0; i < s.holes.size(); ++i) {
    const PartHole& h = s.holes[i];
    const std::string name = "hole " + std::to_string(i) + " ";
    require_part(h.radius > 0, name + "radius must be positive");
    require_part(
        disk_inside(s.pocket_min, s.pocket_max, h.centre, h.radius, kMargin) ||
            (disk_inside(top_lo, top_hi, h.centre, h.radius, kMargin) &&
             rectangle_distance(s.pocket_min, s.pocket_max, h.centre) >= h.radius + kMargin),
        name + "must lie inside the pocket floor or on the flat top, clear of the pocket");
    require_part((h.centre - s.boss_centre).norm() >= h.radius + s.boss_radius + kMargin,
                 name + "must be clear of the boss");
    for (std::size_t j = 0; j < i; ++j)
      require_part((h.centre - s.holes[j].centre).norm() >= h.radius + s.holes[j].radius + kMargin,
                   name + "must be clear of hole " + std::to_string(j));
  }
  const int n = s.circle_segments;
  for (int k = 0; k < n; ++k) {
    const double angle = 2 * std::numbers::pi * k / n;
    unit_circle_.emplace_back(std::cos(angle), std::sin(angle));
  }
}

Eigen::Vector2d PartModel::circle_vertex(const Eigen::Vector2d& centre, double radius,
                                         int k) const {
  const int n = settings_.circle_segments;
  return centre + radius * unit_circle_[static_cast<std::size_t>(((k % n) + n) % n)];
}

double PartModel::floor_z() const { return settings_.block.z() - settings_.pocket_depth; }

bool PartModel::in_pocket(const PartHole& hole) const {
  return disk_inside(settings_.pocket_min, settings_.pocket_max, hole.centre, hole.radius, 0);
}

// Left of every edge of the counter-clockwise polygon: strictly (the open polygon) or not
// (`closed`: its edges included). The disk tests only skip the edge loop far from the boundary (the
// circumradius is `radius`, the inradius radius·cos(π/n)), with a margin far above rounding, so
// the answer is that of the edges.
bool PartModel::in_polygon(const Eigen::Vector2d& centre, double radius, const Eigen::Vector2d& p,
                           bool closed) const {
  const double sq = (p - centre).squaredNorm();
  if (sq > radius * radius * (1 + 1e-9)) return false;
  const double inradius = radius * std::cos(std::numbers::pi / settings_.circle_segments);
  if (sq < inradius * inradius * (1 - 1e-9)) return true;
  const int n = settings_.circle_segments;
  for (int k = 0; k < n; ++k) {
    const double side =
        orient(circle_vertex(centre, radius, k), circle_vertex(centre, radius, k + 1), p);
    if (side < 0 || (side == 0 && !closed)) return false;
  }
  return true;
}

// The block with its chamfer is the intersection of the open half-spaces 0 < z < H, |x| < X,
// |y| < Y, |x| + z < X + H − c, |y| + z < Y + H − c (the chamfer planes through the wall tops
// (X, H − c) and the top's edges (X − c, H)); the pocket and the holes, closed sets, are cut from
// it, and the open boss prism is added, so every point of the surface is outside. The boss prism
// is taken down to z = 0: the block is solid under it.
bool PartModel::contains(const Eigen::Vector3d& p) const {
  const PartSettings& s = settings_;
  const double x = p.x(), y = p.y(), z = p.z(), H = top_z(), wall_top = H - s.chamfer;
  const double X = s.block.x() / 2, Y = s.block.y() / 2;
  if (z > 0 && z < H + s.boss_height &&
      in_polygon(s.boss_centre, s.boss_radius, p.head<2>(), false))
    return true;
  if (!(z > 0 && z < H && std::abs(x) < X && std::abs(y) < Y && std::abs(x) + z < X + wall_top &&
        std::abs(y) + z < Y + wall_top))
    return false;
  if (x >= s.pocket_min.x() && x <= s.pocket_max.x() && y >= s.pocket_min.y() &&
      y <= s.pocket_max.y() && z >= floor_z())
    return false;
  for (const PartHole& h : s.holes)
    if (in_polygon(h.centre, h.radius, p.head<2>(), true)) return false;
  return true;
}

namespace {

Eigen::Vector3d at(const Eigen::Vector2d& p, double z) { return {p.x(), p.y(), z}; }

// The flat top's outline: the block's outline moved in by the chamfer.
std::vector<Eigen::Vector2d> top_outline(const PartSettings& s) {
  const Eigen::Vector2d half = s.block.head<2>() / 2 - Eigen::Vector2d::Constant(s.chamfer);
  return rectangle(-half, half);
}

std::vector<Eigen::Vector2d> polygon(const PartModel& part, const Eigen::Vector2d& centre,
                                     double radius) {
  std::vector<Eigen::Vector2d> out;
  for (int k = 0; k < part.settings().circle_segments; ++k)
    out.push_back(part.circle_vertex(centre, radius, k));
  return out;
}

// The block's four side walls (z from 0 to H − c) and chamfers (from there to the top's edge),
// side k running from outline corner k to k + 1; the right of a counter-clockwise edge is out.
void add_block_sides(const PartModel& part, MeshBuilder& b) {
  const PartSettings& s = part.settings();
  const double H = part.top_z(), wall_top = H - s.chamfer;
  const Eigen::Vector2d half = s.block.head<2>() / 2;
  const auto outer = rectangle(-half, half), inner = top_outline(s);
  for (std::size_t k = 0; k < 4; ++k) {
    const std::size_t l = (k + 1) % 4;
    const Eigen::Vector2d side = outer[l] - outer[k];
    const Eigen::Vector3d out = Eigen::Vector3d(side.y(), -side.x(), 0).normalized();
    b.quad(at(outer[k], 0), at(outer[l], 0), at(outer[l], wall_top), at(outer[k], wall_top), out);
    b.quad(at(outer[k], wall_top), at(outer[l], wall_top), at(inner[l], H), at(inner[k], H),
           out + Eigen::Vector3d::UnitZ());
  }
}

// The side of a vertical polygonal prism from z0 to z1, facing away from its axis (the boss) or
// towards it (a hole: the material is outside).
void add_prism_side(const PartModel& part, const Eigen::Vector2d& centre, double radius, double z0,
                    double z1, bool away, MeshBuilder& b) {
  for (int k = 0; k < part.settings().circle_segments; ++k) {
    const Eigen::Vector2d p = part.circle_vertex(centre, radius, k);
    const Eigen::Vector2d q = part.circle_vertex(centre, radius, k + 1);
    const Eigen::Vector2d out =
        away ? Eigen::Vector2d((p + q) / 2 - centre) : Eigen::Vector2d(centre - (p + q) / 2);
    b.quad(at(p, z0), at(q, z0), at(q, z1), at(p, z1), at(out, 0));
  }
}

// The pocket's four walls (from the floor to the top), facing into the pocket: the left of its
// counter-clockwise outline.
void add_pocket_walls(const PartModel& part, MeshBuilder& b) {
  const PartSettings& s = part.settings();
  const auto pocket = rectangle(s.pocket_min, s.pocket_max);
  const double zf = part.floor_z(), H = part.top_z();
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d &p = pocket[k], &q = pocket[(k + 1) % 4];
    const Eigen::Vector2d side = q - p;
    b.quad(at(p, zf), at(q, zf), at(q, H), at(p, H), Eigen::Vector3d(-side.y(), side.x(), 0));
  }
}

}  // namespace

// Faces: block sides and chamfers, hole and boss sides, pocket walls (quads), then the planar faces
// with holes: the boss top, the pocket floor (minus its holes), the flat top (minus the pocket,
// the other holes and the boss's footprint) and the base (minus every hole).
TriangleMesh PartModel::mesh(std::size_t min_triangles) const {
  if (min_triangles > kMaxTriangles)
    throw std::invalid_argument("PartModel::mesh: more than 100 000 000 triangles asked for");
  const PartSettings& s = settings_;
  const double H = top_z(), zf = floor_z(), boss_top = H + s.boss_height;
  MeshBuilder b;
  add_block_sides(*this, b);
  std::vector<std::vector<Eigen::Vector2d>> base_holes, floor_holes;
  std::vector<std::vector<Eigen::Vector2d>> top_holes{rectangle(s.pocket_min, s.pocket_max)};
  for (const PartHole& h : s.holes) {
    const auto outline = polygon(*this, h.centre, h.radius);
    base_holes.push_back(outline);
    (in_pocket(h) ? floor_holes : top_holes).push_back(outline);
    add_prism_side(*this, h.centre, h.radius, 0, in_pocket(h) ? zf : H, false, b);
  }
  const auto boss = polygon(*this, s.boss_centre, s.boss_radius);
  top_holes.push_back(boss);
  add_prism_side(*this, s.boss_centre, s.boss_radius, H, boss_top, true, b);
  add_pocket_walls(*this, b);
  b.horizontal_face(boss_top, boss, {}, true);
  b.horizontal_face(zf, rectangle(s.pocket_min, s.pocket_max), floor_holes, true);
  b.horizontal_face(H, top_outline(s), top_holes, true);
  const Eigen::Vector2d half = s.block.head<2>() / 2;
  b.horizontal_face(0, rectangle(-half, half), base_holes, false);
  TriangleMesh mesh = b.take();
  int levels = 0;
  for (std::size_t count = mesh.triangles.size(); count < min_triangles; count *= 4) ++levels;
  return subdivide(mesh, levels);
}

TriangleMesh subdivide(const TriangleMesh& mesh, int levels) {
  TriangleMesh out = mesh;
  for (int level = 0; level < levels; ++level) {
    TriangleMesh finer;
    finer.vertices = out.vertices;
    finer.triangles.reserve(4 * out.triangles.size());
    std::unordered_map<std::uint64_t, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
      const auto [it, added] =
          midpoints.try_emplace(key, static_cast<std::uint32_t>(finer.vertices.size()));
      if (added) finer.vertices.push_back(0.5 * (out.vertices[a] + out.vertices[b]));
      return it->second;
    };
    for (const auto& [a, b, c] : out.triangles) {
      const std::uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      finer.triangles.push_back({a, ab, ca});
      finer.triangles.push_back({ab, b, bc});
      finer.triangles.push_back({ca, bc, c});
      finer.triangles.push_back({ab, bc, ca});
    }
    out = std::move(finer);
  }
  return out;
}

namespace {

std::string corner_name(double sx, double sy) {
  return std::string("(x ") + (sx > 0 ? "max" : "min") + ", y " + (sy > 0 ? "max" : "min") + ")";
}

// The corner features: per corner of the block, its bottom corner and both chamfer corners; per
// corner of the pocket, its floor and rim corners.
void add_corners(const PartModel& part, std::vector<PartFeature>& f) {
  const PartSettings& s = part.settings();
  const double X = s.block.x() / 2, Y = s.block.y() / 2, c = s.chamfer, H = part.top_z();
  using K = PartFeatureKind;
  for (const auto& [sx, sy] : {std::pair{1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}}) {
    const std::string name = corner_name(sx, sy);
    f.push_back({K::kConvexCorner, "block bottom corner " + name, {sx * X, sy * Y, 0}});
    f.push_back({K::kChamferCorner, "wall-chamfer corner " + name, {sx * X, sy * Y, H - c}});
    f.push_back({K::kChamferCorner, "chamfer-top corner " + name, {sx * (X - c), sy * (Y - c), H}});
  }
  for (const Eigen::Vector2d& p : rectangle(s.pocket_min, s.pocket_max)) {
    const std::string name =
        corner_name(p.x() == s.pocket_max.x() ? 1 : -1, p.y() == s.pocket_max.y() ? 1 : -1);
    f.push_back({K::kPocketFloorCorner, "pocket floor corner " + name, at(p, part.floor_z())});
    f.push_back({K::kPocketRimCorner, "pocket rim corner " + name, at(p, H)});
  }
}

// A hole's features: the midpoint of its first side's rims (top and base) and its first vertex
// there, and the vertical edge between its last and first sides.
void add_hole(const PartModel& part, std::size_t i, std::vector<PartFeature>& f) {
  const PartHole& h = part.settings().holes[i];
  const double top = part.in_pocket(h) ? part.floor_z() : part.top_z();
  const Eigen::Vector2d v0 = part.circle_vertex(h.centre, h.radius, 0);
  const Eigen::Vector2d edge = (v0 + part.circle_vertex(h.centre, h.radius, 1)) / 2;
  const std::string name = "hole " + std::to_string(i) + " ";
  const std::string top_name = part.in_pocket(h) ? "pocket floor" : "top";
  using K = PartFeatureKind;
  f.push_back({K::kHoleRim, name + "rim at the " + top_name, at(edge, top)});
  f.push_back({K::kHoleRim, name + "rim at the base", at(edge, 0)});
  f.push_back({K::kRimVertex, name + "rim vertex at the " + top_name, at(v0, top)});
  f.push_back({K::kRimVertex, name + "rim vertex at the base", at(v0, 0)});
  f.push_back({K::kFacetEdge, name + "side edge", at(v0, top / 2)});
}

}  // namespace

std::vector<PartFeature> PartModel::features() const {
  const PartSettings& s = settings_;
  const double X = s.block.x() / 2, Y = s.block.y() / 2, c = s.chamfer, H = top_z();
  const double zf = floor_z(), boss_top = H + s.boss_height;
  const double pocket_x = (s.pocket_min.x() + s.pocket_max.x()) / 2, y0 = s.pocket_min.y();
  const Eigen::Vector2d b0 = circle_vertex(s.boss_centre, s.boss_radius, 0);
  const Eigen::Vector2d boss_edge = (b0 + circle_vertex(s.boss_centre, s.boss_radius, 1)) / 2;
  using K = PartFeatureKind;
  std::vector<PartFeature> f = {
      {K::kConvexEdge, "block bottom edge (y min)", {0, -Y, 0}},
      {K::kConvexEdge, "block vertical edge (x max, y min)", {X, -Y, (H - c) / 2}},
      {K::kConvexEdge, "pocket rim (y min)", {pocket_x, y0, H}},
      {K::kConvexEdge, "boss top rim", at(boss_edge, boss_top)},
      {K::kConcaveEdge, "pocket floor edge (y min)", {pocket_x, y0, zf}},
      {K::kConcaveEdge,
       "pocket vertical edge (x min, y min)",
       {s.pocket_min.x(), y0, (zf + H) / 2}},
      {K::kConcaveEdge, "boss base", at(boss_edge, H)},
      {K::kChamferEdge, "wall-chamfer edge (y min)", {0, -Y, H - c}},
      {K::kChamferEdge, "chamfer-top edge (y min)", {0, -Y + c, H}},
      {K::kChamferEdge, "chamfer-chamfer edge (x max, y min)", {X - c / 2, -Y + c / 2, H - c / 2}},
      {K::kFacetEdge, "boss side edge", at(b0, H + s.boss_height / 2)},
      {K::kRimVertex, "boss top vertex", at(b0, boss_top)},
      {K::kRimVertex, "boss base vertex", at(b0, H)}};
  add_corners(*this, f);
  for (std::size_t i = 0; i < s.holes.size(); ++i) add_hole(*this, i, f);
  return f;
}

}  // namespace align3d::synth
