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
//      each time a stage has settled, while it is above 1.5 times the final stage's floor 3 s,
//      pairs weighted by a Geman-McClure kernel of scale τ/2, so far pairs (outliers, the intruder
//      wall) pull little while the distinctive structure (box, cap) stays in reach long enough to
//      fix x, y and yaw;
//   3. basin hopping (Wales and Doye 1997) when the answer the final stage (step 4, run first
//      from the coarse stages' pose) reaches is not confirmed by the data: its fit, the final
//      stage's own one-to-one pairs within τ_f = max(3 s, 4 σ̂) (σ̂: the last coarse stage's RMS),
//      above kConfirmedFit (icp/fit.hpp: the point-to-plane residuals against those a right pose
//      leaves), or too few pairs (fewer than min_pairs or 1 % of the source: the stages broke off
//      far from the object, or laid a sliver of it on the surface), the test align() calls
//      unconfirmed. The final stage decides rather than the coarse stages' end, whose pose is
//      only as precise as their weighted, not one-to-one pairs: on data far finer than its
//      spacing that end looked unconfirmed on right poses and paid for hops. Where the pose the
//      coarser levels reached already fits weakly (the probe's test, RefineSettings::probe), a run
//      that may hop skips the stages at full resolution and the final stage and hops at once.
//      GICP's coarse stages from the start are the first candidate (the source's normals are
//      estimated for it); a candidate is kept when it lays kClearlyBetter more of the source
//      within max(3 s, 4 σ₀) of the target (a reach of the data's noise, whatever the candidates'
//      RMS), and GICP's, kept and confirmed at its coarse end (at its own reach), ends step 3.
//      Else the coarse stages run again from the pose moved along the direction their last system
//      constrains least (Gelfand et al. 2003: a near-symmetry, where ICP's pairs exert almost no
//      pull) by ±kHopStep (a turn of 29°), then ±2 kHopStep (57°) and ±3 kHopStep (86°) while
//      none is kept; from a kept pose still unconfirmed the hops go on, at most kHopChain times.
//      If the pose is still unconfirmed after them, GICP's candidate is judged against it, and
//      the hops from it rerun GICP's stages. The final stage runs again from the candidate kept;
//   4. the requested metric runs to convergence with τ = max(3 s, 4 σ̂), still weighted, settling
//      only where its next update is below one standard deviation of the pose
//      (TerminationSettings::step_sigmas); onto a
//      point cloud, a pair longer than s/2 enters the update only when it is the shortest pair of
//      its target point (IcpSettings::reciprocity, 1; below), and point-to-point pairs each
//      source point with its foot on its partner's tangent plane, not with the sample
//      (IcpSettings::tangent_planes; below).
// On large clouds the coarse stages of step 2 use an even thinning of the source to at most 50 000
// points (every m-th point along a Morton curve); the final stage uses every point. A coarse stage
// whose reach τ spans kLevelReach (3) resolutions of a level runs on that level of both clouds:
// every 4^j-th point in spatial order (RefineTarget::level), at least 1 500 points each, so a far
// start's stages, where most queries find nothing within τ after a long descent, search a tree a
// 4^j-th the size with a 4^j-th of the queries; the search is bounded by τ (kdtree.hpp). On the
// dragon's 40 000-point scans the stages from L/8 down to 6 spacings run at levels 2 and 1
// (issue 55: 1.4-2.8 s a pair before, with the fit below, 0.1-0.2 s).
// Target normals are used for `auto` whatever the final metric. The coarse stages run
// point-to-plane whatever the final metric. GICP in the coarse stages lost the chapter scene from
// 12° (7.4° off at the end); the symmetric cost, whose source normals are flipped to face the
// target's, paired the two faces of the bracket's 12 mm upright and slid by its thickness from a
// 10 % shift (`align3d evaluate`'s bracket, 32 trials at 0-30° and 10 % of the diagonal: 370/384
// right with symmetric coarse stages, 384/384 with point-to-plane ones). The point-to-point coarse
// stages we tried first slid along the plane toward the intruder wall on the wide-plane variant.
// Measured on the conveyor variants and partial object views of tests/refine_test.cpp.
//
// Why the hop (bench/compare_basin.py, issue 18): on the bumpy sphere (a sphere with four domes and
// a post, seen 60 %) a turn about an axis through the sphere's centre and one dome moves only the
// other domes and the post; their points pair with the sphere under them, whose normals pull
// along the radius and exert no torque, so ICP from 20-30° and 10 % of the diagonal stopped 29-60°
// about that axis (RMS 4-10 σ₀, the truth 1.2-1.6 σ₀). That turn is the weakest direction of the
// system there. With the hop, bench/compare_basin.py (8 trials a cell) has every method right in
// every trial up to 30° and 10 % of the diagonal on the bumpy sphere (10° before) and up to 60° on
// the chapter scene and the bracket (45° before); 32 other starts at 30° and 10 % on the bumpy
// sphere (tests/refine_test.cpp) end right 32 times (24 before the hop, 31 with hops of 29° and 57°
// only: the one left ended 83° off, out of their reach; with the 86° round also 128 of 128 more
// such starts, every method, and the 32 on the animal, the bracket and the chapter scene; those
// 32 starts on the bumpy sphere took 1.1× the time; 2026-11-29). A confirmed pose is not hopped
// from.
//
// Why the one-to-one rule of step 4 (issue 18): on the animal's two range scans (below) the source
// points beyond the overlap pair with the target's rim, crowding onto a few rim points, and drag
// the final stage along the surface: from the truth, converged, point-to-point ended 0.21° and
// 2.07 mm off, point-to-plane 0.036° and 0.08 mm. Setting aside every pair but the shortest of
// each target point (PCL's CorrespondenceRejectorOneToOne) takes them to 0.12° and 1.09 mm, and
// 0.004° and 0.02 mm. With the default termination point-to-point stops on the way, 0.53 mm off
// (2.01 before; success needs 0.72): `align3d evaluate`'s point-to-point row on the animal went
// from 4 to 33 of 100, a result of where it stops as much as of the rule.
// Pairs within half a spacing are kept whatever: without that floor, the rule moved the chapter's
// conveyor variants by up to 0.05° (two samplings of one surface pair many-to-one everywhere); with
// it, their 24 runs end where they did. A tolerance of 1.5 (a pair enters when no shorter pair of
// its target point is below 1/1.5 of its length) brought point-to-point on the animal to 0.72 mm
// only. A true mutual-neighbour test (a kd-tree of the source) cost 1.8× the final stage on 1M
// points; this one 1.05-1.25×.
//
// Why point-to-point's tangent planes (issue 18): paired sample to sample, two samplings of one
// surface meet where the pairs' offsets along the surface balance, a fraction of a spacing from
// the truth, above the noise floor (the chapter's point-to-point); on the animal, converged, 1.09
// mm off with the one-to-one rule. Paired with the foot on the partner's tangent plane (as with a
// mesh's triangles), the residual lies along the normal and the run stops where point-to-plane's
// does: from the truth, converged, the animal, the chapter, the bracket and the bumpy sphere end
// where point-to-plane does (the animal 0.004° and 0.021 mm), with its RMS; the covariance is
// point-to-plane's, calibrated as theirs are (tests/icp_methods_test.cpp). Clamping the foot to a
// disc about the sample (the surface the sample stands for) did worse at every radius tried: at 2
// s the bracket ended 0.032° off (0.030°), at s 0.043° with 1.8× the RMS, the pairs beyond the
// disc pulling along the surface as sample-to-sample pairs do. The closed-form step converges
// linearly: on the parts scene from 0.2° off (icp() with the final stage's settings), 22 and 31
// iterations at 100k and 1M points against point-to-plane's 5 and 4 (point-to-point on the
// samples: 15 and 24), 1.4× and 1.25× the time of the samples' runs. The relative RMS change
// (1e-5) then stops it short of its stationary point on large clouds: at 1M points 0.0005° and
// 0.0078 mm off where point-to-plane ends 0.0001° and 0.0006 (NEES 423 against 4.6); with
// --tolerance 1e-7 it gets there (NEES 3.1) but runs into the cap of 60 iterations; the run
// reports how far it stopped short (IcpResult::pending_sigmas, 20 standard deviations there:
// align() warns stopped_short above 2). Through this schedule, whose coarse stages start it
// close, the same scene (`align3d synth --scene parts --points 1000000`, register with
// --method point-to-point) ends 0.0001° and 0.0008 mm off, 1.0 σ short (point-to-plane 0.0001°
// and 0.0007 mm; NEES of the one run 6.6 and 7.4, with the model error: icp.hpp). Anderson
// acceleration (AA-ICP) of the closed-form step, tried with depths 2-8, cut the iterations at 1M
// to 17 with an erratic accuracy (NEES 7-72 by depth) and did nothing on the evaluation scenes:
// not kept.
//
// Why the GICP candidate (issue 18): two range scans that each see a side the other does not, of
// a curved object with thin parts (evaluation_scenes()'s animal, 61 % overlap). The unshared points
// lie 2-17 mm from the other scan's surface, within the first stage's τ = L/8 and kernel scale τ/2,
// and pull point-to-plane off even from the truth (249 mm off); GICP's coarse stages, measured,
// hold the truth (0.26 mm and 0.04° at a fixed τ of 17 mm; why it resists that pull better was not
// isolated). Point-to-plane's hops do not mend it: bench/compare_basin.py had 0-14 of
// 224 starts (0-90°, 0-20 %) right for every method before the candidate. It is a candidate, not
// the coarse cost: GICP's coarse stages lost the chapter scene from 12°, and are tried only after
// the hops (from a start where both end unconfirmed, point-to-plane's hops found the chapter's
// truth and GICP's did not). Tried on scratch builds and not kept, as the animal's 80 starts right
// (0-60°, 0-10 %) against the chapter scene's: a kernel scale capped at 2 × 1.4826 × the median
// residual, 56 against 52 of 80; rejecting pairs whose normals differ by more than 45° (30°), 63
// (70) against 76 (67), losing 10-15 of 80 on the bracket and the bumpy sphere too.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "align3d/icp/fit.hpp"
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

