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
#include <cstdint>
#include <optional>
#include <vector>

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

// Turns each of cloud.normals toward `viewpoint` (n·(viewpoint − p) >= 0): estimate_normals' result
// for another viewpoint without a second search, but for the neighbourhoods with no plane, whose
// normal stays the line toward the first viewpoint.
void orient_normals(PointCloud& cloud, const Eigen::Vector3d& viewpoint, int threads = 1);

// Where the sensor of a one-sided range scan was, estimated from the scan alone (its normals, of
// either sign): a range scan is one side of its object, seen along the axis its normals face most
// (the principal axis of Σ n·nᵀ), from the side its surface bulges to (objects are convex on the
// whole: normals turned that way point away from the centroid on average); placed two `extent`s
// from the centroid. Over every m-th point, at most ~2000. For a closed surface the answer is a
// point outside it with no meaning of its own.
Eigen::Vector3d estimated_viewpoint(const PointCloud& cloud, double extent);

// Normals estimated only where they are used. Point-to-plane ICP needs a target normal only at the
// target points that receive a partner, often a fraction of the target (a partial scan of a larger
// model: half of the generated parts scenes, three quarters of the chapter's model), so
// refine() estimates them through this cache. Each normal has the bits estimate_normals
// gives it, so the registration is the same as with every normal estimated first.
// Lifetime: keeps references to `cloud` and `tree` (which must index cloud.positions), which must
// outlive the cache unchanged. Thread-safety: require() runs in parallel itself and must not be
// called concurrently; the const accessors may be read from any thread between calls.
class NormalCache {
 public:
  NormalCache(const PointCloud& cloud, const KdTree& tree, const NormalSettings& settings = {});

  // Estimates the normals of the points `indices` (repeats allowed) not estimated yet;
  // std::out_of_range for an index >= cloud.size().
  void require(const std::vector<std::uint32_t>& indices);

  bool known(std::size_t i) const { return state_[i] != kUnknown; }
  // One per point of the cloud; meaningful where known().
  const std::vector<Eigen::Vector3d>& normals() const { return normals_; }
  const PointCloud& cloud() const { return cloud_; }
  const KdTree& tree() const { return tree_; }
  const NormalSettings& settings() const { return settings_; }
  std::size_t estimated() const { return estimated_; }  // points whose normal has been estimated
  std::size_t undefined() const { return undefined_; }  // of those, neighbourhoods with no plane

 private:
  enum State : unsigned char { kUnknown, kDefined, kUndefined, kPending };  // pending: in require
  const PointCloud& cloud_;
  const KdTree& tree_;
  NormalSettings settings_;
  std::vector<Eigen::Vector3d> normals_;
  std::vector<State> state_;
  std::size_t estimated_ = 0, undefined_ = 0;
};

}  // namespace align3d
