#include "align3d/synth/shapes.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "detail/random.hpp"

namespace align3d::synth {
namespace {

// The nearest admissible crossing seen so far, in the shape's local frame.
struct Crossing {
  double t_min, t_max;
  double t = kInfinity;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  void offer(double t_candidate, const Eigen::Vector3d& n) {
    if (t_candidate > t_min && t_candidate < t_max && t_candidate < t) {
      t = t_candidate;
      normal = n;
    }
  }
  bool found() const { return t < kInfinity; }
};

// Roots of a·t² + 2·b·t + c = 0 (a > 0), without the cancellation of the textbook formula:
// q = −(b + sign(b)·√(b² − a·c)), t = q / a and t = c / q (Numerical Recipes §5.6). Returns the
// number of real roots (a double root is returned twice).
int solve_quadratic(double a, double b, double c, double roots[2]) {
  const double disc = b * b - a * c;
  if (disc < 0) return 0;
  const double q = -(b + std::copysign(std::sqrt(disc), b));
  roots[0] = q / a;
  roots[1] = q != 0 ? c / q : roots[0];  // q = 0 only when b = c = 0: a double root at 0
  return 2;
}

// The ray in the local frame of `pose`: origin R^T·(o − t), direction R^T·d.
Ray to_local(const Eigen::Isometry3d& pose, const Ray& ray) {
  const Eigen::Matrix3d Rt = pose.linear().transpose();
  return {Rt * (ray.origin - pose.translation()), Rt * ray.direction};
}

Crossing cross(const Plane& plane, const Ray& ray, double t_min, double t_max) {
  Crossing c{t_min, t_max};
  const double nd = plane.normal.dot(ray.direction);
  if (nd != 0) c.offer(plane.normal.dot(plane.point - ray.origin) / nd, plane.normal);
  return c;
}

Crossing cross(const Rectangle& rect, const Ray& ray, double t_min, double t_max) {
  Crossing c{t_min, t_max};
  const Ray l = to_local(rect.pose, ray);
  if (l.direction.z() == 0) return c;
  const double t = -l.origin.z() / l.direction.z();
  const Eigen::Vector3d p = l.origin + t * l.direction;
  if (std::abs(p.x()) <= rect.half_size.x() && std::abs(p.y()) <= rect.half_size.y())
    c.offer(t, rect.pose.linear().col(2));
  return c;
}

// Slabs (Kay and Kajiya 1986): the ray is inside the box for t in [max of the entries, min of the
// exits] over the three axes; the entry's axis gives the face hit, and from inside the exit's.
Crossing cross(const Box& box, const Ray& ray, double t_min, double t_max) {
  Crossing c{t_min, t_max};
  const Ray l = to_local(box.pose, ray);
  const Eigen::Vector3d& h = box.half_size;
  double t_in = -kInfinity, t_out = kInfinity;
  int axis_in = -1, axis_out = -1;
  for (int i = 0; i < 3; ++i) {
    const double o = l.origin(i), d = l.direction(i);
    if (d == 0) {  // parallel to the slab: inside it always or never
      if (std::abs(o) > h(i)) return c;
      continue;
    }
    double ta = (-h(i) - o) / d, tb = (h(i) - o) / d;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t_in) {
      t_in = ta;
      axis_in = i;
    }
    if (tb < t_out) {
      t_out = tb;
      axis_out = i;
    }
  }
  if (t_in > t_out) return c;
  const Eigen::Matrix3d& R = box.pose.linear();
  if (axis_in >= 0) c.offer(t_in, -std::copysign(1.0, l.direction(axis_in)) * R.col(axis_in));
  if (!c.found() && axis_out >= 0)
    c.offer(t_out, std::copysign(1.0, l.direction(axis_out)) * R.col(axis_out));
  return c;
}

Crossing cross(const Cylinder& cyl, const Ray& ray, double t_min, double t_max) {
  Crossing c{t_min, t_max};
  const Ray l = to_local(cyl.pose, ray);
  const Eigen::Vector3d &o = l.origin, &d = l.direction;
  const Eigen::Matrix3d& R = cyl.pose.linear();
  // Side: |(o + t·d)_xy|² = r², kept where |z| <= half_height.
  const double a = d.x() * d.x() + d.y() * d.y();
  double roots[2];
  if (a > 0 && solve_quadratic(a, o.x() * d.x() + o.y() * d.y(),
                               o.x() * o.x() + o.y() * o.y() - cyl.radius * cyl.radius, roots))
    for (double t : roots) {
      const Eigen::Vector3d p = o + t * d;
      if (std::abs(p.z()) <= cyl.half_height)
        c.offer(t, R * Eigen::Vector3d(p.x(), p.y(), 0) / cyl.radius);
    }
  // Caps: z = ±half_height, kept where x² + y² <= r².
  if (d.z() != 0)
    for (double s : {-1.0, 1.0}) {
      const double t = (s * cyl.half_height - o.z()) / d.z();
      const Eigen::Vector3d p = o + t * d;
      if (p.x() * p.x() + p.y() * p.y() <= cyl.radius * cyl.radius) c.offer(t, s * R.col(2));
    }
  return c;
}

Crossing cross(const Sphere& sphere, const Ray& ray, double t_min, double t_max) {
  Crossing c{t_min, t_max};
  const Eigen::Vector3d oc = ray.origin - sphere.centre;
  double roots[2];
  if (solve_quadratic(ray.direction.squaredNorm(), oc.dot(ray.direction),
                      oc.squaredNorm() - sphere.radius * sphere.radius, roots))
    for (double t : roots)
      c.offer(t, (oc + t * ray.direction) / sphere.radius);  // (p − centre) / r
  return c;
}

// In the frame where the ellipsoid is the unit sphere (local coordinates / half_axes) the ray's
// parameter t is unchanged; the normal is the gradient of Σ (x_i / a_i)², x / a², turned back.
Crossing cross(const Ellipsoid& e, const Ray& ray, double t_min, double t_max) {
  Crossing c{t_min, t_max};
  const Ray l = to_local(e.pose, ray);
  const Eigen::Vector3d o = l.origin.cwiseQuotient(e.half_axes),
                        d = l.direction.cwiseQuotient(e.half_axes);
  double roots[2];
  if (d.squaredNorm() > 0 && solve_quadratic(d.squaredNorm(), o.dot(d), o.squaredNorm() - 1, roots))
    for (double t : roots) {
      const Eigen::Vector3d p = l.origin + t * l.direction;
      c.offer(t, (e.pose.linear() * p.cwiseQuotient(e.half_axes.cwiseAbs2())).normalized());
    }
  return c;
}

// Signed distances (negative inside), the usual closed forms (Quílez, "distance functions").
double signed_distance(const Box& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = (box.pose.inverse() * p).cwiseAbs() - box.half_size;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double signed_distance(const Cylinder& cyl, const Eigen::Vector3d& p) {
  const Eigen::Vector3d l = cyl.pose.inverse() * p;
  const Eigen::Vector2d q(l.head<2>().norm() - cyl.radius, std::abs(l.z()) - cyl.half_height);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double signed_distance(const Sphere& sphere, const Eigen::Vector3d& p) {
  return (p - sphere.centre).norm() - sphere.radius;
}

// No closed form (Eberly, "Distance from a point to an ellipse, an ellipsoid, or a
// hyperellipsoid"): in the local frame and the first octant, y = |p|, the nearest point is
// x_i = a_i² y_i / (t + a_i²) for the root t > −a_min² of G(t) = Σ (a_i y_i / (t + a_i²))² − 1,
// which decreases there and is ≤ 0 at t = a_max·|y|; bisected to the last bit. The coordinate
// along the shortest axis is then taken from the surface's equation, which also covers y on that
// axis's plane (where G need not cross zero above −a_min²).
double signed_distance(const Ellipsoid& e, const Eigen::Vector3d& p) {
  const Eigen::Vector3d y = (e.pose.inverse() * p).cwiseAbs(), a = e.half_axes;
  const Eigen::Vector3d a2 = a.cwiseAbs2();
  int shortest = 0;
  a.minCoeff(&shortest);
  auto G = [&](double t) {
    return (a.cwiseProduct(y).array() / (t + a2.array())).matrix().squaredNorm() - 1;
  };
  double lo = -a2(shortest), hi = a.maxCoeff() * y.norm();
  for (int k = 0; k < 200 && lo < hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (G(mid) > 0 ? lo : hi) = mid;
  }
  Eigen::Vector3d x = (a2.cwiseProduct(y).array() / (hi + a2.array())).matrix();
  double rest = 1;
  for (int i = 0; i < 3; ++i)
    if (i != shortest) rest -= (x(i) / a(i)) * (x(i) / a(i));
  x(shortest) = a(shortest) * std::sqrt(std::max(0.0, rest));
  const double d = (x - y).norm();
  return y.cwiseQuotient(a).squaredNorm() < 1 ? -d : d;
}

double distance_to(const Plane& plane, const Eigen::Vector3d& p) {
  return std::abs(plane.signed_distance(p));
}

double distance_to(const Rectangle& rect, const Eigen::Vector3d& p) {
  const Eigen::Vector3d l = rect.pose.inverse() * p;
  const Eigen::Vector2d out = (l.head<2>().cwiseAbs() - rect.half_size).cwiseMax(0.0);
  return std::hypot(out.norm(), l.z());
}

template <class Solid>
double distance_to(const Solid& solid, const Eigen::Vector3d& p) {
  return std::abs(signed_distance(solid, p));
}

double area_of(const Plane&) { return kInfinity; }
double area_of(const Rectangle& r) { return 4 * r.half_size.prod(); }
double area_of(const Box& b) {
  const Eigen::Vector3d& h = b.half_size;
  return 8 * (h.x() * h.y() + h.y() * h.z() + h.z() * h.x());
}
double area_of(const Cylinder& c) {
  return 2 * std::numbers::pi * c.radius * (2 * c.half_height) +
         2 * std::numbers::pi * c.radius * c.radius;
}
double area_of(const Sphere& s) { return 4 * std::numbers::pi * s.radius * s.radius; }

// The map u ↦ diag(a)·u from the unit sphere stretches area by J(u) = a_x a_y a_z |u / a|.
double ellipsoid_stretch(const Ellipsoid& e, const Eigen::Vector3d& u) {
  return e.half_axes.prod() * u.cwiseQuotient(e.half_axes).norm();
}

// No closed form: 4π times the mean of J over a Fibonacci lattice of 4096 points of the unit
// sphere (a smooth integrand: relative error below 1e-6 for axes ratios up to 10).
double area_of(const Ellipsoid& e) {
  constexpr int kLattice = 4096;
  double sum = 0;
  for (int k = 0; k < kLattice; ++k) {
    const double z = 1 - (2 * k + 1) / double(kLattice), phi = 2.399963229728653 * k;
    const double r = std::sqrt(1 - z * z);
    sum += ellipsoid_stretch(e, {r * std::cos(phi), r * std::sin(phi), z});
  }
  return 4 * std::numbers::pi * sum / kLattice;
}

Eigen::AlignedBox3d box_of(const Plane&) {
  return {Eigen::Vector3d::Constant(-kInfinity), Eigen::Vector3d::Constant(kInfinity)};
}
Eigen::AlignedBox3d box_of(const Rectangle& r) {
  Eigen::AlignedBox3d box;
  for (double sx : {-1.0, 1.0})
    for (double sy : {-1.0, 1.0})
      box.extend(r.pose * Eigen::Vector3d(sx * r.half_size.x(), sy * r.half_size.y(), 0));
  return box;
}
Eigen::AlignedBox3d box_of(const Box& b) {
  // The extent along world axis i is Σ_k |R_ik|·h_k (the support function of the box).
  const Eigen::Vector3d reach = b.pose.linear().cwiseAbs() * b.half_size;
  return {b.pose.translation() - reach, b.pose.translation() + reach};
}
Eigen::AlignedBox3d box_of(const Cylinder& c) {
  const Eigen::Vector3d a = c.pose.linear().col(2);
  Eigen::Vector3d reach;
  for (int i = 0; i < 3; ++i)
    reach(i) =
        c.half_height * std::abs(a(i)) + c.radius * std::sqrt(std::max(0.0, 1 - a(i) * a(i)));
  return {c.pose.translation() - reach, c.pose.translation() + reach};
}
Eigen::AlignedBox3d box_of(const Sphere& s) {
  return {s.centre.array() - s.radius, s.centre.array() + s.radius};
}
Eigen::AlignedBox3d box_of(const Ellipsoid& e) {
  // The support function of R·diag(a)·(unit sphere) along world axis i: |row i of R·diag(a)|.
  const Eigen::Vector3d reach = (e.pose.linear() * e.half_axes.asDiagonal()).rowwise().norm();
  return {e.pose.translation() - reach, e.pose.translation() + reach};
}

struct Sample {
  Eigen::Vector3d point, normal;
};

Sample sample_on(const Plane&, Random&) {
  throw std::invalid_argument("sample_surface: a Plane is infinite");
}

Sample sample_on(const Rectangle& r, Random& rng) {
  const double x = rng.uniform(-r.half_size.x(), r.half_size.x());
  const double y = rng.uniform(-r.half_size.y(), r.half_size.y());
  return {r.pose * Eigen::Vector3d(x, y, 0), r.pose.linear().col(2)};
}

Sample sample_on(const Box& b, Random& rng) {
  const Eigen::Vector3d& h = b.half_size;
  // Face pair k (normal ±axis k) has area 4·h_i·h_j each, i and j the other two axes.
  const double pair[3] = {h.y() * h.z(), h.z() * h.x(), h.x() * h.y()};
  double pick = rng.uniform() * 2 * (pair[0] + pair[1] + pair[2]);
  int face = 0;  // 0..5: axis face / 2, side face % 2
  while (face < 5 && pick >= pair[face / 2]) pick -= pair[face++ / 2];
  const int axis = face / 2;
  const double side = face % 2 ? 1.0 : -1.0;
  Eigen::Vector3d l;
  for (int i = 0; i < 3; ++i) l(i) = rng.uniform(-h(i), h(i));
  l(axis) = side * h(axis);
  return {b.pose * l, side * b.pose.linear().col(axis)};
}

Sample sample_on(const Cylinder& c, Random& rng) {
  const double side = 2 * std::numbers::pi * c.radius * 2 * c.half_height,
               cap = std::numbers::pi * c.radius * c.radius;
  const double pick = rng.uniform() * (side + 2 * cap);
  const double phi = rng.uniform(0, 2 * std::numbers::pi);
  const Eigen::Matrix3d& R = c.pose.linear();
  if (pick < side) {
    const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0);
    const double z = rng.uniform(-c.half_height, c.half_height);
    return {c.pose * (c.radius * radial + Eigen::Vector3d(0, 0, z)), R * radial};
  }
  const double s = pick < side + cap ? -1.0 : 1.0;
  const double rho = c.radius * std::sqrt(rng.uniform());  // uniform on the disk
  return {c.pose * Eigen::Vector3d(rho * std::cos(phi), rho * std::sin(phi), s * c.half_height),
          s * R.col(2)};
}

// Archimedes: the sphere's area is uniform in z, so z and the azimuth are drawn uniformly.
Sample sample_on(const Sphere& s, Random& rng) {
  const double z = rng.uniform(-1, 1), phi = rng.uniform(0, 2 * std::numbers::pi);
  const double rho = std::sqrt(std::max(0.0, 1 - z * z));
  const Eigen::Vector3d n(rho * std::cos(phi), rho * std::sin(phi), z);
  return {s.centre + s.radius * n, n};
}

// A uniform point u of the unit sphere, kept with probability J(u) / max J (rejection; max J =
// a_x a_y a_z / a_min), is uniform by area once mapped to diag(a)·u.
Sample sample_on(const Ellipsoid& e, Random& rng) {
  const double bound = e.half_axes.prod() / e.half_axes.minCoeff();
  for (;;) {
    const Sample u = sample_on(Sphere{}, rng);
    if (rng.uniform() * bound >= ellipsoid_stretch(e, u.normal)) continue;
    return {e.pose * e.half_axes.cwiseProduct(u.normal),
            (e.pose.linear() * u.normal.cwiseQuotient(e.half_axes)).normalized()};
  }
}

}  // namespace

std::optional<Hit> intersect(const Shape& shape, const Ray& ray, double t_min, double t_max) {
  const Crossing c = std::visit([&](const auto& s) { return cross(s, ray, t_min, t_max); }, shape);
  if (!c.found()) return std::nullopt;
  return Hit{c.t, ray.origin + c.t * ray.direction, c.normal, -1};
}

std::optional<Hit> cast_ray(const std::vector<Shape>& shapes, const Ray& ray, double t_min,
                            double t_max) {
  std::optional<Hit> best;
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    // Narrowing t_max to the best hit so far keeps only strictly nearer hits (ties: lower index).
    std::optional<Hit> h = intersect(shapes[i], ray, t_min, best ? best->t : t_max);
    if (h) {
      h->shape = static_cast<int>(i);
      best = h;
    }
  }
  return best;
}