// When the data confirm a pose, here and in align() (align.hpp): its residuals within the final
// reach at most kConfirmedFit times those a right pose leaves (FitEvidence::ratio, icp/fit.hpp);
// and when one pose is clearly better than another: it lays kClearlyBetter more of the object (a
// share of its points) on the other cloud's surface.
inline constexpr double kConfirmedFit = 1.75;
// Above it a fit is weak (align(): the high_rms warning; a probe gives up, refine.cpp).
inline constexpr double kWeakFit = 2.0;
inline constexpr double kClearlyBetter = 0.05;

// The noise a reach is scaled by: σ₀, but not below kNoiseFloorSpacings × the point spacing
// (noise-free synthetic data have σ₀ ≈ 0 while two samplings of one surface still differ a little).
inline constexpr double kNoiseFloorSpacings = kFitFloorSpacings;
inline double noise_floor(double noise, double spacing) {
  return std::max(noise, kNoiseFloorSpacings * spacing);
}

// Basin hopping (step 3 above): hop from a pose not confirmed; hops of kHopStep, 2 and 3 kHopStep
// along the weakest direction of the system, made dimensionless as degeneracy.hpp does (a unit
// turns by 1 rad, or moves by the pairs' RMS lever arm); a start kept when clearly better. The
// third round (86°) brings back the bumpy sphere's coarse ends 80-90° off (below).
inline constexpr double kHopStep = 0.5;
inline constexpr int kHopRounds = 3;
inline constexpr int kHopChain = 3;

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
  // Basin hopping (step 3 of `auto`). align() hops with init identity or a given pose; with init
  // auto only when the global stage did not mend an unconfirmed first pose (align.hpp): hops from
  // a far-off start cost up to 3 × 4 reruns of the coarse stages (`align3d evaluate`'s default
  // rows took 1.5-2.3× the time when its first ICP hopped). Never from a global pose.
  bool hop = true;
  // GICP's coarse stages from the start, a candidate of step 3 of `auto` (tried first; kept
  // before the hops only when it is confirmed). align() leaves it out of init auto's first ICP, as
  // the hops (with it, `align3d evaluate`'s default rows took 1.4-1.5× the time in a 30-trial
  // scratch run), and tries it from a global pose.
  bool gicp_candidate = true;
  // The source's surface_noise (cloud_stats.hpp) when the caller has measured it (align() has);
  // < 0: `auto` measures it (the fit's σ_s, icp/fit.hpp).
  double source_noise = -1;
  // What the caller asks for beyond the pose: the final stage's covariance (IcpResult::covariance
  // and pending_sigmas: a pass over the pairs), with `model_error` also point-to-plane's and
  // point-to-point's model error for `auto` onto a point cloud's tangent planes (IcpResult::
  // model_error: it needs the source's normals, a third more time on two 40 000-point scans), and
  // RefineResult::fit at the answer (`auto` measures it anyway). align() asks for the covariance
  // and the fit.
  bool covariance = false;
  bool model_error = false;
  bool judge = false;
  // A probe: `auto` gives up before its stages at full resolution when the pose its coarser
  // levels reached fits weakly (icp/fit.hpp, above kWeakFit; RefineResult::finished false),
  // rather than let them slide on from a start a caller will look beyond anyway: align()'s first
  // run under init auto, which goes to the global stage next and finishes this answer only if it
  // keeps it. Clouds too small for levels are never given up on.
  bool probe = false;
  // An earlier `auto` result for the same source, target and init under these settings but for
  // hop, gicp_candidate and probe (not owned; the caller's promise): this run continues it with
  // step 3 instead of repeating steps 2 and 4 (align()'s step 3 after a first run the global stage
  // did not mend). Its stages come first in the result's.
  const struct RefineResult* resume = nullptr;
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
  double noise();                                // surface_noise(), measured once
  // The target at a coarser resolution, for the schedule's coarse stages (step 2): every 4^j-th
  // point of cloud() (j >= 1; an even thinning, the cloud being in spatial order), about
  // spacing() × 2^j apart, with their normals and a kd-tree. Built on first use.
  struct Level {
    double resolution = 0;  // spacing() × 2^j
    PointCloud cloud;
    std::unique_ptr<KdTree> tree;
  };
  const Level& level(int j);
  // Estimates every normal, the spacing, the extent, the noise and every level the schedule can use
  // (coarser than its first reach L/8 needs none) now (for a target shared by many calls).
  void estimate_all_normals();

 private:
  PointCloud cloud_;
  std::shared_ptr<const MeshIndex> surface_;
  std::unique_ptr<KdTree> tree_;
  std::unique_ptr<NormalCache> cache_;
  std::vector<std::unique_ptr<Level>> levels_;  // levels_[j - 1]: level(j), once built
  int normal_k_ = 20;
  int threads_ = 0;
  double spacing_ = -1, extent_ = -1, noise_ = -1;
};

