// Global (coarse) registration: a pose that lands in the right basin whatever the initial pose, for
// ICP to refine (chapter 39.3: "ICP is a refiner, not a searcher"; coarse-to-fine).
//
//   fpfh: voxel-downsample both clouds, normals, FPFH descriptors (Rusu et al. 2009), descriptor
//         nearest-neighbour correspondences, RANSAC with edge-length pre-rejection; parallel
//         hypotheses, deterministic for a seed whatever the thread count.
//   ppf:  point pair features (Drost et al. 2010): a hashed model description, voting over
//         (model reference point, rotation angle), pose clustering (coarse/ppf.hpp).
//
// Honest failure: `success` is false, with a reason, when no pose has enough support; the caller
// must not hand such a pose to ICP as if it were right. `ambiguous` is set when a second, distinct
// pose (rotation differing by more than `distinct_rotation_deg` or translation by more than 2
// voxels) scores within `ambiguity_ratio` of the best (e.g. a symmetric part).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "align3d/point_cloud.hpp"

namespace align3d {

enum class GlobalMethod { kFpfh, kPpf };
inline const char* to_string(GlobalMethod m) { return m == GlobalMethod::kFpfh ? "fpfh" : "ppf"; }

struct GlobalSettings {
  GlobalMethod method = GlobalMethod::kFpfh;
  // Voxel size for downsampling (data units); 0: derived from the data, L/50 with L the target's
  // bounding-box diagonal (unit-free). Feature radii are multiples of it.
  double voxel = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;  // 0: all cores; the result does not depend on it
  // fpfh
  bool mutual_filter = false;  // keep only mutual descriptor nearest neighbours
  int ransac_iterations = 100000;
  double ransac_confidence = 0.9999;
  // Success: at the found pose at least this share of the downsampled source lies within
  // 1.5 voxels of the target (and at least 3 × the minimal sample of inlier correspondences).
  double min_overlap = 0.15;
  // Ambiguity report (see above).
  double ambiguity_ratio = 0.9;
  double distinct_rotation_deg = 10.0;
};

struct GlobalResult {
  bool success = false;
  std::string message;  // why it failed, or a note; empty when nothing to say
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  // target ≈ T·source
  GlobalMethod method = GlobalMethod::kFpfh;
  double score = 0;            // fpfh: inlier correspondences of the best hypothesis; ppf: votes
  double overlap = 0;          // share of the downsampled source within 1.5 voxels at the pose
  std::size_t candidates = 0;  // hypotheses (fpfh) or pose clusters (ppf) scored
  bool ambiguous = false;
  Eigen::Isometry3d second_T = Eigen::Isometry3d::Identity();  // the runner-up when ambiguous
  double second_score = 0;
  double voxel = 0;  // voxel size used
  double time_ms = 0;
};

// Shared by the methods: the voxel size in use (settings.voxel, or L/50 of the target); and the
// share of `source` points that T brings within `radius` of a target point (`tree` indexes target).
double global_voxel(const PointCloud& target, const GlobalSettings& settings);
class KdTree;
double overlap_fraction(const PointCloud& source, const KdTree& tree, const Eigen::Isometry3d& T,
                        double radius, int threads = 0);

// Runs the chosen method. Throws DataError when a cloud is too small or degenerate for descriptors
// (fewer than 10 points after downsampling, or all points on a line).
GlobalResult global_register(const PointCloud& source, const PointCloud& target,
                             const GlobalSettings& settings = {});

}  // namespace align3d
