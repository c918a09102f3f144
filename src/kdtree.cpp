#include "align3d/kdtree.hpp"

#include <cmath>
#include <cstdint>
#include <nanoflann.hpp>
#include <stdexcept>

namespace align3d {
namespace {

struct Adaptor {
  const std::vector<Eigen::Vector3d>& points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][dim]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                 Adaptor, 3, std::uint32_t>;

// A k = 1 result set whose initial radius is the caller's bound, so the search never descends into
// cells farther than the rejection distance.
class BoundedNearest {
 public:
  explicit BoundedNearest(double sq_bound) : sq_best_(sq_bound) {}
  bool addPoint(double sq_d, std::size_t index) {
    if (sq_d < sq_best_) {
      sq_best_ = sq_d;
      index_ = index;
      found_ = true;
    }
    return true;
  }
  double worstDist() const { return sq_best_; }
  bool full() const { return found_; }
  std::size_t index() const { return index_; }

 private:
  double sq_best_;
  std::size_t index_ = 0;
  bool found_ = false;
};

}  // namespace

struct KdTree::Impl {
  explicit Impl(const std::vector<Eigen::Vector3d>& points)
      : adaptor{points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {}
  Adaptor adaptor;
  Tree tree;
};

KdTree::KdTree(const std::vector<Eigen::Vector3d>& points) : size_(points.size()) {
  if (points.size() >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("KdTree: more than 2^32 - 1 points");
  impl_ = std::make_unique<Impl>(points);
}

KdTree::~KdTree() = default;

bool KdTree::nearest(const Eigen::Vector3d& query, Neighbor& out, double sq_max_distance) const {
  if (size_ == 0) return false;
  BoundedNearest result(sq_max_distance);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  if (!result.full()) return false;
  out = {result.index(), result.worstDist()};
  return true;
}

void KdTree::knn(const Eigen::Vector3d& query, std::size_t k, std::vector<Neighbor>& out) const {
  k = std::min(k, size_);
  out.clear();
  if (k == 0) return;
  thread_local std::vector<std::uint32_t> indices;
  thread_local std::vector<double> sq_dists;
  indices.resize(k);
  sq_dists.resize(k);
  const std::size_t found = impl_->tree.knnSearch(query.data(), k, indices.data(), sq_dists.data());
  out.resize(found);
  for (std::size_t i = 0; i < found; ++i) out[i] = {indices[i], sq_dists[i]};
}

void KdTree::radius(const Eigen::Vector3d& query, double sq_radius,
                    std::vector<Neighbor>& out) const {
  out.clear();
  if (size_ == 0) return;
  thread_local std::vector<std::pair<std::uint32_t, double>> found;
  found.clear();
  // nanoflann keeps d < r; the contract is d <= r, so widen r by one ulp.
  const double inclusive = std::nextafter(sq_radius, std::numeric_limits<double>::infinity());
  impl_->tree.radiusSearch(query.data(), inclusive, found, nanoflann::SearchParams(32, 0, true));
  out.reserve(found.size());
  for (const auto& [index, sq_d] : found) out.push_back({index, sq_d});
}

}  // namespace align3d
