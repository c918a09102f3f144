#include "align3d/synth/scenes.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <vector>

#include "align3d/se3.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "align3d/synth/shapes.hpp"
#include "detail/random.hpp"
#include "synth/outliers.hpp"

namespace align3d::synth {
namespace {

// A solid or sheet whose surface can be sampled uniformly by area. Scenes are unions of these:
// a sample is kept only when no other primitive contains it, so hidden surfaces (the plane under
// the box, the box's base) disappear and the kept points are uniform over the visible area.
struct Primitive {
  virtual ~Primitive() = default;
  virtual double area() const = 0;
  virtual Eigen::Vector3d sample(Random& rng) const = 0;
  virtual bool contains(const Eigen::Vector3d& p) const = 0;
};

struct RectanglePrimitive : Primitive {  // a sheet at height z (no inside)
  Eigen::Vector2d lo, hi;
  double z;
  RectanglePrimitive(Eigen::Vector2d l, Eigen::Vector2d h, double zz) : lo(l), hi(h), z(zz) {}
  double area() const override { return (hi - lo).prod(); }
  Eigen::Vector3d sample(Random& rng) const override {
    return {rng.uniform(lo.x(), hi.x()), rng.uniform(lo.y(), hi.y()), z};
  }
  bool contains(const Eigen::Vector3d&) const override { return false; }
};

// Axis-aligned; the bottom face is not sampled (it stands on something).
struct BoxPrimitive : Primitive {
  Eigen::Vector3d lo, hi;
  BoxPrimitive(Eigen::Vector3d l, Eigen::Vector3d h) : lo(l), hi(h) {}
  double area() const override {
    const Eigen::Vector3d s = hi - lo;
    return s.x() * s.y() + 2 * s.z() * (s.x() + s.y());
  }
  Eigen::Vector3d sample(Random& rng) const override {
    const Eigen::Vector3d s = hi - lo;
    const double faces[5] = {s.x() * s.y(), s.y() * s.z(), s.y() * s.z(), s.x() * s.z(),
                             s.x() * s.z()};
    double pick = rng.uniform() * area();
    int f = 0;
    while (f < 4 && pick >= faces[f]) pick -= faces[f++];
    Eigen::Vector3d p(rng.uniform(lo.x(), hi.x()), rng.uniform(lo.y(), hi.y()),
                      rng.uniform(lo.z(), hi.z()));
    if (f == 0) p.z() = hi.z();
    if (f == 1) p.x() = lo.x();
    if (f == 2) p.x() = hi.x();
    if (f == 3) p.y() = lo.y();
    if (f == 4) p.y() = hi.y();
    return p;
  }
  bool contains(const Eigen::Vector3d& p) const override {
    // The base counts as inside, so a sheet the box stands on is hidden beneath it.
    return (p.array() > lo.array() - 1e-9).all() && (p.array() < hi.array()).all() &&
           p.x() > lo.x() && p.y() > lo.y();
  }
};

struct SphereCap : Primitive {  // the part of a sphere above z = z_cut
  Eigen::Vector3d centre;
  double radius, z_cut;
  SphereCap(Eigen::Vector3d c, double r, double zc) : centre(c), radius(r), z_cut(zc) {}
  double area() const override {  // Archimedes: 2πR·h, uniform in height
    return 2 * 3.14159265358979323846 * radius *
           (centre.z() + radius - std::max(z_cut, centre.z() - radius));
  }
  Eigen::Vector3d sample(Random& rng) const override {
    const double z = rng.uniform(std::max(z_cut, centre.z() - radius), centre.z() + radius);
    const double phi = rng.uniform(0, 6.283185307179586);
    const double rho =
        std::sqrt(std::max(0.0, radius * radius - (z - centre.z()) * (z - centre.z())));
    return {centre.x() + rho * std::cos(phi), centre.y() + rho * std::sin(phi), z};
  }
  bool contains(const Eigen::Vector3d& p) const override {
    return p.z() >= z_cut - 1e-9 && (p - centre).norm() < radius;
  }
};

struct CylinderPrimitive : Primitive {  // vertical, with its top disk (base not sampled)
  Eigen::Vector2d axis;
  double radius, z0, z1;
  CylinderPrimitive(Eigen::Vector2d a, double r, double lo, double hi)
      : axis(a), radius(r), z0(lo), z1(hi) {}
  double area() const override {
    return 2 * 3.14159265358979323846 * radius * (z1 - z0) +
           3.14159265358979323846 * radius * radius;
  }
  Eigen::Vector3d sample(Random& rng) const override {
    const double side = 2 * 3.14159265358979323846 * radius * (z1 - z0);
    const double phi = rng.uniform(0, 6.283185307179586);
    if (rng.uniform() * area() < side)
      return {axis.x() + radius * std::cos(phi), axis.y() + radius * std::sin(phi),
              rng.uniform(z0, z1)};
    const double rho = radius * std::sqrt(rng.uniform());
    return {axis.x() + rho * std::cos(phi), axis.y() + rho * std::sin(phi), z1};
  }
  bool contains(const Eigen::Vector3d& p) const override {
    return p.z() >= z0 - 1e-9 && p.z() < z1 && (p.head<2>() - axis).norm() < radius;
  }
};

using Primitives = std::vector<std::unique_ptr<Primitive>>;

std::vector<Eigen::Vector3d> sample_union(const Primitives& parts, int n, Random& rng) {
  double total = 0;
  for (const auto& p : parts) total += p->area();
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<std::size_t>(n));
  while (static_cast<int>(out.size()) < n) {
    double pick = rng.uniform() * total;
    std::size_t k = 0;
    while (k + 1 < parts.size() && pick >= parts[k]->area()) pick -= parts[k++]->area();
    const Eigen::Vector3d p = parts[k]->sample(rng);
    bool hidden = false;
    for (std::size_t j = 0; j < parts.size() && !hidden; ++j)
      hidden = j != k && parts[j]->contains(p);
    if (!hidden) out.push_back(p);
  }
  return out;
}

void add_noise(std::vector<Eigen::Vector3d>& points, double sigma, Random& rng) {
  for (auto& p : points) {
    const double nx = rng.normal(), ny = rng.normal(), nz = rng.normal();
    p += sigma * Eigen::Vector3d(nx, ny, nz);
  }
}

// Moves model-frame points into the scanner's frame and adds the scanner's noise.
void to_scanner(std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& T_scan_model,
                double sigma, Random& rng) {
  for (auto& p : points) p = T_scan_model * p;
  add_noise(points, sigma, rng);
}

Primitives conveyor_parts(const ConveyorSettings& s) {
  Primitives parts;
  parts.push_back(
      std::make_unique<RectanglePrimitive>(Eigen::Vector2d(-s.plane_x / 2, -s.plane_y / 2),
                                           Eigen::Vector2d(s.plane_x / 2, s.plane_y / 2), 0.0));
  const Eigen::Vector3d half(s.box_size.x() / 2, s.box_size.y() / 2, 0);
  parts.push_back(std::make_unique<BoxPrimitive>(
      s.box_centre - half, s.box_centre + half + Eigen::Vector3d(0, 0, s.box_size.z())));
  parts.push_back(std::make_unique<SphereCap>(
      Eigen::Vector3d(s.cap_centre.x(), s.cap_centre.y(), s.cap_height - s.cap_radius),
      s.cap_radius, 0.0));
  return parts;
}

}  // namespace

