// Multi-view stitching: many scans of one object into the frame of the first, as one consistent
// surface (the chapter's first job). The engine of `align3d stitch` and `align3d.stitch`.
//
// The input order carries no meaning (a turntable's order, a file listing, a shuffle give the same
// poses up to the first scan's frame). The steps:
//   1. pairs (stitch/pair_candidates.hpp): every pair of scans, several candidate poses each: point
//      pair feature voting of one scan against the other's table (the scans thinned to 1/40 of
//      the object's size), the strongest pose clusters refined by ICP, kept when at least
//      `min_overlap` of the smaller scan lies on the other's surface, when the fit is at the noise
//      (a view of a box laid on a large wavy sheet overlaps it coarsely, not at the noise), and
//      when neither scan lies in front of what the other's sensor saw (free space: a depth map of
//      each scan by direction from its viewpoint); scored by overlap less free space. A box-like
//      part's plain faces fit each other turned by a quarter or a half, and a near-symmetric
//      part's views fit each other turned about its axis, often better than the truth: the truth
//      is among a pair's few best, not always first. Nothing assumes neighbours in the list are
//      neighbours on the object.
//   2. the choice (stitch/selection.hpp): one pose per scan for the whole set at once. Candidates
//      that close loops with others (i→k→j composes to i→j) are taken first, scans are joined
//      into groups (Kruskal) unless a join makes two scans of the groups contradict each other
//      (free space), and of the choices that leave out one early join the one most candidates
//      agree with is kept. Then a scan moves to another placement its candidates give it when
//      that, refined on the other scans, puts clearly more of its points on their surfaces, and
//      a part of the set moves as one where more candidates from more scans put it, when that
//      contradicts no other scan. A scan (or part) that another placement fits nearly as well,
//      or that stronger candidates put elsewhere, is ambiguous (the warning `ambiguous_scans`).
//      Each pair's candidate that agrees with the choice is its edge, refined at full resolution
//      (ICP at 2, 1 and ½ of the pair's reach, Geman-McClure), with its overlap, RMS and
//      information matrix (icp/information.hpp: the point-to-plane ICP Hessian at the optimum over
//      the noise variance); a pair none agrees with is reported, not kept ("inconsistent").
//   3. the pose graph (stitch/pose_graph.hpp): poses from a maximum spanning tree of the edges by
//      overlap, then all optimised at once with Ceres (a robust loss on every edge); an edge that
//      disagrees with the optimised graph by more than prune_rotation_deg or prune_translation ×
//      the object's diameter is pruned, the worst first, and the graph re-optimised without it.
//   4. multi-view ICP (stitch/multiview_icp.hpp): every scan against its neighbours in the
//      optimised frame (the kept edges, and any other two scans that overlap there by
//      min_overlap: a near-symmetric part's pair whose candidates all came turned still holds its
//      turn), all poses solved together, so the residual is spread over the loop instead of
//      accumulating along it: pairs of a few thousand points a scan within the pairs' reach, then
//      of the half of each scan's points that hold its pose best (icp/sampling.hpp: the points of
//      most leverage, which a near-symmetric part's turn rests on, and every m-th of the others)
//      within a spacing or three noise levels; each stage stops when the scans have settled, but
//      for any that keeps sliding (multiview_icp.hpp).
//   5. the merged cloud (stitch/merge.hpp): the scans in the first scan's frame, one point per
//      voxel (size from the scans' point spacing, or `voxel`), normals oriented towards the sensor
//      of the scan they came from and averaged, the scan index of each merged point.
//   6. the check: every two connected scans at their final poses, joined by an edge or not, must
//      not contradict each other (the free-space test of step 2, counting the points that face
//      the other sensor at less than 70°): more than kMaxInconsistency of one in front of what
//      the other saw is the warning `inconsistent_scans`. Measured on the generated sets
//      (bench/compare_stitch.py): at the true poses every pair ≤ 3 %; at the wrong results, up to
//      100 %.
// Scans that no kept edge connects to the first scan are reported (`connected` false, a warning),
// never forced in; they are left out of the merged cloud. A scan whose pose may be wrong (held by
// one edge, ambiguous, or inconsistent) lists those warnings in its own StitchScan::warnings.
//
// Conventions: `transformation` of a scan maps it into the frame of the first scan given
// (scan_0 ≈ T·scan_k); an edge's maps its source scan into its target scan's frame
// (target ≈ T·source). Units: the data's; every distance default follows the data.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "align3d/icp/refine.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/progress.hpp"
#include "align3d/se3.hpp"
#include "align3d/warning.hpp"

