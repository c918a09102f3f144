// Analytic primitives for synthetic range data: exact ray intersections, distances to the surface
// and area-uniform surface samples. Units are the caller's (the scenes use millimetres).
//
// Shapes and their local frames (a pose maps local coordinates into the frame the shape lives in):
//   Plane      align3d::Plane (plane/plane.hpp): infinite, normal `normal`, through `point`.
//   Rectangle  a sheet on local z = 0, |x| <= half_size.x, |y| <= half_size.y; normal local +z.
//   Box        a solid, |x|, |y|, |z| <= half_size (local).
//   Cylinder   a solid with both caps: local axis z, radius `radius`, |z| <= half_height.
//   Sphere     a solid, centre `centre`, radius `radius`.
//   Ellipsoid  a solid, semi-axes `half_axes` along local x, y, z.
// Plane and Rectangle are sheets: they have no inside, and their normal is the stated one whichever
// side a ray comes from. The normal of a solid points outwards.
// A scene is a union: std::vector<Shape>. Every function here is pure and thread-safe.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <optional>
#include <variant>
#include <vector>

#include "align3d/plane/plane.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d::synth {

struct Rectangle {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector2d half_size{1, 1};
};

struct Box {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d half_size{1, 1, 1};
};

struct Cylinder {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  double radius = 1;
  double half_height = 1;
};

struct Sphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 1;
};

struct Ellipsoid {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d half_axes{1, 1, 1};
};

using Shape = std::variant<Plane, Rectangle, Box, Cylinder, Sphere, Ellipsoid>;

// origin + t·direction, t >= 0. The direction need not be unit length; t is then in its units.
struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

struct Hit {
  double t = 0;            // the ray parameter of the hit
  Eigen::Vector3d point;   // origin + t·direction
  Eigen::Vector3d normal;  // unit; outward for solids, the stated normal for sheets
  int shape = -1;          // cast_ray: the index of the shape hit; intersect: -1
};

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The first crossing of the surface with t_min < t < t_max (the first exit when the ray starts
// inside a solid). A ray tangent to a curved surface touches it at one point and counts as a hit
// there; a ray lying in a sheet's or face's plane does not hit that sheet or face. Closed forms:
// quadratics (sphere, cylinder side, solved in the cancellation-free form), ray–plane (sheets,
// caps), slabs (box).
std::optional<Hit> intersect(const Shape& shape, const Ray& ray, double t_min = 0,
                             double t_max = kInfinity);

// The nearest hit over a union of shapes (ties go to the lower index); Hit::shape says which.
std::optional<Hit> cast_ray(const std::vector<Shape>& shapes, const Ray& ray, double t_min = 0,
                            double t_max = kInfinity);

// Euclidean distance from p to the shape's surface (for solids: the boundary, from either side).
double surface_distance(const Shape& shape, const Eigen::Vector3d& p);
// Whether p lies strictly inside a solid (sheets contain nothing).
bool contains(const Shape& shape, const Eigen::Vector3d& p);
// The surface area (a Plane is infinite: kInfinity).
double surface_area(const Shape& shape);
// The exact axis-aligned bounding box (a Plane's is unbounded: ±kInfinity). A cylinder with unit
// axis a spans half_height·|a_i| + radius·√(1 − a_i²) about its centre along world axis i.
Eigen::AlignedBox3d bounding_box(const Shape& shape);
// The shape moved rigidly by T (T·pose, T·centre; a Plane's normal rotated, its point moved).
Shape transformed(const Shape& shape, const Eigen::Isometry3d& T);

// `count` points spread uniformly by area over the outer surface of the union of `shapes`, with
// their outward unit normals: a sample on one shape is dropped when another shape contains it, so
// nothing lies inside the union. Shapes must not share a face (the shared part would be sampled
// twice): let the parts of a compound object overlap instead. Deterministic for `seed`. Throws
// std::invalid_argument for an infinite shape (Plane), no area, or when fewer than 1 sample in 1000
// survives (a union whose outer surface is nearly all hidden).
PointCloud sample_surface(const std::vector<Shape>& shapes, int count, std::uint64_t seed);

}  // namespace align3d::synth
