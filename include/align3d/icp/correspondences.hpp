// Correspondence search (chapter 39.1 step 1): each source point, moved by the current pose, is
// paired with its nearest target point (kd-tree, O(log M) per query), or, for a mesh target, with
// the exact closest point on its triangles (mesh_index.hpp), not with a sampled vertex.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "align3d/kdtree.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

constexpr std::size_t kNoPartner = std::numeric_limits<std::size_t>::max();

// One entry per source point: its partner's target index (kNoPartner when none lies within the
// search bound) and the true (not squared) distance to it (infinity when none).
struct Correspondences {
  std::vector<std::size_t> target;
  std::vector<double> distance;
  // A mesh target's partners: the closest point on the surface and its triangle's unit normal
  // (`target` then holds the triangle). Empty for a point-cloud target.
  std::vector<Eigen::Vector3d> point, normal;
  // Pairs the update sets aside (non-zero; IcpSettings::reciprocity): counted in the RMS and the
  // kept pairs, left out of the system. Empty: none. Not touched by the searches below.
  std::vector<std::uint8_t> aside;
};

// Whether source point i has a partner within `threshold` (a kept pair).
inline bool is_kept(const Correspondences& c, std::size_t i, double threshold) {
  return c.target[i] != kNoPartner && c.distance[i] <= threshold;
}

// Pairs T·source[i] with its nearest target point closer than `bound` (data units; infinity: no
// bound). `tree` indexes target.positions. When `pairs` already holds the previous iteration's
// partners of the same source, each one bounds its new search: the nearest point is at most as
// far as the old partner, so the result is the same exact nearest neighbour, found with far less
// backtracking. Runs on `threads` threads (0: all cores); the result does not depend on it.
void find_correspondences(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                          const KdTree& tree, const Eigen::Isometry3d& T, double bound, int threads,
                          Correspondences& pairs);

// Sets aside (Correspondences::aside) each pair within `threshold`, longer than `floor`, whose
// target point has another kept pair shorter than its distance ÷ `reciprocity` (1: PCL's
// CorrespondenceRejectorOneToOne, which keeps only the shortest pair of each target point;
// `targets` the target's size). Turk and Levoy (1994) drop pairs on a mesh's boundary for the same
// reason: the source points beyond the overlap pair with the rim, along the surface, and the rim's
// partners inside the overlap are closer to it (refine.hpp has the measurements on the animal).
void set_aside_crowded(std::size_t targets, double threshold, double reciprocity, double floor,
                       int threads, Correspondences& c);

// The signed distance of T·source[i] along its partner's normal, for each pair kept within
// `threshold` and not set aside, in source order: onto a mesh's surface (c.point, c.normal;
// `target` and `normals` unused) when c.point is filled, else onto the target point with `normals`
// (indexed as target.positions). What a fit at the noise judges (icp/fit.hpp).
std::vector<double> normal_residuals(const std::vector<Eigen::Vector3d>& source,
                                     const Eigen::Isometry3d& T, const Correspondences& c,
                                     double threshold, const PointCloud& target,
                                     const std::vector<Eigen::Vector3d>& normals, int threads = 1);

// Pairs T·source[i] with its closest point on `surface` closer than `bound` (the same contract);
// consecutive source points close in space make the search cheap (MeshIndex::closest_points).
void find_surface_correspondences(const std::vector<Eigen::Vector3d>& source,
                                  const MeshIndex& surface, const Eigen::Isometry3d& T,
                                  double bound, int threads, Correspondences& pairs);

}  // namespace align3d
