// A machined part with exact ground truth, for CAD inspection (`align3d inspect SCAN CAD`): its CAD
// mesh, an analytic membership oracle, its sharp features, and an as-built scan of it (a raster
// scanner's points with known dents, bumps, warp, noise, a fixture and a known pose).
// Units: millimetres. Same settings, same bits (at any thread count).
//
// The part (CAD frame: base on z = 0, z up, the block centred on the z axis), with the defaults:
//   block     120 × 80 × 40, its four top outer edges chamfered at 45° (legs of 4 mm): the side
//             walls rise to z = 36, the flat top is 112 × 72 at z = 40;
//   pocket    x ∈ [−45, −5], y ∈ [−25, 25], 15 deep (flat floor at z = 25, vertical walls);
//   holes     through-holes r 6 at (−25, 0), through the pocket floor, and r 5 at (35, −20),
//             through the top;
//   boss      r 12 at (30, 15), 15 high (top at z = 55).
// Circles are regular polygons of `circle_segments` sides, vertex k at angle 2πk/n from +x, and
// the mesh, the oracle and the features all describe that polygonal solid exactly (not the true
// cylinder). No symmetry maps the part onto itself.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "align3d/mesh.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d::synth {

struct PartHole {
  Eigen::Vector2d centre;
  double radius;
};

// Throws std::invalid_argument (PartModel) for a geometry that is not clean: non-positive sizes,
// fewer than 8 segments, a pocket or boss not inside the flat top with 1 mm to spare, a hole not
// wholly inside the pocket floor or wholly on the flat top, features closer than 1 mm.
struct PartSettings {
  Eigen::Vector3d block{120, 80, 40};  // x, y, z extents: |x| <= 60, |y| <= 40, 0 <= z <= 40
  double chamfer = 4;                  // 45° chamfer leg on the top outer edges
  Eigen::Vector2d pocket_min{-45, -25}, pocket_max{-5, 25};
  double pocket_depth = 15;
  std::vector<PartHole> holes = {{{-25, 0}, 6}, {{35, -20}, 5}};  // through the pocket or the top
  Eigen::Vector2d boss_centre{30, 15};
  double boss_radius = 12, boss_height = 15;
  int circle_segments = 64;  // sides of every circle (holes, boss)
};

// The sharp features of the part, for sign tests of distance queries. Edge angles are measured
// through the material.
enum class PartFeatureKind : std::uint8_t {
  kConvexEdge,     // 90°: block edges, pocket rim, boss top rim
  kConcaveEdge,    // 270°: pocket floor–wall, boss base
  kChamferEdge,    // 135°: wall–chamfer, chamfer–top, chamfer–chamfer (the corner diagonal)
  kHoleRim,        // 90°: a hole's polygon meeting the top, the pocket floor or the base
  kFacetEdge,      // 180° ∓ 360°/n: between two sides of the boss (convex) or a hole (concave)
  kConvexCorner,   // the block's bottom corners: three 90° convex edges
  kChamferCorner,  // where two walls meet two chamfers, and two chamfers meet the top
  kPocketFloorCorner,  // concave: the floor and two pocket walls
  kPocketRimCorner,    // saddle: the top face and two pocket walls (convex edges, concave corner)
  kRimVertex,          // a polygon vertex on a hole rim, the boss base or the boss top
};
const char* to_string(PartFeatureKind kind);

struct PartFeature {
  PartFeatureKind kind;
  std::string name;       // e.g. "pocket floor corner (x min, y min)"
  Eigen::Vector3d point;  // on the feature (an edge's midpoint, or the vertex)
};

// The part for validated settings. Thread-safe (const).
class PartModel {
 public:
  explicit PartModel(const PartSettings& settings = {});

  const PartSettings& settings() const { return settings_; }