namespace align3d {

// The check (step 6): the largest share of one stitched scan allowed in front of another's view.
constexpr double kMaxInconsistency = 0.1;
// The merged cloud's default voxel, in median point spacings of the scans.
constexpr double kMergeVoxelSpacings = 1.5;

struct StitchSettings {
  // An edge needs this share of the smaller scan on the other at the pair's global pose.
  double min_overlap = 0.2;
  // Edges disagreeing with the optimised graph by more than this are pruned.
  double prune_rotation_deg = 1.0;
  double prune_translation = 0.01;  // share of the object's diameter
  int multiview_iterations = 30;    // cap of each multi-view ICP stage (stops when poses settle)
  // The ICP cost of each edge's refinement and of the multi-view ICP, and their kernel. Unset
  // kernel: Geman-McClure at half the reach, for both; a kernel with scale 0 takes its tuning
  // constant × σ̂ there, σ̂ the point-to-plane noise of a pair (√2 × the noisiest scan's,
  // cloud_stats.hpp). Point-to-point pairs two scans' samples, a bias of the sampling the
  // multi-view ICP would spread over every scan (tests/stitch_test.cpp's ring from 0.5° off: still
  // 0.3° and 2 mm off after 300 iterations, where the other costs end within 0.1° and 0.2 mm): it
  // refines the edges only, the multi-view ICP running point-to-plane.
  CostSettings cost;
  double voxel = 0;  // merged cloud; 0: kMergeVoxelSpacings × the median spacing
  // Where each scan's sensor was, in that scan's frame (normals are oriented towards it and free
  // space is seen from it): one per scan, or empty. A scan with none (most PLY, XYZ and OBJ
  // exports) gets its frame's origin when the scan could have been seen from there, else a
  // position estimated from the scan itself (StitchScan::sensor says which).
  std::vector<std::optional<Eigen::Vector3d>> viewpoints;
  int threads = 0;  // 0: all cores; the result does not depend on it
  ProgressCallback progress;
};

struct StitchEdge {
  std::size_t source = 0, target = 0;  // scan indices (input order), source < target
  Eigen::Isometry3d transformation = Eigen::Isometry3d::Identity();  // target ≈ T·source
  Matrix6d information = Matrix6d::Zero();  // (rotation, translation) about the target's origin
  double overlap = 0;  // share of the smaller scan on the other at the pose (support.hpp)
  double rms = 0;      // point-to-plane RMS of its pairs at the pose (information.hpp)
  // The larger of the two shares of a scan's points lying in front of what the other saw (step 2).
  double free_space = 0;
  std::size_t pairs = 0;                               // of the information matrix
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  // of those pairs, target frame
  bool kept = false;
  // Why it was not kept, empty when kept: "weak" (fewer than 6 pairs at the refined pose),
  // "inconsistent" (none of the pair's candidates agrees with the chosen poses: step 2), "pruned"
  // (disagrees with the pose graph).
  std::string status;
  // The final poses against this edge: the rotation angle (degrees) of the disagreement
  // E = X_target⁻¹·X_source·T⁻¹ and the distance it moves `centroid` (data units); NaN when a
  // scan of the edge is not connected.
  double rotation_residual_deg = 0, translation_residual = 0;
  std::vector<Warning> warnings;  // of its registration
};

// How a scan's sensor position was known: given (by its file, io::sensor_position, or by the
// caller), the frame's origin (none given; the scan could have been seen from there), or
// estimated from the scan (none given, and the origin lies under or inside the object).
enum class SensorSource { kGiven, kOrigin, kEstimated };
std::string_view to_string(SensorSource s);

struct StitchScan {
  Eigen::Isometry3d transformation = Eigen::Isometry3d::Identity();  // scan_0 ≈ T·scan_k
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();               // its sensor, in its own frame
  SensorSource sensor = SensorSource::kGiven;
  bool connected = false;  // reached from the first scan through kept edges
  std::size_t points = 0;
  std::size_t edges = 0;  // kept edges at this scan
  // Distances of its points (the second multi-view ICP stage's half, step 4) to its neighbours'
  // surfaces (point-to-plane, pairs within that stage's reach) in the final poses: their count,
  // RMS, median and 95th percentile.
  std::size_t pairs = 0;
  double rms = 0, median = 0, p95 = 0;
  // The codes of the result's warnings that name this scan (unconnected_scan, single_edge_scan,
  // ambiguous_scans, inconsistent_scans), in the result's order: with any but the first its pose
  // may be wrong.
  std::vector<std::string> warnings;
};

struct StitchTimings {
  double pairs_ms = 0, edges_ms = 0, graph_ms = 0, multiview_ms = 0, merge_ms = 0, total_ms = 0;
};

struct StitchResult {
  std::vector<StitchScan> scans;  // input order
  std::vector<StitchEdge> edges;  // every pair found to overlap, kept or not, by (source, target)
  PointCloud merged;              // the first scan's frame, with normals
  std::vector<std::int32_t> merged_scan;  // per merged point: the scan most of its voxel came from
  double voxel = 0;                       // of the merge
  double diameter = 0;  // the object's: the largest robust extent of a scan (cloud_stats.hpp)
  int multiview_iterations = 0;
  std::vector<Warning> warnings;
  StitchTimings timings;
};

// Throws std::invalid_argument naming the field for unusable settings and DataError("scan K", …)
// for a scan that cannot be registered (NaN, too few points, degenerate: cloud_stats.hpp); fewer
// than two scans is a DataError too.
StitchResult stitch(const std::vector<PointCloud>& scans, const StitchSettings& settings = {});

}  // namespace align3d
