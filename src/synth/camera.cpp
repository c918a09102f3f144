#include "align3d/synth/camera.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "align3d/se3.hpp"
#include "detail/parallel.hpp"
#include "detail/random.hpp"

namespace align3d::synth {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check(const PinholeCamera& c, const DepthSensorSettings& s) {
  const bool camera_ok = c.width > 0 && c.height > 0 && c.fx > 0 && c.fy > 0 &&
                         std::isfinite(c.fx) && std::isfinite(c.fy) && std::isfinite(c.cx) &&
                         std::isfinite(c.cy);
  const bool sensor_ok = s.min_depth >= 0 && s.max_depth > s.min_depth && s.noise_a >= 0 &&
                         s.noise_b >= 0 && s.max_incidence_deg > 0 && s.max_incidence_deg <= 90 &&
                         s.dropout >= 0 && s.dropout <= 1 && s.hole_clusters >= 0 &&
                         (s.hole_clusters == 0 || s.hole_radius_max >= 1) &&
                         s.projector_offset.allFinite();
  if (!camera_ok) throw std::invalid_argument("render: bad camera size or intrinsics");
  if (!sensor_ok) throw std::invalid_argument("render: bad depth sensor settings");
}

// The geometric part of a pixel: the exact hit in the camera frame, or none (rules 1–3 of the
// header).
struct PixelHit {
  Eigen::Vector3d point{kNaN, kNaN, kNaN};
  int shape = -1;
};

PixelHit cast_pixel(const PinholeCamera& camera, const RayCaster& cast,
                    const DepthSensorSettings& s, const Eigen::Vector3d& projector_world,
                    double min_cos, int u, int v) {
  const Eigen::Isometry3d& T = camera.T_world_camera;
  // The direction has z = 1 in the camera frame, so the ray parameter t is the depth z.
  const Eigen::Vector3d d_camera = camera.pixel_direction(u, v);
  const Ray ray{T.translation(), T.linear() * d_camera};
  const std::optional<Hit> hit = cast(ray, 0, s.max_depth);
  PixelHit out;
  if (!hit || hit->t < s.min_depth) return out;
  // Incidence: cos θ = |n·d| / |d|; sheets may face either way, so n is turned towards the camera.
  const double n_dot_d = hit->normal.dot(ray.direction);
  if (std::abs(n_dot_d) < min_cos * ray.direction.norm()) return out;
  const Eigen::Vector3d n_facing = n_dot_d < 0 ? hit->normal : Eigen::Vector3d(-hit->normal);
  if (s.projector_offset != Eigen::Vector3d::Zero()) {
    // The projector lights the hit only from the side the camera sees, and only with nothing in
    // between: a shadow ray from the hit to the projector (t in (0, 1)) must reach it. The 1e-9
    // margins keep the surface itself (t = 0) and the projector (t = 1) out of the test.
    const Eigen::Vector3d to_projector = projector_world - hit->point;
    if (n_facing.dot(to_projector) <= 0) return out;
    if (cast({hit->point, to_projector}, 1e-9, 1 - 1e-9)) return out;
  }
  out.point = hit->t * d_camera;
  out.shape = hit->shape;
  return out;
}

}  // namespace

Eigen::Isometry3d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                          const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(up);
  if (!(x.norm() > 1e-9 * up.norm()))
    throw std::invalid_argument("look_at: up is parallel to the viewing direction");
  x.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = eye;
  return T;
}

Eigen::Isometry3d downward_camera_pose(double height, double tilt_deg,
                                       const Eigen::Vector3d& axis) {
  Eigen::Matrix3d down;
  down.col(0) = Eigen::Vector3d::UnitX();
  down.col(1) = -Eigen::Vector3d::UnitY();
  down.col(2) = -Eigen::Vector3d::UnitZ();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rigid_transform(tilt_deg, axis).linear() * down;
  const Eigen::Vector3d z = T.linear().col(2);
  if (!(z.z() < -1e-3)) throw std::invalid_argument("the camera does not look down");
  T.translation() = z * (height / z.z());  // on the optical axis through the origin, at `height`
  return T;
}

std::size_t OrganizedCloud::valid_count() const {
  std::size_t n = 0;
  for (const auto& p : positions) n += p.allFinite();
  return n;
}

PointCloud OrganizedCloud::valid_points() const {
  PointCloud cloud;
  cloud.positions.reserve(valid_count());
  for (const auto& p : positions)
    if (p.allFinite()) cloud.positions.push_back(p);
  return cloud;
}

OrganizedCloud render(const PinholeCamera& camera, const std::vector<Shape>& shapes,
                      const DepthSensorSettings& s, std::uint64_t seed) {
  return render_rays(
      camera,
      [&shapes](const Ray& ray, double t_min, double t_max) {
        return cast_ray(shapes, ray, t_min, t_max);
      },
      s, seed);
}

OrganizedCloud render_rays(const PinholeCamera& camera, const RayCaster& cast,
                           const DepthSensorSettings& s, std::uint64_t seed) {
  check(camera, s);
  const auto w = static_cast<std::size_t>(camera.width);
  const std::size_t pixels = w * static_cast<std::size_t>(camera.height);
  const double min_cos = std::cos(deg_to_rad(s.max_incidence_deg));
  const Eigen::Vector3d projector_world = camera.T_world_camera * s.projector_offset;

  std::vector<PixelHit> hits(pixels);
  parallel_for(pixels, s.threads, [&](std::size_t i) {
    hits[i] = cast_pixel(camera, cast, s, projector_world, min_cos, static_cast<int>(i % w),
                         static_cast<int>(i / w));
  });

  // Rule 4 and the noise, drawn in a fixed order independent of the hits.
  Random rng(seed);
  struct Disk {
    double u, v, sq_radius;
  };
  std::vector<Disk> holes;
  for (int k = 0; k < s.hole_clusters; ++k) {
    const double u = rng.uniform(0, camera.width), v = rng.uniform(0, camera.height);
    const double r = rng.uniform(1, s.hole_radius_max);
    holes.push_back({u, v, r * r});
  }
  OrganizedCloud out;
  out.width = camera.width;
  out.height = camera.height;
  out.positions.assign(pixels, Eigen::Vector3d::Constant(kNaN));
  out.shape.assign(pixels, -1);
  for (std::size_t i = 0; i < pixels; ++i) {
    const bool dropped = rng.uniform() < s.dropout;
    const double noise = rng.normal();
    if (hits[i].shape < 0 || dropped) continue;
    const double u = static_cast<double>(i % w), v = static_cast<double>(i / w);
    bool in_hole = false;
    for (const Disk& d : holes)
      in_hole = in_hole || (u - d.u) * (u - d.u) + (v - d.v) * (v - d.v) <= d.sq_radius;
    if (in_hole) continue;
    // Depth noise along the ray: z' = z + σ(z)·ε moves the point to p·z'/z.
    const double z = hits[i].point.z();
    out.positions[i] = hits[i].point * ((z + s.sigma(z) * noise) / z);
    out.shape[i] = hits[i].shape;
  }
  return out;
}

}  // namespace align3d::synth