double surface_distance(const Shape& shape, const Eigen::Vector3d& p) {
  return std::visit([&](const auto& s) { return distance_to(s, p); }, shape);
}

bool contains(const Shape& shape, const Eigen::Vector3d& p) {
  if (const auto* b = std::get_if<Box>(&shape)) return signed_distance(*b, p) < 0;
  if (const auto* c = std::get_if<Cylinder>(&shape)) return signed_distance(*c, p) < 0;
  if (const auto* s = std::get_if<Sphere>(&shape)) return signed_distance(*s, p) < 0;
  if (const auto* e = std::get_if<Ellipsoid>(&shape))
    return (e->pose.inverse() * p).cwiseQuotient(e->half_axes).squaredNorm() < 1;
  return false;  // sheets
}

double surface_area(const Shape& shape) {
  return std::visit([](const auto& s) { return area_of(s); }, shape);
}

Eigen::AlignedBox3d bounding_box(const Shape& shape) {
  return std::visit([](const auto& s) { return box_of(s); }, shape);
}

Shape transformed(const Shape& shape, const Eigen::Isometry3d& T) {
  if (const auto* p = std::get_if<Plane>(&shape))
    return Plane{T.linear() * p->normal, T * p->point};
  if (const auto* r = std::get_if<Rectangle>(&shape)) return Rectangle{T * r->pose, r->half_size};
  if (const auto* b = std::get_if<Box>(&shape)) return Box{T * b->pose, b->half_size};
  if (const auto* c = std::get_if<Cylinder>(&shape))
    return Cylinder{T * c->pose, c->radius, c->half_height};
  if (const auto* e = std::get_if<Ellipsoid>(&shape)) return Ellipsoid{T * e->pose, e->half_axes};
  const auto& s = std::get<Sphere>(shape);
  return Sphere{T * s.centre, s.radius};
}

