// The principal axes of a neighbourhood: shared by the normals (normals.cpp) and the noise estimate
// (cloud_stats.cpp).
#pragma once

#include <Eigen/Eigenvalues>
#include <vector>

#include "align3d/kdtree.hpp"

namespace align3d::detail {

// Eigen-decomposition of the covariance of cloud[nb[*].index], taken about `p` (the neighbours lie
// within a few spacings of it, so the second moments lose no precision to the cloud's offset from
// the origin). Eigenvalues ascending; the closed form for 3×3, as Open3D's and PCL's normals.
inline Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> neighbourhood_pca(
    const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& p,
    const std::vector<Neighbor>& nb) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const auto& m : nb) {
    const Eigen::Vector3d d = points[m.index] - p;
    sum += d;
    second.noalias() += d * d.transpose();
  }
  const double count = static_cast<double>(nb.size());
  const Eigen::Vector3d mean = sum / count;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(second / count - mean * mean.transpose());
  return eig;
}

}  // namespace align3d::detail
