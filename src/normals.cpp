#include "align3d/normals.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "detail/parallel.hpp"
#include "detail/pca.hpp"

namespace align3d {
namespace {

// `who` names the caller in the messages.
void check(const PointCloud& cloud, const KdTree& tree, const NormalSettings& settings,
           const std::string& who) {
  if (settings.k < 3) throw std::invalid_argument(who + ": k must be >= 3");
  if (tree.size() != cloud.size())
    throw std::invalid_argument(who + ": the kd-tree does not index the cloud");
}

// The normal at point `index` (PCA of its k nearest neighbours); false when the neighbourhood has
// no plane, and `normal` is then the orientation direction. `nb` is scratch space.
bool normal_at(const PointCloud& cloud, const KdTree& tree, std::size_t index,
               const NormalSettings& settings, std::vector<Neighbor>& nb, Eigen::Vector3d& normal) {
  const Eigen::Vector3d& p = cloud.positions[index];
  tree.knn_unsorted(p, static_cast<std::size_t>(settings.k), nb);
  const auto eig = detail::neighbourhood_pca(cloud.positions, p, nb);
  const Eigen::Vector3d ev = eig.eigenvalues();
  const Eigen::Vector3d toward =
      settings.viewpoint ? Eigen::Vector3d(*settings.viewpoint - p) : Eigen::Vector3d::UnitZ();
  // No plane when the middle eigenvalue vanishes relative to the largest (a line or a point:
  // neighbourhoods ~3000 times longer than wide). The closed form resolves a double eigenvalue
  // only to ~sqrt(ε), hence 1e-7 rather than a bound near ε.
  if (nb.size() < 3 || !(ev(1) > 1e-7 * ev(2)) || eig.info() != Eigen::Success) {
    normal = toward.norm() > 0 ? Eigen::Vector3d(toward.normalized()) : Eigen::Vector3d::UnitZ();
    return false;
  }
  normal = eig.eigenvectors().col(0);
  if (normal.dot(toward) < 0) normal = -normal;
  return true;
}

}  // namespace

NormalResult estimate_normals(PointCloud& cloud, const KdTree& tree,
                              const NormalSettings& settings) {
  check(cloud, tree, settings, "estimate_normals");
  const std::size_t n = cloud.size();
  // Points are visited in the tree's leaf order so consecutive searches share cached tree nodes;
  // results are written in that order too (each thread to its own stretch, no shared cache lines)
  // and put back in place afterwards.
  const std::vector<std::uint32_t>& order = tree.leaf_order();
  std::vector<Eigen::Vector3d> by_rank(n);
  std::vector<unsigned char> undefined(n, 0);
  parallel_for(n, settings.threads, [&](std::size_t rank) {
    thread_local std::vector<Neighbor> nb;
    undefined[rank] = !normal_at(cloud, tree, order[rank], settings, nb, by_rank[rank]);
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

void orient_normals(PointCloud& cloud, const Eigen::Vector3d& viewpoint, int threads) {
  if (!cloud.has_normals()) throw std::invalid_argument("orient_normals: the cloud has no normals");
  parallel_for(cloud.size(), threads, [&](std::size_t i) {
    if (cloud.normals[i].dot(viewpoint - cloud.positions[i]) < 0) cloud.normals[i] *= -1;
  });
}

Eigen::Vector3d estimated_viewpoint(const PointCloud& cloud, double extent) {
  if (cloud.empty() || !cloud.has_normals())
    throw std::invalid_argument("estimated_viewpoint: needs points with normals");
  constexpr std::size_t kSamples = 2000;
  constexpr double kDistance = 2.0;  // extents from the centroid
  const std::size_t m = std::max<std::size_t>(1, (cloud.size() + kSamples - 1) / kSamples);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d facing = Eigen::Matrix3d::Zero();
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud.size(); i += m, ++count) {
    centroid += cloud.positions[i];
    facing.noalias() += cloud.normals[i] * cloud.normals[i].transpose();
  }
  centroid /= static_cast<double>(count);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(facing);
  Eigen::Vector3d axis = eig.eigenvectors().col(2);
  double bulge = 0;  // Σ (p − c)·n with each n turned towards +axis
  for (std::size_t i = 0; i < cloud.size(); i += m) {
    const Eigen::Vector3d& n = cloud.normals[i];
    bulge += (cloud.positions[i] - centroid).dot(n.dot(axis) < 0 ? Eigen::Vector3d(-n) : n);
  }
  if (bulge < 0) axis = -axis;
  return centroid + kDistance * std::max(extent, 0.0) * axis;
}

NormalCache::NormalCache(const PointCloud& cloud, const KdTree& tree,
                         const NormalSettings& settings)
    : cloud_(cloud), tree_(tree), settings_(settings) {
  check(cloud, tree, settings, "NormalCache");
  normals_.resize(cloud.size());
  state_.assign(cloud.size(), kUnknown);
}

void NormalCache::require(const std::vector<std::uint32_t>& indices) {
  std::vector<std::uint32_t> pending;
  for (std::uint32_t i : indices) {
    if (i >= state_.size()) throw std::out_of_range("NormalCache: point index out of range");
    if (state_[i] != kUnknown) continue;
    state_[i] = kPending;  // settled below
    pending.push_back(i);
  }
  if (pending.empty()) return;  // nothing written: concurrent readers of a complete cache are safe
  // In index order: neighbouring indices of a cloud in spatial order (RefineTarget's) are
  // neighbouring points, whose searches share cached tree nodes (each normal is the same in any
  // order). Many (a registration's first pairs ask for most of the cloud): gathered from the
  // states in one pass, where a sort of tens of thousands took a millisecond on the calling thread.
  if (pending.size() > state_.size() / 64) {
    std::size_t k = 0;
    for (std::size_t i = 0; i < state_.size(); ++i)
      if (state_[i] == kPending) pending[k++] = static_cast<std::uint32_t>(i);
  } else {
    std::sort(pending.begin(), pending.end());
  }
  // Each item writes only its own point's normal and state.
  parallel_for(pending.size(), settings_.threads, [&](std::size_t k) {
    thread_local std::vector<Neighbor> nb;
    const std::uint32_t i = pending[k];
    state_[i] = normal_at(cloud_, tree_, i, settings_, nb, normals_[i]) ? kDefined : kUndefined;
  });
  estimated_ += pending.size();
  for (std::uint32_t i : pending) undefined_ += state_[i] == kUndefined;
}

}  // namespace align3d
