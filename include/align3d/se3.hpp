// The only Lie-algebra code in align3d. Convention: a twist is (ω, v) with ω a rotation vector
// (axis · angle, radians) and v a translation; exp((ω, v)) = [exp(ω) | v], i.e. the rotation is
// taken about the origin of the frame the points are expressed in, matching the small-angle model
// R·p + t ≈ p + ω × p + v of point-to-plane ICP (chapter 39.4).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace align3d {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

inline double rad_to_deg(double rad) { return rad * 180.0 / 3.14159265358979323846; }
inline double deg_to_rad(double deg) { return deg * 3.14159265358979323846 / 180.0; }

inline Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

// Rodrigues: the rotation by |ω| about ω/|ω| (the identity for ω = 0).
inline Eigen::Matrix3d so3_exp(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

inline Eigen::Isometry3d se3_exp(const Vector6d& twist) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3_exp(twist.head<3>());
  T.translation() = twist.tail<3>();
  return T;
}

// The rigid transform that rotates by `angle_deg` about `axis` (through the origin), then
// translates by `t`.
inline Eigen::Isometry3d rigid_transform(double angle_deg, const Eigen::Vector3d& axis,
                                         const Eigen::Vector3d& t = Eigen::Vector3d::Zero()) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(deg_to_rad(angle_deg), axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

// Rotation angle of R in radians, in [0, π]; robust near 0 and π (atan2 form, not acos).
inline double rotation_angle(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d axis_sin(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * axis_sin.norm(), 0.5 * (R.trace() - 1.0));
}

// Nearest rotation to M in the Frobenius norm (SVD with the reflection guard).
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M);

}  // namespace align3d
