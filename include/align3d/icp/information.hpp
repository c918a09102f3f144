// The information matrix of a converged point-to-plane registration: how firmly the pairs fix each
// direction of the pose (a pose graph weighs its edges by it; stitch.hpp).
//
// At T (target ≈ T·source) every source point x = T·p with a target point q within max_distance
// and a target normal n is a pair, residual r = (x − q)·n. For a left update T ← exp(ξ)·T,
// ξ = (ω, v) about the target's origin, ∂r/∂ξ = [x × n; n] (PointToPlaneFactor), and the Gauss-
// Newton Hessian H = Σ JᵀJ. With σ² the mean squared residual (the noise at a correct
// convergence), H / σ² is the information of the pose (the inverse of its covariance under
// independent Gaussian residuals; closed-form ICP covariances are known to be optimistic, and
// none covers a wrong minimum).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>

#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/se3.hpp"

namespace align3d {

struct PairInformation {
  Matrix6d information = Matrix6d::Zero();  // H / σ², (rotation, translation) about the origin
  Matrix6d hessian = Matrix6d::Zero();      // H = Σ JᵀJ
  std::size_t pairs = 0;
  double rms = 0;                                      // σ: √(mean r²)
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  // of the paired target points
};

// `target` must have normals; `tree` indexes it. Pairs with |r| = 0 everywhere (noise-free data)
// are given σ = 1e-9 × max_distance so the information stays finite.
PairInformation point_to_plane_information(const PointCloud& source, const PointCloud& target,
                                           const KdTree& tree, const Eigen::Isometry3d& T,
                                           double max_distance, int threads = 0);

}  // namespace align3d
