// One pair's cost: residual and Jacobian, and the sums the solvers need. Coordinates are expressed
// about a fixed reference point (the ICP loop uses the target centroid) to keep the sums
// conditioned.
#pragma once

#include <Eigen/Core>

#include "align3d/kabsch.hpp"
#include "align3d/se3.hpp"

namespace align3d {

// The per-pair cost an ICP run minimises.
enum class IcpMethod { kPointToPoint, kPointToPlane };
inline const char* to_string(IcpMethod m) {
  return m == IcpMethod::kPointToPoint ? "point-to-point" : "point-to-plane";
}

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
  LinearSystem6& operator+=(const LinearSystem6& o) {
    H += o.H;
    b += o.b;
    sq_error += o.sq_error;
    sum_w += o.sum_w;
    return *this;
  }
};

}  // namespace align3d
