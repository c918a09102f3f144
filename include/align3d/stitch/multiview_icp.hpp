// Multi-view ICP: every scan against its neighbours at once, all poses solved together (the
// last step of stitch.hpp), so that a loop's residual is spread over all its scans instead of
// being left on the edges a pose graph could not see inside.
//
// Each iteration pairs, for every link (a, b) and both ways, the sampled points of one scan with
// their nearest point of the other (in node 0's frame at the current poses) within `max_distance`,
// point-to-plane with the other's normal (a partner whose normal differs by more than 45° is on
// another face: no pair), weighted by a Geman-McClure kernel of scale
// max_distance / 2; the Gauss-Newton step of all poses (left updates about the scans' common
// centroid; node 0 held fixed) is one dense 6N × 6N solve. Written here rather than with Ceres:
// the pairs are found again at every iteration, and the normal equations are LinearSystem6's sums
// (icp/factors.hpp) laid out in blocks, a few hundred unknowns at most.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

struct MultiviewScan {
  const PointCloud* cloud = nullptr;  // its own frame, with normals
  const KdTree* tree = nullptr;       // indexes *cloud
  std::vector<std::uint32_t> sample;  // the points it pairs with its neighbours
};

struct MultiviewSettings {
  double max_distance = 1;  // data units
  int max_iterations = 30;
  // Stop when no pose moves by more than this (rotation in radians times `length`, plus
  // translation, in data units).
  double tolerance = 1e-6;
  double length = 1;  // the object's size, for the rotation part of the tolerance
  int threads = 0;
};

struct MultiviewPairs {
  std::size_t count = 0;
  std::vector<double> distances;  // |point-to-plane| of each pair, unweighted
};

struct MultiviewResult {
  std::vector<Eigen::Isometry3d> poses;
  int iterations = 0;
  // Per scan, its sampled points' pairs in the final poses (point-to-plane distances).
  std::vector<MultiviewPairs> residuals;
};

// `poses[k]` maps scan k into node 0's frame; `links` are pairs of scan indices (each once).
// Scans in no link keep their pose.
MultiviewResult multiview_icp(const std::vector<MultiviewScan>& scans,
                              const std::vector<std::pair<std::size_t, std::size_t>>& links,
                              std::vector<Eigen::Isometry3d> poses,
                              const MultiviewSettings& settings);

}  // namespace align3d