struct StageRecord {
  std::string metric;       // to_string(IcpMethod): "point-to-plane", "gicp", ...
  double max_distance = 0;  // τ of the stage (infinity for none, per-iteration for median)
  int first_iteration = 0;  // index into the combined history of the stage's first evaluation
                            // (a stage has iterations + 1 records: its start pose, then one per
                            // update)
  int iterations = 0;
  bool hop = false;  // a coarse stage of a step-3 candidate: from a hop's start, or GICP's
  // The resolution it ran at: the nominal spacing of both clouds' level (RefineTarget::level), or
  // 0 for the clouds as given.
  double resolution = 0;
};

// Where the coarse stages (step 2) ended: the pose, σ̂ (the last stage's RMS) and that stage's
// system (zero when no stage ran); `abandoned` when a probe gave up there.
struct CoarseEnd {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  double sigma = 0;
  Matrix6d hessian = Matrix6d::Zero();
  bool abandoned = false;
};

struct RefineResult {
  IcpResult icp;                         // the final stage; T_target_source is the answer
  std::vector<IterationRecord> history;  // every iteration of every stage, in order
  std::vector<StageRecord> stages;
  int total_iterations = 0;
  double point_spacing = 0;  // the target spacing s used for `auto` (0 otherwise)
  int hops = 0;              // candidates step 3 tried (`auto` only; 0: the pose was confirmed)
  bool hopped = false;       // one of them was kept
  // Step 3's test found the answer unconfirmed (`auto` only: its fit, above kConfirmedFit, or too
  // few pairs; measured even with neither hops nor the GICP candidate, so a caller knows whether
  // step 3 would try candidates).
  bool unconfirmed = false;
  // With RefineSettings::judge, how the answer fits at the noise (icp/fit.hpp): the final stage's
  // own pairs (within its reach, one to one).
  FitEvidence fit;
  // false: a probe gave up before the stages at full resolution (RefineSettings::probe); `icp` is
  // then its pose measured within the final reach (point-to-plane, no update), `fit` its fit there.
  bool finished = true;
  CoarseEnd coarse_end;  // `auto` only (RefineSettings::resume)
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

// How `source` at pose T fits `target` at the noise (icp/fit.hpp): its point-to-plane pairs within
// `reach` (data units; infinity: all), a pair longer than half a point spacing only when it is the
// shortest of its target point, judged with σ_s = `source_noise` (data units).
FitEvidence measure_fit(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& T,
                        double reach, double source_noise, int threads = 0);

// Throws DataError("source"/"target", …) when a cloud has too few points (fewer than 6, or fewer
// than the normal neighbourhood for point-to-plane) or is degenerate (all points on one line or at
// one spot).
RefineResult refine(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& init,
                    const RefineSettings& settings = {});
RefineResult refine(const PointCloud& source, const PointCloud& target,
                    const Eigen::Isometry3d& init, const RefineSettings& settings = {});

}  // namespace align3d
