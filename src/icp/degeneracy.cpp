#include "align3d/icp/degeneracy.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace align3d {

SystemAnalysis analyse_system(const Matrix6d& H) {
  SystemAnalysis a;
  const double rotational = H.topLeftCorner<3, 3>().trace();
  const double translational = H.bottomRightCorner<3, 3>().trace();
  if (!H.allFinite() || !(rotational > 0) || !(translational > 0)) return a;
  const double length = std::sqrt(rotational / translational);
  a.scale << Eigen::Vector3d::Constant(1 / length), Eigen::Vector3d::Ones();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(a.scale.asDiagonal() * H *
                                                    a.scale.asDiagonal());
  a.vectors = eig.eigenvectors();
  a.values = eig.eigenvalues();
  a.usable = eig.info() == Eigen::Success && a.values(5) > 0;
  return a;
}

ConstrainedSolve solve_constrained(const SystemAnalysis& a, const Vector6d& rhs,
                                   const Vector6d& aligned) {
  ConstrainedSolve out;
  const Vector6d scaled_rhs = a.scale.cwiseProduct(rhs);
  Vector6d y = Vector6d::Zero();
  for (int i = 0; i < 6; ++i) {
    const Vector6d v = a.vectors.col(i);
    const double lambda = a.values(i);
    const bool free = !a.usable || !rhs.allFinite() || !(lambda > 0) ||
                      (a.candidate(i) && aligned(i) < kSupportShare * lambda);
    if (free) {
      out.weak.push_back(
          {v.head<3>(), v.tail<3>(), a.usable ? std::max(0.0, lambda) / a.values(5) : 0.0});
      continue;
    }
    y += v * (v.dot(scaled_rhs) / lambda);
  }
  out.x = a.scale.cwiseProduct(y);
  return out;
}

}  // namespace align3d
