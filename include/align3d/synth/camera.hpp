// A simulated depth camera: a pinhole that ray-casts a union of shapes (synth/shapes.hpp) into an
// organized cloud, with the failures of real sensors. Units: millimetres and pixels.
//
// Camera frame (the usual depth-camera convention): x right, y down, z forward (the optical axis).
// Pixel (u, v) is column u, row v, its centre at image coordinates (u, v) (OpenCV's convention):
// its ray is the direction ((u − cx) / fx, (v − cy) / fy, 1) in the camera frame, and a point p on
// it projects to u = cx + fx·p.x / p.z, v = cy + fy·p.y / p.z.
//
// What a pixel holds, in this order of rules (the first that applies gives NaN):
//   1. no surface along the ray, or the depth z of the hit outside [min_depth, max_depth];
//   2. grazing incidence: the angle between the ray and the surface normal above
//      max_incidence_deg (real sensors get no return there);
//   3. projector shadow: with a structured-light projector at `projector_offset`, a hit the
//      projector cannot see (another surface lies between them) gets no pattern, as the shadow
//      band a Kinect leaves beside every object;
//   4. dropout: the pixel is lost at random with probability `dropout`, or lies in one of
//      `hole_clusters` disks of missing pixels (radius uniform in [1, hole_radius_max] pixels);
// otherwise the hit moved along its ray by Gaussian depth noise of σ(z) = noise_a + noise_b·z²
// (Khoshelham and Elberink 2012 measured σ ≈ 1.4·10⁻⁶ mm⁻¹ · z² for the Kinect v1).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "align3d/point_cloud.hpp"
#include "align3d/synth/shapes.hpp"

namespace align3d::synth {

struct PinholeCamera {
  int width = 640, height = 480;
  double fx = 525, fy = 525, cx = 319.5, cy = 239.5;  // pixels; PrimeSense/Kinect v1 defaults
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();  // world ≈ T·camera

  // The ray through pixel (u, v) in the camera frame, with z = 1 (not unit length).
  Eigen::Vector3d pixel_direction(double u, double v) const {
    return {(u - cx) / fx, (v - cy) / fy, 1.0};
  }
  // Image coordinates (u, v) of a camera-frame point with z > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    return {cx + fx * p.x() / p.z(), cy + fy * p.y() / p.z()};
  }
};

// T_world_camera of a camera at `eye` looking at `target`, with `up` (world) appearing upwards in
// the image (−y): z = (target − eye)/|·|, x = z × up/|·|, y = z × x. Throws std::invalid_argument
// when up is parallel to the viewing direction.
Eigen::Isometry3d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                          const Eigen::Vector3d& up);

// T_world_camera of a camera looking straight down on the plane z = 0 (image up = world +y), tilted
// by `tilt_deg` about the horizontal `axis`, its optical axis through the world origin and the
// camera `height` above z = 0. Throws std::invalid_argument when the tilt leaves it not looking
// down.
Eigen::Isometry3d downward_camera_pose(double height, double tilt_deg, const Eigen::Vector3d& axis);

// Defaults: a Kinect-like structured-light camera working from 0.4 to 3 m.
struct DepthSensorSettings {
  double min_depth = 400, max_depth = 3000;    // mm, on the camera's z
  double noise_a = 0.5;                        // σ(z) = noise_a + noise_b·z²: 0.5 mm
  double noise_b = 1.425e-6;                   // mm⁻¹: 1.6 mm at z = 0.9 m, 1.9 mm at 1 m
  double max_incidence_deg = 75;               // NaN beyond this angle from the normal
  Eigen::Vector3d projector_offset{75, 0, 0};  // camera frame; (0, 0, 0): no projector shadows
  double dropout = 0.01;                       // probability that any pixel is lost
  int hole_clusters = 25;                      // disks of missing pixels
  double hole_radius_max = 4;                  // pixels
  int threads = 0;  // 0: OpenMP's default; the output does not depend on it

  double sigma(double z) const { return noise_a + noise_b * z * z; }
};

// One point per pixel, row-major (index v·width + u), in the camera frame; NaN where the sensor
// returned nothing.
struct OrganizedCloud {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3d> positions;
  std::vector<int> shape;  // per pixel: index of the shape the point lies on, −1 where NaN

  const Eigen::Vector3d& at(int u, int v) const {
    return positions[static_cast<std::size_t>(v) * width + u];
  }
  std::size_t valid_count() const;
  PointCloud valid_points() const;  // the finite points, in row-major order
};

// Renders `shapes` (world frame) seen by `camera`. Deterministic for `seed`: the random draws (hole
// disks, then one dropout draw and one noise draw per pixel in row-major order) do not depend on
// the geometry, so the same seed over another scene loses the same pixels. Settings with no noise,
// dropout and holes give the exact ray-cast. Throws std::invalid_argument for a bad size or
// focal length, or negative noise, dropout or ranges.
OrganizedCloud render(const PinholeCamera& camera, const std::vector<Shape>& shapes,
                      const DepthSensorSettings& sensor, std::uint64_t seed);

// The same sensor over any scene: `cast` returns the nearest hit of a world-frame ray with
// t_min < t < t_max (Hit::shape: the label the pixel gets, >= 0; Hit::normal: unit, either side),
// and is called from several threads at once. render(camera, shapes, …) is this with cast_ray.
using RayCaster = std::function<std::optional<Hit>(const Ray& ray, double t_min, double t_max)>;
OrganizedCloud render_rays(const PinholeCamera& camera, const RayCaster& cast,
                           const DepthSensorSettings& sensor, std::uint64_t seed);

}  // namespace align3d::synth
