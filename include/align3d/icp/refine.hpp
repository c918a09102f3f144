// Refinement of a pose by ICP: the ICP layer's entry point, used by align() (align.hpp) for every
// path, and callable on its own.
//
// With a fixed rejection rule this is one ICP run (chapter 39.1-39.4). With the default `auto`
// rejection (RejectionRule::automatic()) it is a coarse-to-fine schedule that does not let the
// dominant plane of a conveyor scene capture the estimate (the failure of the median rule on such
// scenes):
//   1. scales from the data: L = the extent of the object, the smaller cloud (robust_extent of
//      source and target, cloud_stats.hpp: a part registered into a wide scene is not pulled by
//      clutter an eighth of the scene away), s = target point spacing (median nearest-neighbour
//      distance), so the same data in mm or m behaves the same;
//   2. point-to-plane ICP with a maximum correspondence distance τ that starts at L/8 and halves
//      each time a stage has settled, pairs weighted by a Geman-McClure kernel of scale τ/2, so far
//      pairs (outliers, the intruder wall) pull little while the distinctive structure (box, cap)
//      stays in reach long enough to fix x, y and yaw;
//   3. once τ is down to 3 s, the requested metric runs to convergence with τ = max(3 s, 4 σ̂)
//      (σ̂: the point-to-plane RMS of the last stage, i.e. the noise), still weighted.
// On large clouds the coarse stages of step 2 use an even thinning of the source to at most 50 000
// points (every m-th point along a Morton curve); the final stage uses every point.
// Target normals are used for `auto` whatever the final metric. The coarse stages run
// point-to-plane, or the symmetric cost when it is the final metric (its wider basin is the point
// of it). GICP in the coarse stages lost the chapter scene from 12° (7.4° off at the end), where
// point-to-plane ones do not: GICP runs the final stage only. Measured on the conveyor
// variants and partial object views of tests/refine_test.cpp; the point-to-point coarse stages we
// tried first slid along the plane toward the intruder wall on the wide-plane variant.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "align3d/icp/icp.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/normals.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

// The cost ICP minimises and the kernel weighing its pairs: the choice every command that refines
// offers (register, inspect, stitch, find; set_kernel() parses the kernel's name).
struct CostSettings {
  IcpMethod method = IcpMethod::kPointToPlane;  // the final metric
  // The kernel weighing the pairs (kernels.hpp). Unset: each command's own default (refine():
  // below). Set: kernel_scale > 0 in data units, else kernel_tuning(kernel) × σ̂, the noise as each
  // command estimates it.
  std::optional<RobustKernel> kernel;
  double kernel_scale = 0;
};

struct RefineSettings : CostSettings {
  RejectionRule rejection = RejectionRule::automatic();  // kAuto: the schedule above
  // For a fixed rule, of the single run; for `auto`, of the final stage (the coarse stages have
  // their own cap of 30 iterations and looser tolerances).
  TerminationSettings termination;
  // The kernel (CostSettings): unset, `auto` weighs every stage by Geman-McClure at τ/2 (above)
  // and a fixed rule does not weigh. Set, the final stage of `auto` (its coarse stages keep their
  // own) or the single run use it, σ̂ being for `auto` the last coarse stage's RMS, for a single
  // run the median residual of each iteration (solver.hpp).
  // For target normals when the target has none, and for the source's when the method needs them
  // (GICP, symmetric) and it has none (k; threads ignored).
  NormalSettings normals;
  int threads = 0;  // 0: all cores; the result does not depend on it
};

// The target of any number of refinements, prepared once: a copy in spatial order (the search,
// the normals and the ICP sums then touch memory in order; a pose does not depend on the order of
// the points), its kd-tree, and its normals: the file's, or estimated on demand where pairs need
// them (NormalCache). Lifetime: self-contained (copies the cloud). Not copyable or movable (the
// cache refers to the copy). Thread-safety: one refinement at a time; any number at once after
// estimate_all_normals() (everything a refinement reads is then measured: PreparedTarget).
//
// A mesh target (a CAD model) is registered onto its exact surface: ICP pairs each source point
// with its closest point on the triangles (icp.hpp). What needs points (the schedule's spacing, the
// global stage, the support measure) uses an even sample of the surface by area (sample_surface,
// mesh.hpp, with the triangles' normals): one point per (diagonal / kMeshSampleDivisions)² of area,
// kMinMeshSamples to kMaxMeshSamples points, seeded by kMeshSampleSeed (the same mesh gives the
// same sample).
inline constexpr double kMeshSampleDivisions = 400;
inline constexpr std::size_t kMinMeshSamples = 20000;
inline constexpr std::size_t kMaxMeshSamples = 400000;
inline constexpr std::uint64_t kMeshSampleSeed = 1;

