// Closed-form rigid transform between paired points (Kabsch / Umeyama, chapter 39.1; Arun, Huang
// and Blostein 1987): minimise Σ wᵢ‖R·pᵢ + t − qᵢ‖² over rotations R (det +1) and translations t.
//   p̄, q̄ weighted centroids;  H = Σ wᵢ (pᵢ − p̄)(qᵢ − q̄)ᵀ = U Σ Vᵀ;
//   R = V·diag(1, 1, d)·Uᵀ with d = sign det(V Uᵀ)  (the reflection guard);  t = q̄ − R·p̄.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace align3d {

// Running sums that define the problem; parallel reductions add accumulators together. Sums are
// taken about the coordinates as given, so callers with far-from-origin data should centre them
// first (the ICP loop works about the target centroid).
struct KabschAccumulator {
  double sum_w = 0;
  Eigen::Vector3d sum_p = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_q = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_pq = Eigen::Matrix3d::Zero();  // Σ w p qᵀ

  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& q, double w = 1.0) {
    sum_w += w;
    sum_p += w * p;
    sum_q += w * q;
    sum_pq.noalias() += w * p * q.transpose();
  }
  KabschAccumulator& operator+=(const KabschAccumulator& o) {
    sum_w += o.sum_w;
    sum_p += o.sum_p;
    sum_q += o.sum_q;
    sum_pq += o.sum_pq;
    return *this;
  }
};

// T with q ≈ T·p. With fewer than 3 pairs, or all pairs on one line, the rotation is not unique and
// the SVD returns one of the minimisers; never a reflection. Requires sum_w > 0.
Eigen::Isometry3d solve_kabsch(const KabschAccumulator& acc);

// Convenience for paired arrays (same size, >= 1 pair); weights optional (empty = all 1).
Eigen::Isometry3d kabsch(const std::vector<Eigen::Vector3d>& p,
                         const std::vector<Eigen::Vector3d>& q,
                         const std::vector<double>& weights = {});

}  // namespace align3d
