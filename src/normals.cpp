#include "align3d/normals.hpp"

#include <Eigen/Eigenvalues>
#include <stdexcept>

#include "align3d/parallel.hpp"

namespace align3d {

NormalResult estimate_normals(PointCloud& cloud, const KdTree& tree,
                              const NormalSettings& settings) {
  if (settings.k < 3) throw std::invalid_argument("estimate_normals: k must be >= 3");
  const std::size_t n = cloud.size();
  const auto k = static_cast<std::size_t>(settings.k);
  // Points are visited in spatial order so consecutive searches share cached tree nodes; results
  // are written in that order too (each thread to its own stretch, no shared cache lines) and put
  // back in place afterwards.
  const std::vector<std::uint32_t> order = spatial_order(cloud.positions);
  std::vector<Eigen::Vector3d> by_rank(n);
  std::vector<unsigned char> undefined(n, 0);
  parallel_for(n, settings.threads, [&](std::size_t rank) {
    thread_local std::vector<Neighbor> nb;
    const Eigen::Vector3d& p = cloud.positions[order[rank]];
    tree.knn(p, k, nb);
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& m : nb) mean += cloud.positions[m.index];
    mean /= static_cast<double>(nb.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& m : nb) {
      const Eigen::Vector3d d = cloud.positions[m.index] - mean;
      cov.noalias() += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);  // eigenvalues ascending
    const Eigen::Vector3d ev = eig.eigenvalues();
    Eigen::Vector3d toward =
        settings.viewpoint ? Eigen::Vector3d(*settings.viewpoint - p) : Eigen::Vector3d::UnitZ();
    // No plane when the middle eigenvalue vanishes relative to the largest (a line or a point).
    if (nb.size() < 3 || !(ev(1) > 1e-12 * ev(2)) || eig.info() != Eigen::Success) {
      undefined[rank] = 1;
      by_rank[rank] =
          toward.norm() > 0 ? Eigen::Vector3d(toward.normalized()) : Eigen::Vector3d::UnitZ();
      return;
    }
    Eigen::Vector3d normal = eig.eigenvectors().col(0);
    if (normal.dot(toward) < 0) normal = -normal;
    by_rank[rank] = normal;
  });
  cloud.normals.resize(n);
  NormalResult result;
  for (std::size_t rank = 0; rank < n; ++rank) {
    cloud.normals[order[rank]] = by_rank[rank];
    result.undefined += undefined[rank];
  }
  return result;
}

NormalResult estimate_normals(PointCloud& cloud, const NormalSettings& settings) {
  const KdTree tree(cloud.positions);
  return estimate_normals(cloud, tree, settings);
}

}  // namespace align3d
