#include "align3d/synth/depth_scenes.hpp"

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include "align3d/se3.hpp"
#include "detail/random.hpp"

namespace align3d::synth {
namespace {

Eigen::Isometry3d translation(double x, double y, double z) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

// A box given by its lower and upper corners (axis-aligned in the frame it is given in).
Box corner_box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d c = (lo + hi) / 2;
  return {translation(c.x(), c.y(), c.z()), (hi - lo) / 2};
}

Eigen::AlignedBox3d bounding_box(const std::vector<Shape>& shapes) {
  Eigen::AlignedBox3d box;
  for (const Shape& s : shapes) box.extend(bounding_box(s));
  return box;
}

// A footprint on the bin's bottom: the circle about `centre` holding the bounding box's xy.
struct Footprint {
  Eigen::Vector2d centre;
  double radius;
};

// The largest horizontal distance from the vertical axis through the origin to a point of the
// shape (a bound for cylinders and spheres: the centre's distance plus the radius; exact for boxes,
// whose farthest point is a corner).
double horizontal_reach(const Shape& shape) {
  if (const auto* b = std::get_if<Box>(&shape)) {
    double r = 0;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d sign(corner & 1 ? 1 : -1, corner & 2 ? 1 : -1, corner & 4 ? 1 : -1);
      r = std::max(r, (b->pose * sign.cwiseProduct(b->half_size)).head<2>().norm());
    }
    return r;
  }
  if (const auto* c = std::get_if<Cylinder>(&shape)) {
    const Eigen::Vector3d axis = c->half_height * c->pose.linear().col(2);
    return std::max((c->pose.translation() + axis).head<2>().norm(),
                    (c->pose.translation() - axis).head<2>().norm()) +
           c->radius;
  }
  if (const auto* s = std::get_if<Sphere>(&shape)) return s->centre.head<2>().norm() + s->radius;
  throw std::invalid_argument("make_bin_scene: only boxes, cylinders and spheres are placed");
}

// Places `parts` (given about a vertical axis through their local origin, in any orientation) at
// a random spot of the bin's floor [lo, hi] (xy) whose footprint clears every placed one, resting
// on z = floor_z. Returns the world transform applied to them, or nothing when 500 random spots
// were all taken.
std::optional<Eigen::Isometry3d> place(const std::vector<Shape>& parts, const Eigen::Vector2d& lo,
                                       const Eigen::Vector2d& hi, double floor_z,
                                       std::vector<Footprint>& placed, Random& rng) {
  constexpr double kGap = 4;  // mm between footprints
  constexpr int kTries = 500;
  double radius = 0;
  for (const Shape& p : parts) radius = std::max(radius, horizontal_reach(p));
  const double lowest = bounding_box(parts).min().z();
  for (int attempt = 0; attempt < kTries; ++attempt) {
    const Eigen::Vector2d c(rng.uniform(lo.x() + radius, hi.x() - radius),
                            rng.uniform(lo.y() + radius, hi.y() - radius));
    if (c.x() - radius < lo.x() || c.y() - radius < lo.y()) continue;  // larger than the bin
    bool clear = true;
    for (const Footprint& f : placed)
      clear = clear && (f.centre - c).norm() > f.radius + radius + kGap;
    if (!clear) continue;
    placed.push_back({c, radius});
    return translation(c.x(), c.y(), floor_z - lowest);
  }
  return std::nullopt;
}

// A random rotation: yaw uniform about z, then a tilt of up to `max_tilt_deg` about a random
// horizontal axis.
Eigen::Matrix3d random_attitude(double max_tilt_deg, Random& rng) {
  const double yaw = rng.uniform(0, 360), axis_angle = rng.uniform(0, 2 * 3.14159265358979323846);
  const double tilt = rng.uniform(0, max_tilt_deg);
  const Eigen::Vector3d axis(std::cos(axis_angle), std::sin(axis_angle), 0);
  return rigid_transform(tilt, axis).linear() *
         rigid_transform(yaw, Eigen::Vector3d::UnitZ()).linear();
}

