// Global (coarse) registration: a pose that lands in the right basin whatever the initial pose, for
// ICP to refine (chapter 39.3: "ICP is a refiner, not a searcher"; coarse-to-fine).
//
//   fpfh: voxel-downsample both clouds, normals, FPFH descriptors (Rusu et al. 2009), descriptor
//         nearest-neighbour correspondences, RANSAC with edge-length pre-rejection; parallel
//         hypotheses, deterministic for a seed whatever the thread count.
//   ppf:  point pair features (Drost et al. 2010): a hashed model description of the object,
//         voting over (model reference point, rotation angle), pose clustering (coarse/ppf.hpp).
//
// Defaults follow the object, not the scene: of the two clouds, the one of smaller robust extent
// (cloud_stats.hpp: the bulk of its points, not a few strays) is the object being found, whichever
// role it has. The voxel is 1/50 of its extent, but at least 3 point spacings (the larger spacing
// of the two clouds: cloud_stats.hpp; a depth camera's sparse, noisy scene needs it); the feature
// radii are multiples of the voxel; fpfh matches descriptors from the object's points; the
// overlap requirement is a share of the object's points. So a 15 cm part is found in a 1 m
// depth-camera scene with the sampling the part needs, and the same data in mm or m behave alike.
//
// Honest failure: `success` is false, with a reason, when no pose has enough support; the caller
// must not hand such a pose to ICP as if it were right. `ambiguous` is set when a second, distinct
// pose (rotation differing by more than `distinct_rotation_deg` or translation by more than 2
// voxels) scores within `ambiguity_ratio` of the best (e.g. a symmetric part); the message gives
// the two values that were compared.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "align3d/cloud_stats.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

enum class GlobalMethod { kFpfh, kPpf };
inline const char* to_string(GlobalMethod m) { return m == GlobalMethod::kFpfh ? "fpfh" : "ppf"; }

struct GlobalSettings {
  GlobalMethod method = GlobalMethod::kFpfh;
  // Voxel size for downsampling both clouds (data units), for every method; 0: from the object's
  // extent and the spacing (see above). Feature radii are multiples of it.
  double voxel = 0.0;
  std::uint64_t seed = 1;
  int threads = 0;  // 0: all cores; the result does not depend on it
  // fpfh
  bool mutual_filter = false;  // keep only mutual descriptor nearest neighbours
  int ransac_iterations = 100000;
  double ransac_confidence = 0.9999;
  // Success: at the found pose at least this share of the object's downsampled points lies on the
  // other cloud's surface (surface_fit below; and, for fpfh, at least 3 × the minimal sample of
  // inlier correspondences).
  double min_overlap = 0.15;
  // Ambiguity report (see above).
  double ambiguity_ratio = 0.9;
  double distinct_rotation_deg = 10.0;
};

// Which input is the object (see above).
enum class Role { kSource, kTarget };
inline const char* to_string(Role r) { return r == Role::kSource ? "source" : "target"; }

struct GlobalResult {
  bool success = false;
  std::string message;  // why it failed, or a note; empty when nothing to say
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  // target ≈ T·source
  GlobalMethod method = GlobalMethod::kFpfh;
  Role object = Role::kTarget;  // the cloud the defaults followed
  // fpfh: inlier correspondences of the winner (the refined hypothesis with the best `overlap`);
  // ppf: the winner's fit (= overlap), by which it was chosen.
  double score = 0;
  double votes = 0;            // ppf: votes of the winning pose cluster (0 for fpfh)
  double overlap = 0;          // surface_fit of the object's downsampled points at the pose
  std::size_t candidates = 0;  // hypotheses (fpfh) or pose clusters (ppf) scored
  bool ambiguous = false;
  Eigen::Isometry3d second_T_target_source = Eigen::Isometry3d::Identity();  // when ambiguous
  double second_score = 0;  // the runner-up's value of the measure the ambiguity compared
  double voxel = 0;         // voxel size used
  double time_ms = 0;
};

// The object (the cloud of smaller robust extent) and the voxel in use: settings.voxel, or the rule
// above. From the clouds, or from their scales (cloud_stats.hpp) measured already.
Role object_role(const PointCloud& source, const PointCloud& target);
double global_voxel(const PointCloud& source, const PointCloud& target,
                    const GlobalSettings& settings);
Role object_role(const CloudScale& source, const CloudScale& target);
double global_voxel(const CloudScale& source, const CloudScale& target,
                    const GlobalSettings& settings);

class GlobalTargetCache;  // coarse/target_cache.hpp

// What the caller has measured or kept already (align() passes it); every member is optional.
struct GlobalContext {
  const CloudScale* source = nullptr;  // measure_scale() of each cloud
  const CloudScale* target = nullptr;
  GlobalTargetCache* target_cache = nullptr;  // the target's descriptors, kept across calls
};

// The object and the voxel of a pair, for every method: from the context's scales, or measured
// here (the spacing only when settings.voxel does not fix the voxel). Throws DataError(object, …)
// when there is no length scale for the voxel (all points at one spot).
struct GlobalPlan {
  Role object = Role::kTarget;
  double voxel = 0;
};
GlobalPlan plan_global(const PointCloud& source, const PointCloud& target,
                       const GlobalSettings& settings, const GlobalContext& context = {});

// The share of `cloud` points that T lays onto the surface of `other` (`other_tree` indexes it;
// both clouds have normals): a point of `other` within 1.5 voxels, the moved point within 0.25
// voxel of its tangent plane, and normals within 20° up to sign. Stricter than mere nearness, it
// tells a fit from a pose that only lies among the other cloud's points (a plane slid over a
// plane, a flipped part, a cloud of scattered points that any coarse pose comes near).
double surface_fit(const PointCloud& cloud, const PointCloud& other, const KdTree& other_tree,
                   const Eigen::Isometry3d& T, double voxel, int threads = 0);

// Runs the chosen method. Throws DataError("source"/"target", …) when a cloud is too small or
// degenerate for descriptors (fewer than 10 points after downsampling, or all points on a line).
GlobalResult global_register(const PointCloud& source, const PointCloud& target,
                             const GlobalSettings& settings = {},
                             const GlobalContext& context = {});

}  // namespace align3d