PointCloud sample_surface(const std::vector<Shape>& shapes, int count, std::uint64_t seed) {
  if (count < 0) throw std::invalid_argument("sample_surface: negative count");
  std::vector<double> cumulative;
  double total = 0;
  for (const Shape& s : shapes) {
    const double a = surface_area(s);
    if (!std::isfinite(a)) throw std::invalid_argument("sample_surface: a Plane is infinite");
    cumulative.push_back(total += a);
  }
  if (!(total > 0)) throw std::invalid_argument("sample_surface: the shapes have no area");
  Random rng(seed);
  PointCloud cloud;
  cloud.positions.reserve(static_cast<std::size_t>(count));
  cloud.normals.reserve(static_cast<std::size_t>(count));
  const double max_attempts = 1000.0 * count + 1000;
  for (double attempts = 0; static_cast<int>(cloud.size()) < count; ++attempts) {
    if (attempts > max_attempts)
      throw std::invalid_argument("sample_surface: the union's outer surface is (nearly) empty");
    const auto k = static_cast<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end() - 1, rng.uniform() * total) -
        cumulative.begin());
    const Sample s =
        std::visit([&](const auto& shape) { return sample_on(shape, rng); }, shapes[k]);
    bool hidden = false;
    for (std::size_t j = 0; j < shapes.size() && !hidden; ++j)
      hidden = j != k && contains(shapes[j], s.point);
    if (hidden) continue;
    cloud.positions.push_back(s.point);
    cloud.normals.push_back(s.normal);
  }
  return cloud;
}

}  // namespace align3d::synth