  // The CAD mesh: watertight, manifold, wound outward (counter-clockwise seen from outside), its
  // vertices indexed and unique (every shared corner is computed by one expression, so an STL
  // written from it welds back exactly). Planar faces with holes are triangulated by ear clipping
  // with hole bridging (Eberly 2008), taking the best-shaped ear first; walls are quads cut in two.
  // With `min_triangles` above the natural count, every triangle is split into four at its edge
  // midpoints as often as needed to reach it (the count is natural · 4^k; the surface is the
  // same). The defaults: 812 triangles (then 3 248, 12 992, 51 968, 207 872, ...). Throws
  // std::invalid_argument above 10^8 triangles.
  TriangleMesh mesh(std::size_t min_triangles = 0) const;

  // Whether p lies strictly inside the material, from the analytic description (half-spaces and
  // the same polygon vertices as the mesh, not the triangles): exact for the polygonal solid,
  // false on its surface.
  bool contains(const Eigen::Vector3d& p) const;

  // Every kind of sharp edge and vertex of the part, with a point on it (one or a few of each).
  std::vector<PartFeature> features() const;

  // Vertex k of a circle of the part: centre + radius·(cos 2πk/n, sin 2πk/n), k taken modulo n.
  Eigen::Vector2d circle_vertex(const Eigen::Vector2d& centre, double radius, int k) const;

  double top_z() const { return settings_.block.z(); }  // the flat top
  double floor_z() const;                               // the pocket floor
  bool in_pocket(const PartHole& hole) const;           // a hole through the pocket floor

 private:
  bool in_polygon(const Eigen::Vector2d& centre, double radius, const Eigen::Vector2d& p,
                  bool closed) const;

  PartSettings settings_;
  std::vector<Eigen::Vector2d> unit_circle_;  // (cos 2πk/n, sin 2πk/n)
};

// `mesh` with every triangle split into four at its edge midpoints, `levels` times (shared edges
// get one shared midpoint, so a closed mesh stays closed).
TriangleMesh subdivide(const TriangleMesh& mesh, int levels);

// ---- The as-built scan -------------------------------------------------------------------------
//
// A structured-light or laser scanner with parallel projection (telecentric): per view, a raster
// of parallel rays `pitch` apart on a plane square to the view direction, 1 m before the part,
// its rows along the CAD x axis as seen from the scanner, framing the part's vertices (and the
// corners of every fixture box marked `framed`) with `raster_margin` to spare. Each ray is cast at
// the CAD mesh and the fixture (MeshIndex::intersect); the first hit is kept when its incidence
// angle (between the ray and the face normal) is below `max_incidence_deg`. A part hit x on a face
// of outward normal n becomes
//     x + δ(x)·n + ε·d,   δ = Σ defects + warp (true_deviation), ε ~ N(0, noise_sigma²),
// d the ray's unit direction (range noise); a fixture hit becomes x + ε·d. Fixture hits closer than
// `fixture_clearance` to the CAD surface are dropped (they could not be told from the part).
// Everything is then moved into the scanner's frame: scan = T_scan_cad · point, and the ground
// truth is T_cad_scan = T_scan_cad⁻¹ (CAD ≈ T_cad_scan · scan).
// The defaults give 384 566 points: 235 030 on the part, 149 536 on the fixture (26 500 on the
// clamp, the rest on the table; the riser stays hidden under the part), in about 0.5 s on 2 cores;
// target_points = 2 000 000 picks a pitch of 0.132 mm (1 994 294 points, 2 s).

// A dent (peak < 0) or bump (peak > 0) on a planar face: the surface moves along the face's
// outward normal by peak·cos²(π·r / 2R) at distance r < R from the centre in the face's plane (the
// profile and its slope vanish at r = R).
struct SurfaceDefect {
  Eigen::Vector3d centre;  // CAD frame, on the face
  Eigen::Vector3d normal;  // the face's outward normal (unit)
  double radius;           // R
  double peak;             // mm along the normal
};

// An axis-aligned box of the fixture, CAD frame: in the scan, not in the CAD model.
struct FixtureBox {
  std::string name;
  Eigen::Vector3d min, max;
  bool framed = false;  // the scanner's raster is widened to take it in
};