// One clutter part about its local origin: a box, an upright or lying cylinder, or a sphere, with
// dimensions (extents) between 30 and 120 mm.
Shape random_clutter(Random& rng) {
  const int kind = static_cast<int>(rng.below(4));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rigid_transform(rng.uniform(0, 360), Eigen::Vector3d::UnitZ()).linear();
  if (kind == 0) {
    const double x = rng.uniform(15, 60), y = rng.uniform(15, 50), z = rng.uniform(15, 40);
    return Box{pose, {x, y, z}};
  }
  const double radius = rng.uniform(15, 40), half_height = rng.uniform(15, 60);
  if (kind == 1) return Cylinder{pose, radius, half_height};
  if (kind == 2) {  // lying on its side: the axis turned horizontal
    pose.linear() = pose.linear() * rigid_transform(90, Eigen::Vector3d::UnitX()).linear();
    return Cylinder{pose, radius, half_height};
  }
  return Sphere{Eigen::Vector3d::Zero(), radius};
}

// The bin: a bottom slab and four walls standing on it.
std::vector<Shape> bin_shapes(const Eigen::Vector3d& size, double wall) {
  const double x = size.x() / 2, y = size.y() / 2, h = size.z();
  return {corner_box({-x, -y, 0}, {x, y, wall}), corner_box({-x, -y, wall}, {-x + wall, y, h}),
          corner_box({x - wall, -y, wall}, {x, y, h}),
          corner_box({-x + wall, -y, wall}, {x - wall, -y + wall, h}),
          corner_box({-x + wall, y - wall, wall}, {x - wall, y, h})};
}

}  // namespace

std::vector<Shape> test_object_shapes() {
  return {corner_box({-70, -40, 0}, {70, 40, 30}),         // base block
          corner_box({48, -34, 10}, {66, 34, 75}),         // upright wall
          Cylinder{translation(-35, 12, 42.5), 16, 22.5},  // boss, z 20..65
          Sphere{{5, -22, 34}, 16}};                       // knob
}

std::vector<Shape> animal_shapes() {
  struct Part {
    Eigen::Vector3d centre, half_axes;
    double pitch_deg, yaw_deg;
  };
  const Part parts[] = {{{0, 0, 45}, {34, 16, 17}, 0, 0},       // body
                        {{30, 0, 62}, {9, 8, 18}, -35, 0},      // neck
                        {{42, 2, 78}, {14, 8, 9}, 0, 10},       // head
                        {{54, 4, 74}, {8, 5, 5}, 10, 10},       // snout
                        {{38, 7, 87}, {2.5, 2, 6}, 0, 20},      // ears
                        {{36, -5, 87}, {2.5, 2, 6}, -25, -10},  //
                        {{22, 9, 22}, {5, 5, 22}, 5, 0},        // front legs
                        {{22, -9, 22}, {5, 5, 22}, -5, 0},      //
                        {{-24, 9, 22}, {6, 6, 22}, 10, 0},      // hind legs
                        {{-24, -9, 22}, {6, 6, 22}, 10, 0},     //
                        {{-40, 2, 55}, {14, 3, 3}, -35, 15}};   // tail
  std::vector<Shape> out;
  for (const Part& p : parts)
    out.push_back(Ellipsoid{Eigen::Translation3d(p.centre) *
                                rigid_transform(p.yaw_deg, Eigen::Vector3d::UnitZ()) *
                                rigid_transform(p.pitch_deg, Eigen::Vector3d::UnitY()),
                            p.half_axes});
  return out;
}

PointCloud test_object_model(int points, std::uint64_t seed) {
  return sample_surface(test_object_shapes(), points, seed);
}

