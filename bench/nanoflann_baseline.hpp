// The kd-tree align3d used before its own (src/kdtree.cpp), kept as the benchmark's baseline: a
// nanoflann KDTreeSingleIndexAdaptor (leaf size 8) over a copy of the points in leaf order, with
// the same queries as align3d::KdTree (bounded nearest, k nearest). core_bench.cpp runs both on
// the same points so the hand-written tree has to keep earning its place.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <nanoflann.hpp>
#include <vector>

#include "align3d/kdtree.hpp"

namespace align3d::bench {

class NanoflannTree {
 public:
  // `threads` is accepted for the same signature as KdTree's; nanoflann builds on one thread.
  explicit NanoflannTree(const std::vector<Eigen::Vector3d>& input, int /*threads*/ = 1)
      : points_(input), tree_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(8)) {
    original_.assign(tree_.vAcc.begin(), tree_.vAcc.end());
    for (std::size_t k = 0; k < original_.size(); ++k) {
      points_[k] = input[original_[k]];
      tree_.vAcc[k] = static_cast<std::uint32_t>(k);
    }
  }

  bool nearest(const Eigen::Vector3d& query, Neighbor& out, double sq_max_distance) const {
    Bounded result(sq_max_distance);
    tree_.findNeighbors(result, query.data(), nanoflann::SearchParams());
    if (!result.found) return false;
    out = {original_[result.index], result.sq_best};
    return true;
  }

  void knn(const Eigen::Vector3d& query, std::size_t k, std::vector<Neighbor>& out) const {
    thread_local std::vector<std::uint32_t> indices;
    thread_local std::vector<double> sq_dists;
    indices.resize(k);
    sq_dists.resize(k);
    const std::size_t found = tree_.knnSearch(query.data(), k, indices.data(), sq_dists.data());
    out.resize(found);
    for (std::size_t i = 0; i < found; ++i) out[i] = {original_[indices[i]], sq_dists[i]};
  }

 private:
  struct Adaptor {
    const std::vector<Eigen::Vector3d>& points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][dim]; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  // k = 1 with the caller's bound as the initial radius.
  struct Bounded {
    explicit Bounded(double sq_bound) : sq_best(sq_bound) {}
    bool addPoint(double sq_d, std::size_t i) {
      if (sq_d < sq_best) {
        sq_best = sq_d;
        index = i;
        found = true;
      }
      return true;
    }
    double worstDist() const { return sq_best; }
    bool full() const { return found; }
    double sq_best;
    std::size_t index = 0;
    bool found = false;
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                   Adaptor, 3, std::uint32_t>;

  std::vector<Eigen::Vector3d> points_;  // in leaf order
  std::vector<std::uint32_t> original_;
  Adaptor adaptor_{points_};
  Tree tree_;
};

}  // namespace align3d::bench
