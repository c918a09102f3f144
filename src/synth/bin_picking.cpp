#include "align3d/synth/bin_picking.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "align3d/mesh_index.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/part.hpp"
#include "detail/parallel.hpp"
#include "detail/random.hpp"

namespace align3d::synth {
namespace {

constexpr int kMaxInstances = 12;
constexpr int kPlacementTries = 50;
constexpr std::size_t kCollisionSamples = 4000;  // surface samples per object for the drop test
constexpr double kDropStep = 2;                  // mm: the coarse descent, then bisection

using Triangle = std::array<std::uint32_t, 3>;

void add_quad(TriangleMesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c,
              std::uint32_t d) {  // a b c d counter-clockwise seen from outside
  m.triangles.push_back({a, b, c});
  m.triangles.push_back({a, c, d});
}

// A solid placed in the world: its mesh's index, world bounding box and surface samples.
struct Object {
  std::unique_ptr<MeshIndex> index;
  Eigen::AlignedBox3d box;
  std::vector<Eigen::Vector3d> samples;
  int label = -1;  // the instance index, −1 for the bin and the distractors
};

Object make_object(const TriangleMesh& world_mesh, int label, std::uint64_t seed) {
  Object o;
  o.index = std::make_unique<MeshIndex>(world_mesh, 1, "synth object");
  for (const auto& v : world_mesh.vertices) o.box.extend(v);
  o.samples = sample_surface(world_mesh, kCollisionSamples, seed).positions;
  o.samples.insert(o.samples.end(), world_mesh.vertices.begin(), world_mesh.vertices.end());
  o.label = label;
  return o;
}

// Whether any of `samples` (bounding box `box`) lies closer than `clearance` to `b`'s surface or
// inside it. Only a band of kBand about the surface is searched: the drop moves samples by at
// most kDropStep from free positions, so none can be deeper inside without having crossed it.
bool too_close(const std::vector<Eigen::Vector3d>& samples, const Eigen::AlignedBox3d& box,
               const Object& b, double clearance) {
  const double band = kDropStep + clearance + 0.5;
  const Eigen::AlignedBox3d grown(b.box.min().array() - band, b.box.max().array() + band);
  if (!grown.intersects(box)) return false;
  for (const auto& p : samples) {
    SurfacePoint s;
    if (grown.contains(p) && b.index->closest(p, s, band * band) &&
        b.index->signed_distance(p, s) < clearance)
      return true;
  }
  return false;
}

// Whether `local` (an object in its own frame) moved by T comes too close to any placed object,
// tested with the samples of each against the other (thin parts slip between one side's samples).
bool collides(const Object& local, const Eigen::Isometry3d& T, const std::vector<Object>& placed,
              double clearance) {
  std::vector<Eigen::Vector3d> samples;
  samples.reserve(local.samples.size());
  Eigen::AlignedBox3d box;
  for (const auto& p : local.samples) box.extend(samples.emplace_back(T * p));
  const Eigen::Isometry3d Ti = T.inverse();
  const double band = kDropStep + clearance + 0.5;
  const Eigen::AlignedBox3d near(box.min().array() - band, box.max().array() + band);
  std::vector<Eigen::Vector3d> back;
  for (const Object& o : placed) {
    if (too_close(samples, box, o, clearance)) return true;
    back.clear();
    for (const auto& p : o.samples)
      if (near.contains(p)) back.push_back(Ti * p);
    if (!back.empty() && too_close(back, local.box, local, clearance)) return true;
  }
  return false;
}

Eigen::Matrix3d random_rotation(Random& rng) {
  Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
  return q.normalized().toRotationMatrix();
}

// Drops `mesh` (local frame) at a random orientation over a random spot of [lo, hi]: lowered in
// kDropStep steps from above everything, then the contact height bisected to 0.05 mm. Returns
// the world pose, or nothing when no spot in kPlacementTries lets it in.
std::optional<Eigen::Isometry3d> drop(const TriangleMesh& mesh, const Object& local,
                                      const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                                      double top, const std::vector<Object>& placed,
                                      double clearance, Random& rng) {
  for (int attempt = 0; attempt < kPlacementTries; ++attempt) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = random_rotation(rng);
    Eigen::AlignedBox3d box;
    for (const auto& v : mesh.vertices) box.extend(T.linear() * v);
    const Eigen::Vector2d half = 0.5 * (box.max() - box.min()).head<2>();
    if ((hi - lo - 2 * half).minCoeff() < 0) continue;  // this attitude does not fit the bin
    const Eigen::Vector2d c(rng.uniform(lo.x() + half.x(), hi.x() - half.x()),
                            rng.uniform(lo.y() + half.y(), hi.y() - half.y()));
    const Eigen::Vector2d centre = 0.5 * (box.min() + box.max()).head<2>();
    double above = top - box.min().z();  // the lowest point at `top`
    T.translation() << c.x() - centre.x(), c.y() - centre.y(), above;
    if (collides(local, T, placed, clearance)) continue;  // no room even at the top
    double below = above;
    while (true) {
      T.translation().z() = below - kDropStep;
      if (collides(local, T, placed, clearance)) break;
      above = below -= kDropStep;
    }
    below -= kDropStep;  // [below, above]: a collision, then free
    while (above - below > 0.05) {
      T.translation().z() = 0.5 * (above + below);
      (collides(local, T, placed, clearance) ? below : above) = T.translation().z();
    }
    T.translation().z() = above;
    return T;
  }
  return std::nullopt;
}

TriangleMesh distractor(Random& rng) {
  const int kind = static_cast<int>(rng.below(3));
  if (kind == 0) return box_mesh({rng.uniform(15, 55), rng.uniform(15, 55), rng.uniform(15, 40)});
  if (kind == 1) return cylinder_mesh(rng.uniform(15, 40), rng.uniform(15, 55), 48);
  return sphere_mesh(rng.uniform(15, 35), 16);
}

std::vector<TriangleMesh> bin_walls(const BinPickingSettings& s) {
  const double x = s.bin_size.x() / 2, y = s.bin_size.y() / 2, h = s.bin_size.z(), w = s.bin_wall;
  auto slab = [](const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    return transformed(box_mesh((hi - lo) / 2),
                       Eigen::Isometry3d(Eigen::Translation3d((hi + lo) / 2)));
  };
  return {slab({-x - 200, -y - 200, -10}, {x + 200, y + 200, 0}),  // the floor under the bin
          slab({-x, -y, 0}, {x, y, w}),                            // the bin's bottom
          slab({-x, -y, w}, {-x + w, y, h}),
          slab({x - w, -y, w}, {x, y, h}),
          slab({-x + w, -y, w}, {x - w, -y + w, h}),
          slab({-x + w, y - w, w}, {x - w, y, h})};
}

void check(const BinPickingSettings& s) {
  if (s.instances < 0 || s.instances > kMaxInstances)
    throw std::invalid_argument("bin picking scene: instances must be 0 to 12");
  if (s.distractors < 0 || s.distractors > 20)
    throw std::invalid_argument("bin picking scene: distractors must be 0 to 20");
  if (!(s.bin_wall > 0) || !(s.bin_size.minCoeff() > 2 * s.bin_wall) || !(s.clearance > 0) ||
      !(s.camera_height > s.bin_size.z()))
    throw std::invalid_argument("bin picking scene: bad bin, clearance or camera height");
}

// The nearest hit among `objects` (world-frame ray); Hit::shape = the object's index.
std::optional<Hit> cast_objects(const std::vector<Object>& objects, const Ray& ray, double t_min,
                                double t_max) {
  std::optional<Hit> best;
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const Object& o = objects[k];
    // Slab test against the box before the hierarchy.
    double lo = t_min, hi = t_max;
    for (int a = 0; a < 3 && lo <= hi; ++a) {
      const double inv = 1.0 / ray.direction[a];
      double t0 = (o.box.min()[a] - ray.origin[a]) * inv,
             t1 = (o.box.max()[a] - ray.origin[a]) * inv;
      if (t0 > t1) std::swap(t0, t1);
      lo = std::max(lo, t0);
      hi = std::min(hi, t1);
    }
    if (lo > hi) continue;
    RayHit h;
    if (!o.index->intersect(ray.origin, ray.direction, h, t_min, t_max)) continue;
    t_max = h.t;
    best = Hit{h.t, ray.origin + h.t * ray.direction, o.index->face_normal(h.triangle),
               static_cast<int>(k)};
  }
  return best;
}