std::size_t add_outliers(std::vector<Eigen::Vector3d>& points, std::size_t n, Random& rng) {
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  for (std::size_t i = 0; i < n; ++i) {
    const double x = rng.uniform(box.min().x(), box.max().x());
    const double y = rng.uniform(box.min().y(), box.max().y());
    const double z = rng.uniform(box.min().z(), box.max().z());
    points.emplace_back(x, y, z);
  }
  return n;
}

ConveyorSettings ConveyorSettings::variant(const std::string& name) {
  ConveyorSettings s;
  if (name == "chapter") return s;
  if (name == "wide-plane") {  // the plane holds an even larger share of the points
    s.plane_x = 500;
    s.plane_y = 350;
    return s;
  }
  if (name == "small-features") {
    s.box_size = {28, 28, 16};
    s.cap_radius = 20;
    s.cap_height = 9;
    return s;
  }
  if (name == "large-offset") {
    s.rotation_deg = 25;
    s.translation = {25, -15, 8};
    return s;
  }
  if (name == "extreme") {  // all three at once: the median rule locks onto the plane here
    s.plane_x = 400;
    s.plane_y = 280;
    s.box_size = {24, 24, 12};
    s.cap_radius = 16;
    s.cap_height = 7;
    s.rotation_deg = 20;
    s.translation = {15, -9, 6};
    return s;
  }
  throw std::invalid_argument("unknown conveyor variant '" + name +
                              "' (chapter, wide-plane, small-features, large-offset, extreme)");
}

