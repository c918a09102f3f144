#include "align3d/kabsch.hpp"

#include <Eigen/SVD>
#include <stdexcept>

#include "align3d/se3.hpp"

namespace align3d {

Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M) {
  // For M = U Σ Vᵀ the closest rotation is U·diag(1,1,d)·Vᵀ, d = sign det(U Vᵀ).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const double d = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * Eigen::Vector3d(1, 1, d).asDiagonal() * svd.matrixV().transpose();
}

Eigen::Isometry3d solve_kabsch(const KabschAccumulator& acc) {
  if (!(acc.sum_w > 0)) throw std::invalid_argument("solve_kabsch: no pairs (total weight 0)");
  const Eigen::Vector3d p_bar = acc.sum_p / acc.sum_w;
  const Eigen::Vector3d q_bar = acc.sum_q / acc.sum_w;
  const Eigen::Matrix3d H = acc.sum_pq - acc.sum_w * p_bar * q_bar.transpose();
  // H = U Σ Vᵀ maximises tr(R H) at R = V·diag(1,1,d)·Uᵀ (chapter 39.1).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  const double d = (V * U.transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = V * Eigen::Vector3d(1, 1, d).asDiagonal() * U.transpose();
  T.translation() = q_bar - T.linear() * p_bar;
  return T;
}

Eigen::Isometry3d kabsch(const std::vector<Eigen::Vector3d>& p,
                         const std::vector<Eigen::Vector3d>& q,
                         const std::vector<double>& weights) {
  if (p.size() != q.size() || p.empty() || (!weights.empty() && weights.size() != p.size()))
    throw std::invalid_argument("kabsch: p, q (and weights) must be non-empty and of equal size");
  // Two passes: centre each set on its plain mean first so the sums stay well conditioned far
  // from the origin; then T = translate(q0)·T_centred·translate(−p0).
  Eigen::Vector3d p0 = Eigen::Vector3d::Zero(), q0 = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p.size(); ++i) {
    p0 += p[i];
    q0 += q[i];
  }
  p0 /= static_cast<double>(p.size());
  q0 /= static_cast<double>(q.size());
  KabschAccumulator acc;
  for (std::size_t i = 0; i < p.size(); ++i)
    acc.add(p[i] - p0, q[i] - q0, weights.empty() ? 1.0 : weights[i]);
  Eigen::Isometry3d T = solve_kabsch(acc);
  T.translation() += q0 - T.linear() * p0;
  return T;
}

}  // namespace align3d