// Exact (sensor-free) pixel counts per instance: where it is the first surface hit, and where its
// ray meets it at all (it alone in front of the camera), within the sensor's depth range.
void visible_fractions(const PinholeCamera& camera, const std::vector<Object>& objects,
                       const DepthSensorSettings& sensor, std::vector<BinPickingInstance>& out) {
  const std::size_t w = static_cast<std::size_t>(camera.width);
  const std::size_t pixels = w * static_cast<std::size_t>(camera.height);
  std::vector<std::vector<std::uint32_t>> hits(pixels);  // instances hit; first: the front one
  parallel_for(pixels, sensor.threads, [&](std::size_t i) {
    const Eigen::Vector3d d =
        camera.T_world_camera.linear() *
        camera.pixel_direction(static_cast<double>(i % w), static_cast<double>(i / w));
    const Ray ray{camera.T_world_camera.translation(), d};
    const std::optional<Hit> front = cast_objects(objects, ray, sensor.min_depth, sensor.max_depth);
    if (front && objects[static_cast<std::size_t>(front->shape)].label >= 0)
      hits[i].push_back(static_cast<std::uint32_t>(objects[front->shape].label) + 1);
    else
      hits[i].push_back(0);
    for (const Object& o : objects) {
      RayHit h;
      if (o.label >= 0 && o.index->intersect(ray.origin, d, h, sensor.min_depth, sensor.max_depth))
        hits[i].push_back(static_cast<std::uint32_t>(o.label));
    }
  });
  std::vector<std::size_t> front(out.size()), alone(out.size());
  for (const auto& h : hits) {
    if (h[0] > 0) ++front[h[0] - 1];
    for (std::size_t k = 1; k < h.size(); ++k) ++alone[h[k]];
  }
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k].visible_fraction =
        alone[k] ? static_cast<double>(front[k]) / static_cast<double>(alone[k]) : 0.0;
}