Scene make_conveyor_scene(const ConveyorSettings& s) {
  if (s.model_points < 1 || s.scan_model_points < 1 || s.wall_points < 0 ||
      s.scan_model_points > s.model_points)
    throw std::invalid_argument("make_conveyor_scene: inconsistent point counts");
  Random rng(s.seed);
  const Primitives parts = conveyor_parts(s);
  Scene scene;
  scene.model.positions = sample_union(parts, s.model_points, rng);

  // The scan is the model moved by the known transform, with noise (so its 4310 kept points truly
  // correspond to model points, as in the chapter).
  const Eigen::Isometry3d T_scan_model =
      rigid_transform(s.rotation_deg, s.rotation_axis, s.translation);
  std::vector<Eigen::Vector3d> seen = scene.model.positions;
  to_scanner(seen, T_scan_model, s.noise_sigma, rng);
  // Crop the left side away: keep the scan_model_points points farthest to the right (+x).
  std::stable_sort(
      seen.begin(), seen.end(),
      [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.x() > b.x(); });
  seen.resize(static_cast<std::size_t>(s.scan_model_points));

  // The intruder wall: a vertical sheet right of the plane's right edge, in the scanner's frame.
  double right = -1e300, y_lo = 1e300, y_hi = -1e300, z_lo = 1e300;
  for (double x : {-s.plane_x / 2, s.plane_x / 2})
    for (double y : {-s.plane_y / 2, s.plane_y / 2}) {
      const Eigen::Vector3d c = T_scan_model * Eigen::Vector3d(x, y, 0);
      right = std::max(right, c.x());
      y_lo = std::min(y_lo, c.y());
      y_hi = std::max(y_hi, c.y());
      z_lo = std::min(z_lo, c.z());
    }
  std::vector<Eigen::Vector3d> wall;
  wall.reserve(static_cast<std::size_t>(s.wall_points));
  for (int i = 0; i < s.wall_points; ++i)
    wall.emplace_back(right + s.wall_gap, rng.uniform(y_lo, y_hi),
                      rng.uniform(z_lo, z_lo + s.wall_height));
  add_noise(wall, s.noise_sigma, rng);

  scene.scan.positions = std::move(seen);
  scene.scan.positions.insert(scene.scan.positions.end(), wall.begin(), wall.end());
  scene.scan_corresponding = static_cast<std::size_t>(s.scan_model_points);
  scene.scan_outliers = wall.size();
  scene.T_model_scan = T_scan_model.inverse();
  return scene;
}

