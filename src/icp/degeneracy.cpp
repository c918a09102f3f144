#include "align3d/icp/degeneracy.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace align3d {

ConstrainedSolve solve_constrained(const Matrix6d& H, const Vector6d& rhs) {
  ConstrainedSolve out;
  const double rotational = H.topLeftCorner<3, 3>().trace();
  const double translational = H.bottomRightCorner<3, 3>().trace();
  if (!H.allFinite() || !rhs.allFinite() || !(rotational > 0) || !(translational > 0)) {
    for (int i = 0; i < 6; ++i) {
      const Vector6d e = Vector6d::Unit(i);
      out.weak.push_back({e.head<3>(), e.tail<3>(), 0.0});
    }
    return out;
  }
  const double length = std::sqrt(rotational / translational);
  Vector6d scale;  // x = S·y, with y the dimensionless unknowns
  scale << Eigen::Vector3d::Constant(1 / length), Eigen::Vector3d::Ones();
  const Matrix6d scaled = scale.asDiagonal() * H * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(scaled);  // eigenvalues ascending
  const Vector6d lambda = eig.eigenvalues();
  const Vector6d scaled_rhs = scale.cwiseProduct(rhs);
  // Damped in the eigenbasis: y = Σ v (v·rhs) / (λ + μ), μ = kWeakRatio·λmax. A well-constrained
  // direction takes (nearly) the full Gauss-Newton step; a free one (λ ≈ 0, and then v·rhs ≈ 0 as
  // well) does not move, and a weak one moves at most |v·rhs| / μ per iteration. The fixed point,
  // rhs = 0, is the undamped one.
  const double mu = kWeakRatio * lambda(5);
  Vector6d y = Vector6d::Zero();
  for (int i = 0; i < 6; ++i) {
    const Vector6d v = eig.eigenvectors().col(i);
    y += v * (v.dot(scaled_rhs) / (std::max(0.0, lambda(i)) + mu));
    if (lambda(i) < mu)
      out.weak.push_back({v.head<3>(), v.tail<3>(), std::max(0.0, lambda(i)) / lambda(5)});
  }
  out.x = scale.cwiseProduct(y);
  return out;
}

}  // namespace align3d