BinScene make_bin_scene(const BinSceneSettings& s) {
  if (s.instances < 0 || s.clutter < 0 || s.camera_height <= 0 || s.bin_wall <= 0 ||
      !(s.bin_size.array() > 2 * s.bin_wall).all() || s.max_instance_tilt_deg < 0)
    throw std::invalid_argument("make_bin_scene: bad settings");
  Random rng(s.seed);
  BinScene scene;
  scene.model = test_object_model(s.model_points, s.seed);
  scene.shapes.push_back(Plane{Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()});  // the floor
  for (const Shape& b : bin_shapes(s.bin_size, s.bin_wall)) scene.shapes.push_back(b);

  const Eigen::Vector2d lo = -s.bin_size.head<2>() / 2 + Eigen::Vector2d::Constant(s.bin_wall);
  const Eigen::Vector2d hi = -lo;
  std::vector<Footprint> placed;
  std::vector<Eigen::Isometry3d> T_world_object;
  for (int k = 0; k < s.instances; ++k) {
    Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
    R.linear() = random_attitude(s.max_instance_tilt_deg, rng);
    std::vector<Shape> parts;
    for (const Shape& p : test_object_shapes()) parts.push_back(transformed(p, R));
    const std::optional<Eigen::Isometry3d> T = place(parts, lo, hi, s.bin_wall, placed, rng);
    if (!T)
      throw std::invalid_argument("make_bin_scene: " + std::to_string(s.instances) +
                                  " instances do not fit into the bin (" + std::to_string(k) +
                                  " placed)");
    T_world_object.push_back(*T * R);
  }
  for (int k = 0; k < s.clutter; ++k) {  // clutter only fills the room the instances left
    const Shape part = random_clutter(rng);
    if (const auto T = place({part}, lo, hi, s.bin_wall, placed, rng)) {
      scene.shapes.push_back(transformed(part, *T));
      ++scene.clutter;
    }
  }
  scene.shape_instance.assign(scene.shapes.size(), -1);
  for (int k = 0; k < s.instances; ++k)
    for (const Shape& p : test_object_shapes()) {
      scene.shapes.push_back(transformed(p, T_world_object[static_cast<std::size_t>(k)]));
      scene.shape_instance.push_back(k);
    }

  scene.camera = s.camera;
  scene.camera.T_world_camera =
      downward_camera_pose(s.camera_height, s.camera_tilt_deg, s.camera_tilt_axis);
  const Eigen::Isometry3d T_camera_world = scene.camera.T_world_camera.inverse();
  scene.cloud = render(scene.camera, scene.shapes, s.sensor, splitmix64(s.seed + 1));
  scene.instance.resize(scene.cloud.shape.size());
  for (std::size_t i = 0; i < scene.instance.size(); ++i)
    scene.instance[i] = scene.cloud.shape[i] < 0
                            ? -1
                            : scene.shape_instance[static_cast<std::size_t>(scene.cloud.shape[i])];
  for (const auto& T : T_world_object) scene.T_camera_object.push_back(T_camera_world * T);
  scene.floor = {T_camera_world.linear() * Eigen::Vector3d::UnitZ(),
                 T_camera_world * Eigen::Vector3d::Zero()};
  return scene;
}

ObjectViews make_object_views(const ObjectViewsSettings& s) {
  if (s.azimuth_deg.empty()) throw std::invalid_argument("make_object_views: no azimuth");
  if (s.object != "part" && s.object != "animal")
    throw std::invalid_argument("make_object_views: unknown object '" + s.object +
                                "' (part or animal)");
  const std::vector<Shape> object = s.object == "animal" ? animal_shapes() : test_object_shapes();
  ObjectViews out;
  out.model = sample_surface(object, s.model_points, s.seed);
  const Eigen::Vector3d target(0, 0, s.target_height);
  const double e = deg_to_rad(s.elevation_deg);
  for (std::size_t k = 0; k < s.azimuth_deg.size(); ++k) {
    const double a = deg_to_rad(s.azimuth_deg[k]);
    const Eigen::Vector3d eye =
        target + s.distance * Eigen::Vector3d(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a),
                                              std::sin(e));
    for (const Shape& p : object)
      if (contains(p, eye))
        throw std::invalid_argument("make_object_views: the camera is inside the object");
    PinholeCamera camera = s.camera;
    camera.T_world_camera = look_at(eye, target, Eigen::Vector3d::UnitZ());
    out.views.push_back(render(camera, object, s.sensor, splitmix64(s.seed + k + 1)));
    out.cameras.push_back(camera);
    out.T_camera_object.push_back(camera.T_world_camera.inverse());
  }
  return out;
}

}  // namespace align3d::synth
