// Nearest-neighbour search over a fixed set of 3D points (a balanced kd-tree; chapter 39.1 step 1:
// O(log M) per query instead of the brute-force O(M)).
//
// Lifetime: the tree keeps its own copy of the points (in leaf order, for cache locality: 35 to 42
// bytes per point with the nodes; 60 while it is being built), so the input may change or go away
// afterwards; results index the input order. Points must be finite (std::invalid_argument
// otherwise); queries may be anything (a NaN query finds nothing). Thread-safety: all const queries
// may run concurrently from any number of threads. Distances: every `sq_` quantity is a squared
// Euclidean distance in the data's units. Ties: among equidistant points the result is
// deterministic for a given tree.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace align3d {

struct Neighbor {
  std::size_t index = 0;
  double sq_distance = std::numeric_limits<double>::infinity();
};

class KdTree {
 public:
  // Builds the tree; `threads` as everywhere (0: all the CPUs the process may run on); the tree
  // is the same for any thread count.
  explicit KdTree(const std::vector<Eigen::Vector3d>& points, int threads = 0);
  ~KdTree();
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;

  std::size_t size() const { return size_; }

  // The nearest point within sq_max_distance (exclusive bound: the search prunes subtrees farther
  // than it, which is what makes a bounded ICP query cheap). Returns false when there is none
  // (also for an empty tree).
  bool nearest(const Eigen::Vector3d& query, Neighbor& out,
               double sq_max_distance = std::numeric_limits<double>::infinity()) const;

  // The same nearest point as nearest() (ties included), and in sq_second the squared distance of
  // the next nearest, or sq_max_distance when no other point lies within it: every other point
  // lies at least that far. A query moved by less than half the difference of the two distances
  // keeps its nearest (the triangle inequality; stitch/multiview_icp.cpp).
  bool nearest_two(const Eigen::Vector3d& query, Neighbor& out, double& sq_second,
                   double sq_max_distance = std::numeric_limits<double>::infinity()) const;

  // The min(k, size()) nearest points, closest first, written into `out` (resized).
  void knn(const Eigen::Vector3d& query, std::size_t k, std::vector<Neighbor>& out) const;

  // The same neighbourhood in an unspecified order (the same for a given tree and query), for
  // callers that need the set and not the ranking, as the normals do: ~20 % faster for k = 20
  // (bench KdTreeKnn). Among points tied at the k-th distance it may keep others than knn.
  void knn_unsorted(const Eigen::Vector3d& query, std::size_t k, std::vector<Neighbor>& out) const;

  // All points with squared distance <= sq_radius, closest first, written into `out`.
  void radius(const Eigen::Vector3d& query, double sq_radius, std::vector<Neighbor>& out) const;
  // The same set in the tree's order (the same for a given tree and query), for callers that
  // visit every neighbour alike: the point pair voting's thousands a query spent 8 % of
  // `align3d find` ranking them.
  void radius_unsorted(const Eigen::Vector3d& query, double sq_radius,
                       std::vector<Neighbor>& out) const;

  // The input indices in the tree's leaf order: visiting the tree's own points in this order keeps
  // consecutive queries in the same or neighbouring leaves (what the normals do).
  const std::vector<std::uint32_t>& leaf_order() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t size_;
};

// The indices of `points` ordered along a Morton (Z-order) curve on a 1024³ grid over their
// bounding box (a stable radix sort, O(n)): consecutive indices are close in space, so queries
// issued in this order find the tree's nodes and points still in cache. The box is the finite
// points'; the others go anywhere without changing their order. `threads` (0: all cores) compute
// the keys and sort; the order does not depend on it.
std::vector<std::uint32_t> spatial_order(const std::vector<Eigen::Vector3d>& points,
                                         int threads = 1);

}  // namespace align3d
