// Step 1 of a stitch (stitch.hpp): the poses two scans may have relative to each other, several
// per pair, for the global choice (stitch/selection.hpp) to pick from. Internal to the engine.
//
// One best pose per pair is not enough: a box-like part's plain faces fit each other turned by a
// quarter or a half, and a near-symmetric part's scans fit each other turned about its axis with
// more overlap than the truth (each scan's visible half put onto the other's), so the truth is
// often not the pair's best fit, though it is among its few best. Per pair (source i, target j):
//   1. point pair feature voting (coarse/ppf.hpp, ppf_hypotheses) of scan j's thinned points
//      against scan i's table (its normals point to its sensor: the outward side of what it saw),
//      the kHypotheses strongest pose clusters;
//   2. each refined by point-to-plane ICP of a probe of scan i's thinned points (at most
//      kProbePoints) onto scan j's (2 then 1 voxel; those that meet after the first round go on
//      once), its overlap the share of the smaller scan's thinned points (by robust extent) on
//      the other's surface (surface_fit); those of at least min_overlap, distinct, the kFineKept
//      best by overlap going on;
//   2b. when two or more of those turn about one axis from the best (a part of revolution, or
//      nearly), the best turned about that axis in steps, the turns of least free space added;
//   3. each refined again on a sample of scan i against all of scan j, kept when it fits at the
//      noise (the point-to-plane RMS within the reach at most kMaxFitRms × the pair's noise floor:
//      a box's view laid on a large wavy sheet overlaps it at the coarse voxel), and tested against
//      free space: the share of either scan's points that face the other sensor and lie in front of
//      what it saw (stitch/views.hpp) must not pass kMaxPairFreeSpace. A wrong turn of a
//      near-symmetric part shows there (a key or lug put where the other sensor saw the plain
//      rim): measured on the generated flange sets, right poses 0–0.6 %, the wrong ones of best
//      overlap 1–2.3 %;
//   4. scored overlap − kFreeSpaceWeight × free space; the kKept best distinct ones are returned.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <initializer_list>
#include <memory>
#include <vector>

#include "align3d/coarse/ppf.hpp"
#include "align3d/kdtree.hpp"
#include "stitch/views.hpp"

namespace align3d::detail {

// Step 4's weight of the free-space share against the overlap.
constexpr double kFreeSpaceWeight = 30;

struct PairCandidate {
  std::size_t source = 0, target = 0;  // scan indices, source < target
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double overlap = 0;     // step 2
  double free_space = 0;  // step 3
  double score = 0;       // step 4
};

// What a scan brings to every pair, prepared once: its point pair feature table (with `table`:
// only a pair's first scan votes with its table, so the last scan needs none; model.voxel is set
// either way), its thinned cloud (normals to its sensor) with a tree, a probe of that cloud
// (kProbePoints) and a sample of its own points (kFineSamples), each taken every m-th.
struct PairSearchScan {
  PpfModel model;
  PointCloud down;
  std::unique_ptr<KdTree> down_tree;
  PointCloud probe, sample;
};
PairSearchScan prepare_pair_search(const ScanData& scan, double voxel, bool table);

// The candidates of scans i < j, best score first (none when they do not overlap). `voxel` is the
// search's thinning (the model's, PairSearchScan::model.voxel); single-threaded (the caller runs
// pairs in parallel).
std::vector<PairCandidate> pair_candidates(std::size_t i, std::size_t j,
                                           const std::vector<ScanData>& scans,
                                           const std::vector<PairSearchScan>& search,
                                           const std::vector<DepthMap>& maps, double min_overlap);

// Point-to-plane ICP of `source` onto `target` (indexed by `tree`) from T, single-threaded, pairs
// within each reach in turn, `iterations` at most each; Geman-McClure of `kernel_scale` when that
// is positive.
Eigen::Isometry3d icp_rounds(const PointCloud& source, const PointCloud& target, const KdTree& tree,
                             Eigen::Isometry3d T, std::initializer_list<double> reaches,
                             int iterations, double kernel_scale = 0);

// Whether two relative poses of scan `source` agree: rotations within `degrees`, and the centroid
// c moved to within `distance`.
bool same_pose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const Eigen::Vector3d& c,
               double degrees, double distance);

}  // namespace align3d::detail
