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

// The inverse of se3_exp: (rotation vector of R, t) for T = [R | t], the angle in [0, π].
inline Vector6d se3_log(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd turn(T.linear());
  Vector6d twist;
  twist << turn.angle() * turn.axis(), T.translation();
  return twist;
}

// The adjoint of T = [R, t] for twists (ω, v) acting as x ↦ x + ω × x + v (se3_exp):
// T·exp(ξ)·T⁻¹ = exp(Ad(T)·ξ), Ad(T) = [[R, 0], [[t]× R, R]]. Carries a covariance of a left
// perturbation from one frame to another (Cov' = Ad Cov Adᵀ).
inline Matrix6d adjoint(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  Matrix6d A = Matrix6d::Zero();
  A.topLeftCorner<3, 3>() = R;
  A.bottomRightCorner<3, 3>() = R;
  A.bottomLeftCorner<3, 3>() = skew(T.translation()) * R;
  return A;
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

// The rotation by the shortest arc taking the direction of `from` onto that of `to` (Rodrigues
// about from × to; both non-zero). The identity when they agree; for opposite directions, where
// from × to vanishes, a half turn about the coordinate axis least aligned with `to` (made
// orthogonal to it): x for ±z, y for ±x.
inline Eigen::Matrix3d shortest_arc(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const Eigen::Vector3d a = from.normalized(), b = to.normalized();
  const Eigen::Vector3d axis = a.cross(b);
  const double sin_angle = axis.norm(), cos_angle = a.dot(b);
  if (sin_angle > 1e-12)
    return Eigen::AngleAxisd(std::atan2(sin_angle, cos_angle), axis / sin_angle).toRotationMatrix();
  if (cos_angle > 0) return Eigen::Matrix3d::Identity();
  Eigen::Index least = 0;
  b.cwiseAbs().minCoeff(&least);
  const Eigen::Vector3d e = Eigen::Vector3d::Unit(least);
  return Eigen::AngleAxisd(3.14159265358979323846, (e - e.dot(b) * b).normalized())
      .toRotationMatrix();
}

// Rotation angle of R in radians, in [0, π]; robust near 0 and π (atan2 form, not acos).
inline double rotation_angle(const Eigen::Matrix3d& R) {
  const Eigen::Vector3d axis_sin(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * axis_sin.norm(), 0.5 * (R.trace() - 1.0));
}

// The error of an estimated pose against the truth: the angle of R_estᵀ·R_true (degrees) and the
// distance between the translations (data units).
struct PoseError {
  double rotation_deg = 0;
  double translation = 0;
};

inline PoseError pose_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return {rad_to_deg(rotation_angle(estimate.linear().transpose() * truth.linear())),
          (estimate.translation() - truth.translation()).norm()};
}

// Nearest rotation to M in the Frobenius norm (SVD with the reflection guard).
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M);

}  // namespace align3d