// The drop order: K instances (as k >= 0) and D distractors (−1) shuffled (Fisher–Yates).
std::vector<int> drop_order(int instances, int distractors, Random& rng) {
  std::vector<int> order;
  for (int k = 0; k < instances; ++k) order.push_back(k);
  order.insert(order.end(), static_cast<std::size_t>(distractors), -1);
  for (std::size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.below(i)]);
  return order;
}

}  // namespace

const char* to_string(BinPart part) {
  switch (part) {
    case BinPart::kBracket:
      return "bracket";
    case BinPart::kFlange:
      return "flange";
    case BinPart::kPlate:
      return "plate";
  }
  return "?";
}

BinPart bin_part_from_string(const std::string& name) {
  for (const BinPart part : {BinPart::kBracket, BinPart::kFlange, BinPart::kPlate})
    if (name == to_string(part)) return part;
  throw std::invalid_argument("unknown part '" + name + "' (bracket, flange or plate)");
}

TriangleMesh box_mesh(const Eigen::Vector3d& h) {
  TriangleMesh m;
  for (int k = 0; k < 8; ++k)
    m.vertices.emplace_back(k & 1 ? h.x() : -h.x(), k & 2 ? h.y() : -h.y(), k & 4 ? h.z() : -h.z());
  add_quad(m, 0, 2, 3, 1);  // −z
  add_quad(m, 4, 5, 7, 6);  // +z
  add_quad(m, 0, 1, 5, 4);  // −y
  add_quad(m, 2, 6, 7, 3);  // +y
  add_quad(m, 0, 4, 6, 2);  // −x
  add_quad(m, 1, 3, 7, 5);  // +x
  return m;
}