struct AsBuiltSettings {
  std::uint64_t seed = 1;  // draws the noise only: rays, defects, fixture and pose are settings
  PartSettings part;
  std::vector<SurfaceDefect> defects = {
      {{8, -18, 40}, {0, 0, 1}, 6, -0.3},       // dent on the flat top
      {{-20, -40, 18}, {0, -1, 0}, 10, -0.25},  // dent on the front wall (y min)
      {{8, 18, 40}, {0, 0, 1}, 6, 0.2},         // bump on the flat top
      {{60, 10, 16}, {1, 0, 0}, 8, 0.3}};       // bump on the right wall (x max)
  // Warp: δ_w(p) = A·sin(2πx/λ + 0.3)·sin(2πy/λ + 1.1)·cos(2πz/λ), |δ_w| <= A.
  double warp_amplitude = 0.015, warp_wavelength = 240;
  double noise_sigma = 0.01;  // mm, along the ray
  // Ray directions (CAD frame, any length), 35° from the vertical: from above the front-right
  // (the scanner at +x, −y), then from above the back-left.
  std::vector<Eigen::Vector3d> views = {{-0.5, 0.5, -1}, {0.5, -0.5, -1}};
  double pitch = 0.3;             // mm between neighbouring rays
  std::size_t target_points = 0;  // > 0: the pitch is chosen to give about this many points
  double max_incidence_deg = 75;
  double raster_margin = 8;  // mm
  std::vector<FixtureBox> fixture = {{"clamp", {-80, -20, -26}, {-66, 20, 30}, true},
                                     {"riser", {-40, -25, -26}, {40, 25, 0}},
                                     {"table", {-110, -80, -40}, {110, 80, -25}}};
  double fixture_clearance = 3;  // mm
  // T_scan_cad: rotation_deg about rotation_axis, then translation.
  double rotation_deg = 3;
  Eigen::Vector3d rotation_axis{1, -2, 4};
  Eigen::Vector3d translation{5, -4, 3};
  int threads = 0;  // 0: all cores; the scan does not depend on it
};

enum class ScanLabel : std::uint8_t { kPart = 0, kFixture = 1 };

// One view's raster: ray (i, j) starts at origin + (i + ½)·pitch·u + (j + ½)·pitch·v and runs
// along `direction` (unit); rays are taken row by row (j), then along the row (i).
struct ScanRaster {
  Eigen::Vector3d direction, origin, u, v;  // CAD frame
  int columns = 0, rows = 0;
  std::size_t points = 0;  // kept
};

struct AsBuiltScan {
  PointCloud scan;                 // scanner frame, no normals; view 0's points first
  std::vector<ScanLabel> label;    // per point
  std::vector<double> deviation;   // per point: δ (mm, no noise); 0 on the fixture
  std::vector<std::uint8_t> view;  // per point
  Eigen::Isometry3d T_cad_scan = Eigen::Isometry3d::Identity();  // CAD ≈ T·scan
  double pitch = 0;                                              // as used
  std::vector<ScanRaster> rasters;                               // per view
  std::size_t part_points = 0, fixture_points = 0;
  std::size_t dropped_near_part = 0;  // fixture hits within fixture_clearance of the CAD
};

// Throws std::invalid_argument for bad settings: no view or more than 255, a non-positive pitch
// or sigma below 0, a defect not lying on a face of the part (its centre and rim, tested with
// PartModel::contains), or a raster of more than 2^31 rays.
AsBuiltScan make_as_built_scan(const AsBuiltSettings& settings = {});

// δ at a point x of the CAD surface whose face has outward normal n: the defects on that face
// (same normal and plane) plus the warp.
double true_deviation(const AsBuiltSettings& settings, const Eigen::Vector3d& x,
                      const Eigen::Vector3d& n);

}  // namespace align3d::synth
