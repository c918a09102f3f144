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
  // Points are visited in the tree's leaf order so consecutive searches share cached tree nodes;
  // results are written in that order too (each thread to its own stretch, no shared cache lines)
  // and put back in place afterwards.
  if (tree.size() != n)
    throw std::invalid_argument("estimate_normals: the kd-tree does not index the cloud");
  const std::vector<std::uint32_t>& order = tree.leaf_order();
  std::vector<Eigen::Vector3d> by_rank(n);
  std::vector<unsigned char> undefined(n, 0);
  parallel_for(n, settings.threads, [&](std::size_t rank) {
    thread_local std::vector<Neighbor> nb;
    const Eigen::Vector3d& p = cloud.positions[order[rank]];
    tree.knn(p, k, nb);
    // One pass over the neighbours, about p (they are within a few spacings of it, so the
    // second moments lose no precision to the cloud's offset from the origin).
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    for (const auto& m : nb) {
      const Eigen::Vector3d d = cloud.positions[m.index] - p;
      sum += d;
      second.noalias() += d * d.transpose();
    }
    const double count = static_cast<double>(nb.size());
    const Eigen::Vector3d mean = sum / count;
    const Eigen::Matrix3d cov = second / count - mean * mean.transpose();
    // Closed form for 3×3 (as Open3D's and PCL's normals); eigenvalues ascending.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(cov);
    const Eigen::Vector3d ev = eig.eigenvalues();
    Eigen::Vector3d toward =
        settings.viewpoint ? Eigen::Vector3d(*settings.viewpoint - p) : Eigen::Vector3d::UnitZ();
    // No plane when the middle eigenvalue vanishes relative to the largest (a line or a point:
    // neighbourhoods ~3000 times longer than wide). The closed form resolves a double eigenvalue
    // only to ~sqrt(ε), hence 1e-7 rather than a bound near ε.
    if (nb.size() < 3 || !(ev(1) > 1e-7 * ev(2)) || eig.info() != Eigen::Success) {
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
  const KdTree tree(cloud.positions, settings.threads);
  return estimate_normals(cloud, tree, settings);
}

}  // namespace align3d