TriangleMesh revolve(const std::vector<Eigen::Vector2d>& profile, int segments) {
  if (profile.size() < 3 || segments < 3)
    throw std::invalid_argument("revolve: at least 3 profile points and 3 segments");
  double area2 = 0;  // twice the profile's signed area in the (r, z) plane
  for (std::size_t i = 0; i < profile.size(); ++i) {
    const Eigen::Vector2d& a = profile[i];
    const Eigen::Vector2d& b = profile[(i + 1) % profile.size()];
    if (!(a.x() > 0)) throw std::invalid_argument("revolve: the profile must stay off the axis");
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  const auto n = static_cast<std::uint32_t>(profile.size());
  const auto m_seg = static_cast<std::uint32_t>(segments);
  TriangleMesh m;
  for (std::uint32_t k = 0; k < m_seg; ++k) {
    const double phi = 2 * std::numbers::pi * k / segments;
    for (const auto& p : profile)
      m.vertices.emplace_back(p.x() * std::cos(phi), p.x() * std::sin(phi), p.y());
  }
  for (std::uint32_t k = 0; k < m_seg; ++k)
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t a = k * n + i, b = k * n + (i + 1) % n;
      const std::uint32_t c = ((k + 1) % m_seg) * n + (i + 1) % n, d = ((k + 1) % m_seg) * n + i;
      // A counter-clockwise profile (r right, z up) faces outward with this order.
      if (area2 > 0)
        add_quad(m, a, d, c, b);
      else
        add_quad(m, a, b, c, d);
    }
  return m;
}

TriangleMesh cylinder_mesh(double radius, double half_height, int segments) {
  // A revolved rectangle would leave a pin-hole on the axis: the caps are fans instead.
  if (!(radius > 0) || !(half_height > 0) || segments < 3)
    throw std::invalid_argument("cylinder_mesh: positive sizes and at least 3 segments");
  TriangleMesh m;
  const auto n = static_cast<std::uint32_t>(segments);
  for (std::uint32_t k = 0; k < n; ++k) {
    const double phi = 2 * std::numbers::pi * k / segments;
    m.vertices.emplace_back(radius * std::cos(phi), radius * std::sin(phi), -half_height);
    m.vertices.emplace_back(radius * std::cos(phi), radius * std::sin(phi), half_height);
  }
  m.vertices.emplace_back(0, 0, -half_height);
  m.vertices.emplace_back(0, 0, half_height);
  const std::uint32_t bottom = 2 * n, top = 2 * n + 1;
  for (std::uint32_t k = 0; k < n; ++k) {
    const std::uint32_t j = (k + 1) % n;
    add_quad(m, 2 * k, 2 * j, 2 * j + 1, 2 * k + 1);
    m.triangles.push_back({bottom, 2 * j, 2 * k});
    m.triangles.push_back({top, 2 * k + 1, 2 * j + 1});
  }
  return m;
}

TriangleMesh sphere_mesh(double radius, int rings) {
  if (!(radius > 0) || rings < 2) throw std::invalid_argument("sphere_mesh: bad size or rings");
  TriangleMesh m;
  const auto r = static_cast<std::uint32_t>(rings), n = 2 * r;
  m.vertices.emplace_back(0, 0, -radius);
  for (std::uint32_t i = 1; i < r; ++i) {
    const double theta = std::numbers::pi * i / rings - std::numbers::pi / 2;
    for (std::uint32_t k = 0; k < n; ++k) {
      const double phi = 2 * std::numbers::pi * k / n;
      m.vertices.emplace_back(radius * std::cos(theta) * std::cos(phi),
                              radius * std::cos(theta) * std::sin(phi), radius * std::sin(theta));
    }
  }
  m.vertices.emplace_back(0, 0, radius);
  const auto at = [&](std::uint32_t ring, std::uint32_t k) { return 1 + (ring - 1) * n + k % n; };
  const std::uint32_t north = static_cast<std::uint32_t>(m.vertices.size() - 1);
  for (std::uint32_t k = 0; k < n; ++k) {
    m.triangles.push_back({0, at(1, k + 1), at(1, k)});
    m.triangles.push_back({north, at(r - 1, k), at(r - 1, k + 1)});
    for (std::uint32_t i = 1; i + 1 < r; ++i)
      add_quad(m, at(i, k), at(i, k + 1), at(i + 1, k + 1), at(i + 1, k));
  }
  return m;
}

