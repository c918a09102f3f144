// One pair's cost: residual and Jacobian, and the sums the solvers need. Coordinates are expressed
// about a fixed reference point (the ICP loop uses the target centroid) to keep the sums
// conditioned.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <optional>
#include <string_view>

#include "align3d/kabsch.hpp"
#include "align3d/se3.hpp"

namespace align3d {

// The per-pair cost an ICP run minimises. Point-to-point and point-to-plane are the chapter's;
// GICP and symmetric need the source's normals too (refine() estimates them when the source has
// none).
enum class IcpMethod { kPointToPoint, kPointToPlane, kGicp, kSymmetric };
inline constexpr IcpMethod kAllIcpMethods[] = {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane,
                                               IcpMethod::kGicp, IcpMethod::kSymmetric};
inline const char* to_string(IcpMethod m) {
  switch (m) {
    case IcpMethod::kPointToPoint:
      return "point-to-point";
    case IcpMethod::kPointToPlane:
      return "point-to-plane";
    case IcpMethod::kGicp:
      return "gicp";
    case IcpMethod::kSymmetric:
      return "symmetric";
  }
  return "point-to-plane";
}
// The method named by to_string(); nullopt for any other name.
inline std::optional<IcpMethod> icp_method_from_string(std::string_view name) {
  for (IcpMethod m : kAllIcpMethods)
    if (name == to_string(m)) return m;
  return std::nullopt;
}
// Whether the method reads the source's normals (GICP's covariances are built from them).
inline bool needs_source_normals(IcpMethod m) {
  return m == IcpMethod::kGicp || m == IcpMethod::kSymmetric;
}

// The fewest pairs that fix a pose: 3 points for point-to-point (Kabsch), 6 scalar constraints for
// the others.
inline std::size_t min_pairs(IcpMethod m) { return m == IcpMethod::kPointToPoint ? 3 : 6; }

// Point-to-plane (chapter 39.4; Chen and Medioni 1992): r = (p − q)·n, and for the update
// p ← p + ω × p + v the Jacobian is ∂r/∂(ω, v) = [p × n; n].
struct PointToPlaneFactor {
  static double residual(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                         const Eigen::Vector3d& n) {
    return (p - q).dot(n);
  }
  static Vector6d jacobian(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    Vector6d J;
    J << p.cross(n), n;
    return J;
  }
};

// Symmetric point-to-plane (Rusinkiewicz 2019, "A symmetric objective function for ICP", eq. 7-9):
// the source turns by +θ and the target by −θ about one axis a, so the residual is linear in
// ã = a·tan θ and t̃ = t / cos θ: r = (p − q)·n + ((p + q) × n)·ã + n·t̃, with n = n_p + n_q (both
// normals unit and facing the same side). The solved (ã, t̃) gives the update p ← R(R p + t),
// R the rotation by θ = atan|ã| about ã/|ã|, t = t̃ cos θ (symmetric_update).
struct SymmetricFactor {
  static double residual(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                         const Eigen::Vector3d& n) {
    return (p - q).dot(n);
  }
  static Vector6d jacobian(const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                           const Eigen::Vector3d& n) {
    Vector6d J;
    J << (p + q).cross(n), n;
    return J;
  }
};

// The update of the symmetric objective's unknowns x = (ã, t̃) (SymmetricFactor).
inline Eigen::Isometry3d symmetric_update(const Vector6d& x) {
  const Eigen::Vector3d a = x.head<3>();
  const double tan_theta = a.norm();
  const double theta = std::atan(tan_theta);
  Eigen::Isometry3d R = Eigen::Isometry3d::Identity();
  if (tan_theta > 0) R.linear() = Eigen::AngleAxisd(theta, a / tan_theta).toRotationMatrix();
  return R * Eigen::Translation3d(x.tail<3>() * std::cos(theta)) * R;
}

// Generalized ICP (Segal, Haehnel and Thrun 2009), plane-to-plane: the pair's error e = x − q
// (x = T·p) weighed by M = (C_q + R C_p Rᵀ)⁻¹, cost eᵀ M e, with M held fixed over a step as in
// small_gicp. Covariances are regularised as small_gicp's default (RegularizationMethod::PLANE):
// the k-NN covariance's eigenvalues replaced by (ε, 1, 1), ε = 1e-3, whose eigenvectors are the
// normal and the tangent plane, so C = I − (1 − ε) n nᵀ follows from the unit normal alone (a
// point without one, n = 0, gets C = I). For the update x ← x + ω × x + v, ∂e/∂(ω, v) = [−[x]×, I].
struct GicpFactor {
  static constexpr double kEpsilon = 1e-3;
  static Eigen::Matrix3d covariance(const Eigen::Vector3d& n) {
    return Eigen::Matrix3d::Identity() - (1.0 - kEpsilon) * n * n.transpose();
  }
  // M for the (rotated) source normal m = R n_p and the target normal n_q.
  static Eigen::Matrix3d weight(const Eigen::Vector3d& m, const Eigen::Vector3d& n_q) {
    return (covariance(n_q) + covariance(m)).inverse();
  }
  static Eigen::Matrix<double, 3, 6> jacobian(const Eigen::Vector3d& x) {
    Eigen::Matrix<double, 3, 6> J;
    J << -skew(x), Eigen::Matrix3d::Identity();
    return J;
  }
};

// Gauss-Newton normal equations H·x = −b of Σ w r², with H = Σ w JᵀJ and b = Σ w J r.
struct LinearSystem6 {
  Matrix6d H = Matrix6d::Zero();
  Vector6d b = Vector6d::Zero();
  double sq_error = 0;  // Σ w r²
  double sum_w = 0;

  void add(const Vector6d& J, double r, double w) {
    H.noalias() += w * J * J.transpose();
    b.noalias() += w * r * J;
    sq_error += w * r * r;
    sum_w += w;
  }
  // A vector residual e with Jacobian J and weight matrix M: H += Jᵀ M J, b += Jᵀ M e, e² += eᵀ M
  // e.
  void add(const Eigen::Matrix<double, 3, 6>& J, const Eigen::Vector3d& e, const Eigen::Matrix3d& M,
           double w) {
    const Eigen::Matrix<double, 6, 3> JtM = J.transpose() * M;
    H.noalias() += w * JtM * J;
    b.noalias() += w * JtM * e;
    sq_error += w * e.dot(M * e);
    sum_w += w;
  }
  LinearSystem6& operator+=(const LinearSystem6& o) {
    H += o.H;
    b += o.b;
    sq_error += o.sq_error;
    sum_w += o.sum_w;
    return *this;
  }
};

}  // namespace align3d