Scene make_object_scene(const ObjectSettings& s) {
  if (s.points < 10 || !(s.overlap > 0 && s.overlap <= 1) || s.outlier_fraction < 0 ||
      s.outlier_fraction >= 1)
    throw std::invalid_argument("make_object_scene: bad settings");
  Random rng(s.seed);
  Primitives parts;
  if (s.shape == "bracket") {  // an L-bracket with a boss and a dome
    parts.push_back(
        std::make_unique<BoxPrimitive>(Eigen::Vector3d(-40, -25, 0), Eigen::Vector3d(40, 25, 10)));
    parts.push_back(
        std::make_unique<BoxPrimitive>(Eigen::Vector3d(28, -25, 0), Eigen::Vector3d(40, 25, 55)));
    parts.push_back(std::make_unique<CylinderPrimitive>(Eigen::Vector2d(-18, 8), 9, 0, 24));
    parts.push_back(std::make_unique<SphereCap>(Eigen::Vector3d(0, -10, 2), 11, 10));
  } else if (s.shape == "bumpy-sphere") {  // a sphere carrying four large domes and a post
    parts.push_back(std::make_unique<SphereCap>(Eigen::Vector3d(0, 0, 0), 30, -30));
    const Eigen::Vector3d bumps[4] = {{26, 0, 12}, {-8, 24, 14}, {-12, -20, 18}, {5, 5, 29}};
    for (const auto& b : bumps) parts.push_back(std::make_unique<SphereCap>(b, 12, -1e9));
    parts.push_back(std::make_unique<CylinderPrimitive>(Eigen::Vector2d(12, -12), 5, 0, 42));
  } else if (s.shape != "animal") {
    throw std::invalid_argument("unknown object shape '" + s.shape +
                                "' (bracket, bumpy-sphere, animal)");
  }
  // The animal is made of ellipsoids (shapes.hpp, as the range scans of it are rendered).
  const std::vector<Shape> animal = s.shape == "animal" ? animal_shapes() : std::vector<Shape>{};
  std::uint64_t draws = 0;
  auto sample = [&] {
    if (animal.empty()) return sample_union(parts, s.points, rng);
    return sample_surface(animal, s.points, splitmix64(s.seed + ++draws)).positions;
  };
  Scene scene;
  scene.model.positions = sample();

  // The view: the `overlap` share of a fresh sampling lying farthest along a view direction.
  std::vector<Eigen::Vector3d> seen = sample();
  const Eigen::Vector3d view = Eigen::Vector3d(0.4, 0.3, 1).normalized();
  std::stable_sort(seen.begin(), seen.end(),
                   [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
                     return a.dot(view) > b.dot(view);
                   });
  seen.resize(static_cast<std::size_t>(s.overlap * static_cast<double>(seen.size())));
  const Eigen::Isometry3d T_scan_model =
      rigid_transform(s.rotation_deg, s.rotation_axis, s.translation);
  to_scanner(seen, T_scan_model, s.noise_sigma, rng);
  scene.scan_corresponding = seen.size();
  scene.scan_outliers =
      add_outliers(seen,
                   static_cast<std::size_t>(s.outlier_fraction * static_cast<double>(seen.size()) /
                                            (1 - s.outlier_fraction)),
                   rng);
  scene.scan.positions = std::move(seen);
  scene.T_model_scan = T_scan_model.inverse();
  return scene;
}

