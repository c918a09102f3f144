// Plane correction (chapter 39.5): fit the reference plane, rotate its normal n onto +Z (Rodrigues
// about n × z), then shift along z so the plane lies on z = 0. x and y of the plane's centroid are
// kept, so positions on the part stay meaningful.
//
// Which side is up (the normal's sign), in order of precedence:
//   1. `up` when given: n·up > 0;
//   2. the side the part is on: when more than 0.5 % of the points lie farther than 6 σ̂ off the
//      plane and over the plate's footprint (something stands on it; a floor seen past the plate's
//      edge does not count), n points toward the larger share of them;
//   3. otherwise the sensor's side, +Z (a sensor looking down): n·ẑ >= 0.
// So a plate is never turned upside down. n = +Z gives the identity rotation; n = −Z (only possible
// with `up`) a half turn about the x axis, since n × z is undefined there.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "align3d/plane/plane.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/warning.hpp"

namespace align3d {

struct RectifySettings {
  // true (the default): the dominant plane found by RANSAC, refitted by least squares on its
  // inliers, which holds on a scene with parts, walls or clutter; false: least squares on every
  // point (the chapter's fit, right only when the cloud is the plate alone).
  bool robust = true;
  std::optional<Eigen::Vector3d> up;  // any finite non-zero length; else std::invalid_argument
  RansacPlaneSettings ransac;
};

// Warns ("not_flat") when the inliers' RMS distance to the plane exceeds this multiple of the
// cloud's surface noise (cloud_stats.hpp; not below 5 % of the point spacing): the points the
// plane was fitted to do not lie on one plane (a least-squares fit through parts or walls, a
// curved or stepped surface), so the plane and the tilt are not to be trusted.
constexpr double kMaxFlatnessNoise = 3.0;

struct RectifyResult {
  Eigen::Isometry3d T_level_cloud = Eigen::Isometry3d::Identity();  // cloud → levelled frame
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // fitted normal, oriented up (cloud frame)
  double tilt_before_deg = 0;                         // angle between `normal` and +Z
  double tilt_after_deg = 0;  // the same, measured by refitting the levelled inliers
  std::size_t inliers = 0;    // points the plane was fitted to (all, unless robust)
  double flatness = 0;        // peak-to-valley of the inliers' residuals to the fitted plane
  double rms = 0;             // RMS of those residuals
  double noise = 0;           // the cloud's surface noise, for comparison (cloud_stats.hpp)
  std::vector<Warning> warnings;
};

// The rotation taking unit vector n to +Z by the shortest arc (Rodrigues), with the ±Z cases above.
Eigen::Matrix3d rotation_to_z(const Eigen::Vector3d& n);

// Throws DataError when the cloud defines no plane (too few points, collinear, a volume) or holds a
// NaN or Inf coordinate.
RectifyResult rectify(const PointCloud& cloud, const RectifySettings& settings = {});

}  // namespace align3d
