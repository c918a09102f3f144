// Surface normals by PCA of each point's k nearest neighbours (chapter 39.4): the eigenvector of
// the smallest eigenvalue of the neighbourhood covariance.
//
// Orientation: a PCA normal has no sign. By default every normal is turned to point toward +Z
// (n·ẑ >= 0), which suits a sensor looking down on a conveyor; set `viewpoint` to orient toward a
// sensor position instead (n·(viewpoint − p) >= 0). Point-to-plane ICP does not depend on the sign.
// A neighbourhood with all points coincident or collinear has no normal: it gets +Z (or the
// direction to the viewpoint) and is counted in NormalResult::undefined.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

struct NormalSettings {
  int k = 20;                                // neighbours including the point itself; >= 3
  std::optional<Eigen::Vector3d> viewpoint;  // orient toward this point; default: toward +Z
  int threads = 0;                           // 0: all cores
};

struct NormalResult {
  std::size_t undefined = 0;  // neighbourhoods with no plane (coincident or collinear points)
};

// Sets cloud.normals. `tree` must index cloud.positions (std::invalid_argument when its size
// differs). k is clamped to the cloud size.
NormalResult estimate_normals(PointCloud& cloud, const KdTree& tree,
                              const NormalSettings& settings = {});
NormalResult estimate_normals(PointCloud& cloud, const NormalSettings& settings = {});

}  // namespace align3d