// The plate of the header: the machined part's description with a plate's sizes.
PartSettings bin_plate_settings() {
  PartSettings s;
  s.block = {110, 70, 10};
  s.chamfer = 1.5;
  s.pocket_min = {-40, -8}, s.pocket_max = {-10, 8};
  s.pocket_depth = 4;
  s.holes = {{{-25, 0}, 4}, {{35, -22}, 5}};
  s.boss_centre = {30, 18};
  s.boss_radius = 7, s.boss_height = 4;
  return s;
}

TriangleMesh bin_part_mesh(BinPart part, int flange_segments) {
  if (part == BinPart::kBracket) return PartModel().mesh();
  if (part == BinPart::kPlate) return PartModel(bin_plate_settings()).mesh();
  // Counter-clockwise in (r, z): bore, bottom, flange rim, flange top, hub, hub top.
  return revolve({{12, 0}, {45, 0}, {45, 10}, {25, 10}, {25, 50}, {12, 50}}, flange_segments);
}

BinPickingScene make_bin_picking_scene(const BinPickingSettings& s) {
  check(s);
  BinPickingScene scene;
  scene.model = bin_part_mesh(s.part);
  const Object part = make_object(scene.model, 0, splitmix64(s.seed + 2));
  std::vector<Object> placed;
  for (const TriangleMesh& wall : bin_walls(s)) placed.push_back(make_object(wall, -1, 1));
  const double x = s.bin_size.x() / 2 - s.bin_wall, y = s.bin_size.y() / 2 - s.bin_wall;
  const Eigen::Vector2d lo(-x, -y), hi(x, y);
  Random rng(s.seed);
  std::vector<Eigen::Isometry3d> T_world_model;
  for (int item : drop_order(s.instances, s.distractors, rng)) {
    double top = s.bin_size.z() + 1;
    for (const Object& o : placed) top = std::max(top, o.box.max().z() + 1);
    const TriangleMesh mesh = item >= 0 ? scene.model : distractor(rng);
    const Object distractor_object =
        item >= 0 ? Object{} : make_object(mesh, -1, rng.below(1u << 30));
    const Object& local = item >= 0 ? part : distractor_object;
    const std::optional<Eigen::Isometry3d> T =
        drop(mesh, local, lo, hi, top, placed, s.clearance, rng);
    if (!T) continue;
    const int label = item >= 0 ? static_cast<int>(T_world_model.size()) : -1;
    placed.push_back(make_object(transformed(mesh, *T), label, 1));
    if (item >= 0)
      T_world_model.push_back(*T);
    else
      ++scene.distractors;
  }
  scene.camera = s.camera;
  scene.camera.T_world_camera =
      downward_camera_pose(s.camera_height, s.camera_tilt_deg, s.camera_tilt_axis);
  const RayCaster cast = [&placed](const Ray& ray, double t_min, double t_max) {
    std::optional<Hit> hit = cast_objects(placed, ray, t_min, t_max);
    if (hit) hit->shape = placed[static_cast<std::size_t>(hit->shape)].label + 1;  // >= 0
    return hit;
  };
  DepthSensorSettings sensor = s.sensor;
  sensor.threads = s.threads;
  scene.cloud = render_rays(scene.camera, cast, sensor, splitmix64(s.seed + 1));
  for (int& label : scene.cloud.shape) label = label > 0 ? label - 1 : -1;
  const Eigen::Isometry3d T_camera_world = scene.camera.T_world_camera.inverse();
  for (const Eigen::Isometry3d& T : T_world_model) scene.instances.push_back({T_camera_world * T});
  for (const int label : scene.cloud.shape)
    if (label >= 0) ++scene.instances[static_cast<std::size_t>(label)].pixels;
  visible_fractions(scene.camera, placed, sensor, scene.instances);
  scene.floor = {T_camera_world.linear() * Eigen::Vector3d::UnitZ(),
                 T_camera_world * Eigen::Vector3d(0, 0, s.bin_wall)};
  return scene;
}

}  // namespace align3d::synth
