#include "align3d/kdtree.hpp"

#include <Eigen/Geometry>
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

// The tree owns a copy of the points stored in leaf order: after nanoflann has built its nodes over
// the caller's order, the copy is permuted so that every leaf's points are contiguous and the
// index list becomes the identity. A query then reads a few adjacent cache lines per leaf instead
// of scattered points, which is most of the search time on clouds larger than the cache.
struct KdTree::Impl {
  explicit Impl(const std::vector<Eigen::Vector3d>& input)
      : points(input),
        adaptor{points},
        tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafSize)) {
    original.assign(tree.vAcc.begin(), tree.vAcc.end());
    for (std::size_t k = 0; k < original.size(); ++k) {
      points[k] = input[original[k]];
      tree.vAcc[k] = static_cast<std::uint32_t>(k);
    }
  }
  static constexpr std::size_t kLeafSize = 8;
  std::vector<Eigen::Vector3d> points;  // in leaf order
  std::vector<std::uint32_t> original;  // points[k] == input[original[k]]
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
  out = {impl_->original[result.index()], result.worstDist()};
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
  for (std::size_t i = 0; i < found; ++i) out[i] = {impl_->original[indices[i]], sq_dists[i]};
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
  for (const auto& [index, sq_d] : found) out.push_back({impl_->original[index], sq_d});
}

namespace {

// Spreads the low 10 bits of x so that bit i lands at bit 3i.
std::uint32_t spread_bits(std::uint32_t x) {
  x = (x | x << 16) & 0x030000FFu;
  x = (x | x << 8) & 0x0300F00Fu;
  x = (x | x << 4) & 0x030C30C3u;
  x = (x | x << 2) & 0x09249249u;
  return x;
}

}  // namespace

std::vector<std::uint32_t> spatial_order(const std::vector<Eigen::Vector3d>& points) {
  const std::size_t n = points.size();
  if (n >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("spatial_order: more than 2^32 - 1 points");
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  std::vector<std::uint32_t> key(n), order(n), sorted(n);
  if (n == 0) return order;
  const Eigen::Array3d scale = 1023.0 / box.sizes().array().max(1e-300);
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Array3d c = ((points[i] - box.min()).array() * scale).min(1023.0).max(0.0);
    if (!c.allFinite()) c.setZero();  // a NaN or infinite coordinate: any place will do
    key[i] = spread_bits(static_cast<std::uint32_t>(c.x())) |
             spread_bits(static_cast<std::uint32_t>(c.y())) << 1 |
             spread_bits(static_cast<std::uint32_t>(c.z())) << 2;
    order[i] = static_cast<std::uint32_t>(i);
  }
  // LSD radix sort of the 30-bit keys, 10 bits per pass; each pass is stable.
  for (int shift = 0; shift < 30; shift += 10) {
    std::vector<std::size_t> start(1025, 0);
    for (std::uint32_t i : order) ++start[((key[i] >> shift) & 1023u) + 1];
    for (std::size_t b = 1; b <= 1024; ++b) start[b] += start[b - 1];
    for (std::uint32_t i : order) sorted[start[(key[i] >> shift) & 1023u]++] = i;
    order.swap(sorted);
  }
  return order;
}

}  // namespace align3d