Scene make_parts_scene(const PartsSettings& s) {
  if (s.points < 10 || s.parts < 0 || !(s.overlap > 0 && s.overlap <= 1) ||
      s.outlier_fraction < 0 || s.outlier_fraction >= 1)
    throw std::invalid_argument("make_parts_scene: bad settings");
  constexpr double kFloorX = 1200, kFloorY = 900;
  Random rng(s.seed);
  Primitives cell;
  cell.push_back(std::make_unique<RectanglePrimitive>(
      Eigen::Vector2d(-kFloorX / 2, -kFloorY / 2), Eigen::Vector2d(kFloorX / 2, kFloorY / 2), 0.0));
  cell.push_back(std::make_unique<BoxPrimitive>(Eigen::Vector3d(-kFloorX / 2, kFloorY / 2 - 20, 0),
                                                Eigen::Vector3d(kFloorX / 2, kFloorY / 2, 250)));
  // Parts on a grid of cells (8 columns), each a box, a cylinder or a dome jittered in its cell.
  const int columns = 8, rows = std::max(1, (s.parts + columns - 1) / columns);
  const double cx = kFloorX / columns, cy = (kFloorY - 60) / rows;
  for (int i = 0; i < s.parts; ++i) {
    const Eigen::Vector2d centre(-kFloorX / 2 + (i % columns + 0.5) * cx + rng.uniform(-15, 15),
                                 -kFloorY / 2 + (i / columns + 0.5) * cy + rng.uniform(-15, 15));
    const double r = rng.uniform(0.2, 0.4) * std::min(cx, cy);
    switch (i % 3) {
      case 0: {
        const Eigen::Vector3d half(r, rng.uniform(0.5, 1.0) * r, 0);
        const double h = rng.uniform(20, 120);
        cell.push_back(
            std::make_unique<BoxPrimitive>(Eigen::Vector3d(centre.x(), centre.y(), 0) - half,
                                           Eigen::Vector3d(centre.x(), centre.y(), h) + half));
        break;
      }
      case 1:
        cell.push_back(std::make_unique<CylinderPrimitive>(centre, r, 0, rng.uniform(20, 150)));
        break;
      default: {
        const double h = rng.uniform(0.4, 0.9) * r;
        cell.push_back(
            std::make_unique<SphereCap>(Eigen::Vector3d(centre.x(), centre.y(), h - r), r, 0.0));
      }
    }
  }
  Scene scene;
  scene.model.positions = sample_union(cell, s.points, rng);

  // The view: an independent sampling, cropped to the share farthest along +x.
  std::vector<Eigen::Vector3d> seen =
      sample_union(cell, static_cast<int>(std::ceil(s.points / s.overlap)), rng);
  std::stable_sort(
      seen.begin(), seen.end(),
      [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.x() > b.x(); });
  seen.resize(static_cast<std::size_t>(s.points));
  const Eigen::Isometry3d T_scan_model =
      rigid_transform(s.rotation_deg, s.rotation_axis, s.translation);
  to_scanner(seen, T_scan_model, s.noise_sigma, rng);
  scene.scan_corresponding = seen.size();
  scene.scan_outliers =
      add_outliers(seen, static_cast<std::size_t>(s.outlier_fraction * s.points), rng);
  scene.scan.positions = std::move(seen);
  scene.T_model_scan = T_scan_model.inverse();
  return scene;
}

PlateSettings chapter_plate(std::uint64_t scene_seed, bool cluttered) {
  PlateSettings s;
  s.seed = scene_seed + (cluttered ? 2 : 1);
  if (cluttered) s.clutter_fraction = 0.2;
  return s;
}

Plate make_plate(const PlateSettings& s) {
  if (s.points < 3 || s.clutter_fraction < 0 || s.clutter_fraction >= 1)
    throw std::invalid_argument("make_plate: bad settings");
  Random rng(s.seed);
  const auto clutter = static_cast<int>(s.clutter_fraction * s.points);
  Plate plate;
  plate.plate_points = static_cast<std::size_t>(s.points - clutter);
  std::vector<Eigen::Vector3d> points;
  // The plate (z = 0 in its own frame), minus the part's footprint when there is a part.
  Primitives sheet;
  sheet.push_back(
      std::make_unique<RectanglePrimitive>(Eigen::Vector2d(-s.size_x / 2, -s.size_y / 2),
                                           Eigen::Vector2d(s.size_x / 2, s.size_y / 2), 0.0));
  Primitives part;
  part.push_back(
      std::make_unique<BoxPrimitive>(Eigen::Vector3d(5, -12, 0), Eigen::Vector3d(35, 18, 30)));
  if (clutter > 0)
    sheet.push_back(
        std::make_unique<BoxPrimitive>(Eigen::Vector3d(5, -12, 0), Eigen::Vector3d(35, 18, 30)));
  // Sample only the sheet's points from the union (the box there just hides its footprint).
  while (static_cast<int>(points.size()) < s.points - clutter) {
    const Eigen::Vector3d p = sheet[0]->sample(rng);
    if (sheet.size() == 1 || !sheet[1]->contains(p)) points.push_back(p);
  }
  const std::vector<Eigen::Vector3d> on_part = sample_union(part, clutter, rng);
  points.insert(points.end(), on_part.begin(), on_part.end());
  const Eigen::Isometry3d T =
      rigid_transform(s.tilt_deg, s.tilt_axis, Eigen::Vector3d(0, 0, s.height));
  for (auto& p : points) p = T * p;
  add_noise(points, s.noise_sigma, rng);
  plate.cloud.positions = std::move(points);
  plate.true_normal = T.linear() * Eigen::Vector3d::UnitZ();
  return plate;
}

}  // namespace align3d::synth