// That sample of a mesh (with the triangles' normals; the file order of sample_surface).
PointCloud mesh_target_sample(const MeshIndex& surface);

class RefineTarget {
 public:
  RefineTarget(const PointCloud& target, const NormalSettings& normals = {}, int threads = 0);
  // A mesh target; shares `surface`.
  explicit RefineTarget(std::shared_ptr<const MeshIndex> surface, int threads = 0);
  ~RefineTarget();
  RefineTarget(const RefineTarget&) = delete;
  RefineTarget& operator=(const RefineTarget&) = delete;

  const PointCloud& cloud() const { return cloud_; }  // the spatially ordered copy (or sample)
  const MeshIndex* surface() const { return surface_.get(); }  // null for a point-cloud target
  const std::shared_ptr<const MeshIndex>& shared_surface() const { return surface_; }
  const KdTree& tree() const { return *tree_; }
  int normal_k() const { return normal_k_; }
  // The normal of every point in `indices` of cloud() (estimated first where needed), then all
  // normals, meaningful at the points required so far.
  const std::vector<Eigen::Vector3d>& normals(const std::vector<std::uint32_t>& indices);
  NormalCache* cache() { return cache_.get(); }  // null when the cloud came with normals
  double spacing();                              // point_spacing(), measured once
  double extent();                               // robust_extent(), measured once
  // Estimates every normal, the spacing and the extent now (for a target shared by many calls).
  void estimate_all_normals();

 private:
  PointCloud cloud_;
  std::shared_ptr<const MeshIndex> surface_;
  std::unique_ptr<KdTree> tree_;
  std::unique_ptr<NormalCache> cache_;
  int normal_k_ = 20;
  double spacing_ = -1, extent_ = -1;
};

struct StageRecord {
  std::string metric;       // "point-to-point" or "point-to-plane"
  double max_distance = 0;  // τ of the stage (infinity for none, per-iteration for median)
  int first_iteration = 0;  // index into the combined history of the stage's first evaluation
                            // (a stage has iterations + 1 records: its start pose, then one per
                            // update)
  int iterations = 0;
};

struct RefineResult {
  IcpResult icp;                         // the final stage; T_target_source is the answer
  std::vector<IterationRecord> history;  // every iteration of every stage, in order
  std::vector<StageRecord> stages;
  int total_iterations = 0;
  double point_spacing = 0;  // the target spacing s used for `auto` (0 otherwise)
  // Target normals estimated so far when the target has none: only where pairs needed them
  // (normals.hpp, NormalCache), and of those, the neighbourhoods with no plane.
  std::size_t estimated_normals = 0;
  std::size_t undefined_normals = 0;
};

// The name set_kernel() takes for settings.kernel: "auto" when unset, else the kernel's.
inline const char* kernel_name(const CostSettings& settings) {
  return settings.kernel ? to_string(*settings.kernel) : "auto";
}

// Sets settings.kernel and kernel_scale from a name ("auto": unset, or a name of kernels.hpp) and a
// scale (data units, >= 0; 0: from the noise). std::invalid_argument for an unknown name, a
// negative or non-finite scale, or a scale with "auto" (the schedule sets its own).
void set_kernel(CostSettings& settings, std::string_view name, double scale);

// Throws DataError("source"/"target", …) when a cloud has too few points (fewer than 6, or fewer
// than the normal neighbourhood for point-to-plane) or is degenerate (all points on one line or at
// one spot).
RefineResult refine(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& init,
                    const RefineSettings& settings = {});
RefineResult refine(const PointCloud& source, const PointCloud& target,
                    const Eigen::Isometry3d& init, const RefineSettings& settings = {});

}  // namespace align3d
