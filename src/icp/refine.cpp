#include "align3d/icp/refine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "align3d/icp/correspondences.hpp"
#include "align3d/icp/degeneracy.hpp"

namespace align3d {
namespace {

// The `auto` schedule's constants (refine.hpp explains the schedule). All distances are in units
// of L (bounding-box diagonal) or s (point spacing), so the schedule is unit-free.
constexpr double kStartFraction = 1.0 / 8.0;  // τ0 = L/8
constexpr double kShrink = 0.5;               // τ ← τ/2 per stage
constexpr double kKernelFraction = 0.5;       // Geman-McClure scale = τ/2
constexpr double kFinalSpacings = 3.0;        // final τ >= 3 s
constexpr double kFinalSigmas = 4.0;          // final τ >= 4 σ̂
// A coarse stage runs only while its τ is at least this many times the final stage's floor: one
// just above the floor (the dragon's 1.9 mm before a 1.7 mm final stage, both at full resolution)
// repeats the final stage's work at the same cost per iteration.
constexpr double kStageGap = 1.5;
// The final stage settles only where its next update is shorter than this many standard
// deviations (TerminationSettings::step_sigmas; align() warns stopped_short above 2). Without it
// the RMS criterion stopped the dragon 144° onto 168° after one iteration, 2.7 σ short.
constexpr double kFinalStepSigmas = 1.0;
constexpr int kCoarseIterations = 30;
// The final stage's reciprocity (icp.hpp): a pair longer than half a point spacing enters only when
// it is the shortest pair of its target point (refine.hpp, step 4).
constexpr double kFinalReciprocity = 1.0;
constexpr double kReciprocityFloorSpacings = 0.5;
constexpr int kMaxStages = 12;  // L/8 · 2^-12 is far below any useful spacing
// A pose's fit confirms it only over at least this share of the source's points (unconfirmed()).
constexpr double kMinFitShare = 0.01;
// Coarse-to-fine in resolution too: the coarse stages see at most this many source points (every
// m-th along the Morton curve, an even thinning), the final stage all of them.
constexpr std::size_t kCoarsePoints = 50000;
// Coarse-to-fine in resolution (issue 55): a coarse stage of reach τ runs on every 4^j-th point of
// both clouds along their Morton curves (RefineTarget::level: a spacing of about s × 2^j), the
// coarsest with s × 2^j <= τ / kLevelReach, when both keep kMinLevelPoints points; the stages near
// the final reach see every point. A query then meets a bounded number of points within its reach,
// where on the full cloud one far from the target visits every leaf within the distance to its
// nearest point.
constexpr double kLevelReach = 3.0;
constexpr std::size_t kMinLevelPoints = 1500;
constexpr double kLevelPrecision = 0.25;  // of a level's resolution (refine_schedule's probe)
// Mesh targets (noise_stages): at most this many stages set by the noise, each until τ shrinks by
// less than kNoiseShrink; τ never below kMinNoiseReach × the mesh's diagonal (noise-free data).
constexpr int kNoiseStages = 4;
constexpr double kNoiseShrink = 0.1;
constexpr double kMinNoiseReach = 1e-7;

void append(RefineResult& out, const IcpResult& r, const IcpSettings& s) {
  StageRecord stage;
  stage.metric = to_string(s.method);
  stage.max_distance = s.rejection.kind == RejectionRule::Kind::kDistance
                           ? s.rejection.distance
                           : std::numeric_limits<double>::infinity();
  stage.first_iteration = static_cast<int>(out.history.size());
  stage.iterations = r.iterations;
  out.stages.push_back(stage);
  out.history.insert(out.history.end(), r.history.begin(), r.history.end());
  out.total_iterations += r.iterations;
}

PointCloud reordered(const PointCloud& cloud, const std::vector<std::uint32_t>& order) {
  PointCloud out;
  out.positions.reserve(order.size());
  for (std::uint32_t i : order) out.positions.push_back(cloud.positions[i]);
  if (cloud.has_normals()) {
    out.normals.reserve(order.size());
    for (std::uint32_t i : order) out.normals.push_back(cloud.normals[i]);
  }
  return out;
}

// At most kCoarsePoints of `source` (with their normals), evenly along the Morton curve; empty when
// it is small enough.
PointCloud thinned(const PointCloud& source, int threads) {
  if (source.size() <= kCoarsePoints) return {};
  const std::vector<std::uint32_t> order = spatial_order(source.positions, threads);
  const std::size_t step = (source.size() + kCoarsePoints - 1) / kCoarsePoints;
  std::vector<std::uint32_t> kept;
  for (std::size_t k = 0; k < order.size(); k += step) kept.push_back(order[k]);
  return reordered(source, kept);
}

// The noise of `source` about a surface at pose T: 1.4826 × the median distance of the points
// within `reach` (the median absolute deviation's estimate of σ for Gaussian noise, which the few
// points on a dent or a bump do not move).
double robust_sigma(const PointCloud& source, const MeshIndex& surface, const Eigen::Isometry3d& T,
                    double reach, int threads) {
  std::vector<SurfacePoint> closest;
  surface.closest_points(source.positions, T, reach, threads, closest);
  std::vector<double> d;
  d.reserve(closest.size());
  for (const SurfacePoint& c : closest)
    if (c.found()) d.push_back(std::sqrt(c.sq_distance));
  if (d.empty()) return 0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return 1.4826 * d[d.size() / 2];
}

// A mesh's surface is exact, so once the schedule has settled at the sample's spacing the noise
// alone sets the reach: stages at τ = kFinalSigmas·σ_MAD (robust_sigma), re-measured after each,
// until τ stops shrinking by more than a tenth (at most kNoiseStages). A local defect (a dent, a
// bump) farther than that from the CAD surface is then left out instead of pulling the pose; the
// spacing floor would keep a 0.4 mm bump in reach on a part sampled every 0.17 mm. Returns the
// final stage's τ; T is updated.
template <class Run>
double noise_stages(const PointCloud& source, const MeshIndex& surface, double tau,
                    IcpSettings stage, Eigen::Isometry3d& T, Run&& run) {
  const double floor = kMinNoiseReach * surface.diagonal();
  for (int k = 0; k < kNoiseStages; ++k) {
    const double next =
        std::max(floor, kFinalSigmas * robust_sigma(source, surface, T, tau, stage.threads));
    if (next > (1 - kNoiseShrink) * tau) break;
    tau = next;
    stage.rejection = RejectionRule::max_distance(tau);
    stage.kernel_scale = kKernelFraction * tau;
    const IcpResult r = run(source, T, stage);
    if (r.stop_reason == StopReason::kTooFewCorrespondences) break;
    T = r.T_target_source;
  }
  return tau;
}

}  // namespace

RefineTarget::RefineTarget(const PointCloud& target, const NormalSettings& normals, int threads)
    : normal_k_(normals.k), threads_(threads) {
  check_registrable(target, "target");
  cloud_ = reordered(target, spatial_order(target.positions, threads));
  tree_ = std::make_unique<KdTree>(cloud_.positions, threads);
  if (!cloud_.has_normals()) {
    NormalSettings ns = normals;
    ns.threads = threads;
    cache_ = std::make_unique<NormalCache>(cloud_, *tree_, ns);
  }
}

PointCloud mesh_target_sample(const MeshIndex& surface) {
  const double diagonal = surface.diagonal();
  const double cell = diagonal / kMeshSampleDivisions;
  const double wanted = surface_area(surface.mesh()) / (cell * cell);
  const auto count = static_cast<std::size_t>(std::clamp(
      wanted, static_cast<double>(kMinMeshSamples), static_cast<double>(kMaxMeshSamples)));
  return sample_surface(surface.mesh(), count, kMeshSampleSeed);
}

RefineTarget::RefineTarget(std::shared_ptr<const MeshIndex> surface, int threads)
    : surface_(std::move(surface)), threads_(threads) {
  const PointCloud sample = mesh_target_sample(*surface_);
  cloud_ = reordered(sample, spatial_order(sample.positions, threads));
  tree_ = std::make_unique<KdTree>(cloud_.positions, threads);
}

RefineTarget::~RefineTarget() = default;

const std::vector<Eigen::Vector3d>& RefineTarget::normals(
    const std::vector<std::uint32_t>& indices) {
  if (!cache_) return cloud_.normals;
  cache_->require(indices);
  return cache_->normals();
}

namespace {

// The level of a stage of reach `tau` over a target of spacing s (kLevelReach): j >= 1, or 0 for
// the clouds as given.
int level_for(double tau, double spacing) {
  if (!(spacing > 0) || !(tau > 0)) return 0;
  return std::max(0, static_cast<int>(std::floor(std::log2(tau / (kLevelReach * spacing)))));
}

// The indices 0, stride, 2 stride, ... below n.
std::vector<std::uint32_t> every(std::size_t n, std::size_t stride) {
  std::vector<std::uint32_t> kept;
  for (std::size_t k = 0; k < n; k += stride) kept.push_back(static_cast<std::uint32_t>(k));
  return kept;
}

}  // namespace

const RefineTarget::Level& RefineTarget::level(int j) {
  if (j < 1) throw std::invalid_argument("RefineTarget::level: j must be at least 1");
  if (levels_.size() < static_cast<std::size_t>(j)) levels_.resize(static_cast<std::size_t>(j));
  std::unique_ptr<Level>& slot = levels_[static_cast<std::size_t>(j - 1)];
  if (!slot) {
    auto l = std::make_unique<Level>();
    l->resolution = std::ldexp(spacing(), j);
    // cloud_ is in spatial order: every 4^j-th point is an even thinning, with the normals the
    // stages near the final reach use too.
    const std::vector<std::uint32_t> kept = every(cloud_.size(), std::size_t{1} << (2 * j));
    normals(kept);
    l->cloud = reordered(cloud_, kept);
    if (cache_)
      for (std::uint32_t i : kept) l->cloud.normals.push_back(cache_->normals()[i]);
    l->tree = std::make_unique<KdTree>(l->cloud.positions, threads_);
    slot = std::move(l);
  }
  return *slot;
}

void RefineTarget::estimate_all_normals() {
  if (cache_) {
    std::vector<std::uint32_t> all(cloud_.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint32_t>(i);
    cache_->require(all);
  }
  spacing();
  extent();
  noise();
  for (int j = 1; j <= level_for(kStartFraction * extent(), spacing()); ++j) level(j);
}

double RefineTarget::extent() {
  if (extent_ < 0) extent_ = robust_extent(cloud_, threads_);
  return extent_;
}

double RefineTarget::noise() {
  if (noise_ < 0) noise_ = surface_noise(cloud_, *tree_, 20, 2000, threads_);
  return noise_;
}

double RefineTarget::spacing() {
  if (spacing_ < 0) spacing_ = point_spacing(cloud_, *tree_, 2000, threads_);
  return spacing_;
}

FitEvidence measure_fit(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& T,
                        double reach, double source_noise, int threads) {
  const double spacing = target.spacing();
  const double noise = std::hypot(source_noise, target.noise());
  Correspondences c;
  const PointCloud& cloud = target.cloud();
  if (const MeshIndex* surface = target.surface()) {
    find_surface_correspondences(source.positions, *surface, T, reach, threads, c);
    return judge_fit(normal_residuals(source.positions, T, c, reach, cloud, {}, threads), noise,
                     spacing);
  }
  find_correspondences(source.positions, cloud, target.tree(), T, reach, threads, c);
  set_aside_crowded(cloud.size(), reach, kFinalReciprocity, kReciprocityFloorSpacings * spacing,
                    threads, c);
  std::vector<std::uint32_t> partners;
  for (std::size_t i = 0; i < source.size(); ++i)
    if (is_kept(c, i, reach) && !c.aside[i])
      partners.push_back(static_cast<std::uint32_t>(c.target[i]));
  return judge_fit(
      normal_residuals(source.positions, T, c, reach, cloud, target.normals(partners), threads),
      noise, spacing);
}

namespace {

// Step 2 from `init`: point-to-plane at τ = L/8, halved per stage while τ > kStageGap × `floor`;
// before each stage, and after the last, `abandon(T, τ)` may end them (CoarseEnd::abandoned; τ =
// `floor` after the last).
template <class Run, class Abandon>
CoarseEnd coarse_stages(const PointCloud& source, const Eigen::Isometry3d& init, double diagonal,
                        double floor, IcpSettings coarse, Run&& run, Abandon&& abandon) {
  CoarseEnd end;
  end.T = init;
  double tau = kStartFraction * diagonal;
  for (int stage = 0; stage < kMaxStages && tau > kStageGap * floor; ++stage, tau *= kShrink) {
    if (abandon(end.T, tau)) {
      end.abandoned = true;
      return end;
    }
    coarse.rejection = RejectionRule::max_distance(tau);
    coarse.kernel_scale = kKernelFraction * tau;
    const IcpResult r = run(source, end.T, coarse);
    if (r.stop_reason == StopReason::kTooFewCorrespondences) break;
    end.T = r.T_target_source;
    end.sigma = r.rms;  // the plane distance's RMS: the noise along the normal once settled
    end.hessian = r.hessian;
  }
  end.abandoned = abandon(end.T, floor);
  return end;
}

// Whether a fit at the noise (icp/fit.hpp) leaves a pose of a source of `points` unconfirmed: too
// few pairs within the reach, fewer than min_pairs or than kMinFitShare of the points (the stages
// broke off far from the object, or laid a sliver of it on the surface and the rest off), whatever
// the fit of those few, or a ratio above kConfirmedFit. The share: the animal's wrong poses from
// 30° (Refine.TwoRangeScansOfTheAnimalFromThirtyDegrees) fitted 11-51 of 14,612 points at ratios
// 0.9-1.6 after the final stage; a right pose there pairs thousands.
bool unconfirmed(const FitEvidence& f, std::size_t points) {
  return f.pairs < min_pairs(IcpMethod::kPointToPlane) ||
         static_cast<double>(f.pairs) < kMinFitShare * static_cast<double>(points) ||
         f.ratio > kConfirmedFit;
}

// Step 3 of refine.hpp, basin hopping from the coarse stages' `end`, whose answer was not
// confirmed: candidates are tried, each the coarse stages (`coarse(start, method)`) from a start,
// and one that lays clearly more source points within max(3 s, 4 σ₀) of the target is kept: GICP's
// from `init` (settings.gicp_candidate), which ends step 3 if kept and confirmed at its coarse end
// (`judge(T, reach_of(T))`); else, while the pose kept is unconfirmed there, hops from `end` along
// the weakest direction of its system with the cost that reached it (settings.hop; at most
// kHopChain times), then GICP's candidate again on the same test, and hops from it if it is kept.
// The candidates' stages are recorded with StageRecord::hop.
template <class Coarse, class Measure, class Judge, class ReachOf>
CoarseEnd hop_basins(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& init,
                     const CoarseEnd& end, double source_noise, const RefineSettings& settings,
                     RefineResult& out, Coarse&& coarse, Measure&& measure, Judge&& judge,
                     ReachOf&& reach_of) {
  bool doubt = true;
  const Eigen::Vector3d centre = measure(end.T, reach_of(end)).centre;  // of the systems (icp.hpp)
  // Candidates are compared by the source points they lay within a reach of the data's noise
  // (not reach_of(end), which grows with the RMS of the pose the coarse stages reached: where those
  // broke off far from the object it let almost every point count for any candidate).
  const double spacing = target.spacing();
  const double overlap_reach =
      std::max(kFinalSpacings * spacing,
               kFinalSigmas * noise_floor(std::hypot(source_noise, target.noise()), spacing));
  auto overlap = [&](const Eigen::Isometry3d& T) {
    return static_cast<double>(measure(T, overlap_reach).correspondences);
  };
  const double margin = kClearlyBetter * static_cast<double>(source.size());
  const double start_overlap = overlap(end.T);
  CoarseEnd best = end;
  double best_overlap = start_overlap;
  IcpMethod method = IcpMethod::kPointToPlane;  // the cost that reached `best`
  struct Tried {
    CoarseEnd end;
    double overlap;
    IcpMethod cost;
  };
  auto run_candidate = [&](const Eigen::Isometry3d& start, IcpMethod cost) {
    const std::size_t first = out.stages.size();
    const CoarseEnd candidate = coarse(start, cost);
    ++out.hops;
    for (std::size_t k = first; k < out.stages.size(); ++k) out.stages[k].hop = true;
    return Tried{candidate, overlap(candidate.T), cost};
  };
  auto keep_if_better = [&](const Tried& t) {
    if (t.overlap <= best_overlap + margin) return false;
    best = t.end;
    best_overlap = t.overlap;
    // At its coarse end and its own reach: the reach of `end` grows with that pose's RMS, and a
    // right candidate judged there counts the pairs of a wrong pose's overlap (on the dragon's
    // 72° pairs, the GICP candidate: ratio 3.0 at end's reach, 1.6 at its own, and six hops more).
    doubt = unconfirmed(judge(t.end.T, reach_of(t.end)), source.size());
    method = t.cost;
    out.hopped = true;
    return true;
  };
  auto try_candidate = [&](const Eigen::Isometry3d& start, IcpMethod cost) {
    return keep_if_better(run_candidate(start, cost));
  };
  // From a kept pose still unconfirmed, hops along the weakest direction of its system, with the
  // cost that reached it.
  auto hops = [&] {
    for (int chain = 0; chain < kHopChain && doubt; ++chain) {
      const SystemAnalysis system = analyse_system(best.hessian);
      if (!system.usable) return;
      // The weakest eigenvector y of the dimensionless system (a unit of it turns by 1 rad or
      // moves by the lever arm ℓ = 1 / scale(0), analyse_system) as the update
      // (ω, v) = ℓ · scale ⊙ y about the system's centre, times the hop's size.
      const Vector6d unit = system.scale.cwiseProduct(system.vectors.col(0)) / system.scale(0);
      const Eigen::Translation3d to_world(centre);
      const CoarseEnd from = best;
      const IcpMethod cost = method;
      bool kept = false;
      for (int round = 1; round <= kHopRounds && !kept; ++round)
        for (const double sign : {1.0, -1.0}) {
          const Eigen::Isometry3d start =
              to_world * se3_exp(sign * round * kHopStep * unit) * to_world.inverse() * from.T;
          kept = try_candidate(start, cost) || kept;
        }
      if (!kept) return;
    }
  };
  // GICP's candidate first: kept and confirmed, it ends step 3 (on the dragon's far pairs it is
  // the candidate kept, after twelve point-to-plane hops that were not: 0.64-0.74 s a pair, 0.36 s
  // with GICP first). Else the hops run from `end` as if it had not been tried, and it is tried
  // after them (from GICP's pose, its own hops lost the 72° → 24° pair the others find).
  std::optional<Tried> gicp;
  if (settings.gicp_candidate) {
    gicp = run_candidate(init, IcpMethod::kGicp);
    if (keep_if_better(*gicp) && !doubt) return best;
    best = end;
    best_overlap = start_overlap;
    method = IcpMethod::kPointToPlane;
    doubt = true;
    out.hopped = false;
  }
  if (settings.hop) hops();
  if (gicp && doubt && keep_if_better(*gicp) && settings.hop) hops();
  return best;
}

// `source`, or a copy with normals when `method` needs them and it has none (settings.normals).
const PointCloud& with_normals(const PointCloud& source, IcpMethod method,
                               const RefineSettings& settings, PointCloud& copy) {
  if (!needs_source_normals(method) || source.has_normals()) return source;
  if (source.size() < static_cast<std::size_t>(settings.normals.k))
    throw DataError("source", std::to_string(source.size()) + " points; " + to_string(method) +
                                  " needs at least the normal neighbourhood k = " +
                                  std::to_string(settings.normals.k));
  copy = source;
  NormalSettings ns = settings.normals;
  ns.threads = settings.threads;
  estimate_normals(copy, ns);
  return copy;
}

// The source's noise σ_s (icp/fit.hpp): the caller's measure, or surface_noise of `source`.
double noise_of(const PointCloud& source, const RefineSettings& settings) {
  if (settings.source_noise >= 0) return settings.source_noise;
  const KdTree tree(source.positions, settings.threads);
  return surface_noise(source, tree, 20, 2000, settings.threads);
}

// The source's side of the schedule's pyramid (refine.hpp): every 4^j-th point of the coarse source
// along its Morton curve, as the target's levels (RefineTarget::level); built on first use, with
// normals (of `from`'s points) for the costs that read them (GICP).
class Pyramid {
 public:
  Pyramid(const PointCloud& coarse, RefineTarget& target, int threads)
      : coarse_(coarse), target_(target), curve_(spatial_order(coarse.positions, threads)) {}

  const PointCloud& source(int j, const PointCloud& from) {
    std::vector<PointCloud>& built = built_[from.has_normals()];
    if (built.size() < static_cast<std::size_t>(j)) built.resize(static_cast<std::size_t>(j));
    PointCloud& l = built[static_cast<std::size_t>(j - 1)];
    if (l.empty()) {
      std::vector<std::uint32_t> kept;
      for (std::uint32_t k : every(curve_.size(), std::size_t{1} << (2 * j)))
        kept.push_back(curve_[k]);
      l = reordered(from, kept);
    }
    return l;
  }

  // The level a stage of reach τ runs at, 0 for the clouds as given: the coarsest whose reach
  // spans kLevelReach resolutions with kMinLevelPoints points on both sides.
  int level_of(double tau) {
    for (int j = level_for(tau, target_.spacing()); j >= 1; --j)
      if (target_.level(j).cloud.size() >= kMinLevelPoints &&
          source(j, coarse_).size() >= kMinLevelPoints)
        return j;
    return 0;
  }

 private:
  const PointCloud& coarse_;
  RefineTarget& target_;
  std::vector<std::uint32_t> curve_;
  std::vector<PointCloud> built_[2];  // without and with normals
};

// Step 4's settings (refine.hpp): `last` at reach τ; onto a point cloud (`cloud`, point spacing s)
// one to one beyond half a spacing and point-to-point onto tangent planes; weighted by
// Geman-McClure at τ/2 unless the caller chose a kernel (its scale, or tuned to σ̂ = `sigma`).
IcpSettings final_settings(const IcpSettings& last, const RefineSettings& settings, double tau,
                           double sigma, bool cloud, double spacing) {
  IcpSettings s = last;
  s.rejection = RejectionRule::max_distance(tau);
  s.termination.step_sigmas = kFinalStepSigmas;
  if (cloud) {
    s.reciprocity = kFinalReciprocity;
    s.reciprocity_floor = kReciprocityFloorSpacings * spacing;
    s.tangent_planes = true;
  }
  if (!settings.kernel) {
    s.kernel = RobustKernel::kGemanMcClure;
    s.kernel_scale = kKernelFraction * tau;
  } else {
    s.kernel_scale = kernel_scale_or_tuned(last.kernel, settings.kernel_scale, sigma);
  }
  return s;
}

// The `auto` schedule (refine.hpp): coarse stages at a shrinking τ, the final stage with `last`
// (method, termination, threads, covariance, and the kernel when one was asked for), basin hopping
// when its answer is not confirmed, and the final stage again from a candidate kept. `measure`
// evaluates a pose without moving it (an ICP run of no update).
template <class Run, class RunLevel, class Measure>
void refine_schedule(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& init,
                     const RefineSettings& settings, IcpSettings last, RefineResult& out, Run&& run,
                     RunLevel&& run_level, Measure&& measure) {
  // L: the extent of the object, the smaller of the two clouds (cloud_stats.hpp), so that a part
  // registered into a wide scene is not pulled by clutter within an eighth of the scene's size. A
  // cloud of duplicated points has no measurable spacing; fall back to a fine fraction of L.
  const double diagonal = std::min(target.extent(), robust_extent(source, settings.threads));
  double spacing = target.spacing();
  if (!(spacing > 0)) spacing = 1e-4 * diagonal;
  out.point_spacing = spacing;
  const double floor = kFinalSpacings * spacing;
  const PointCloud thin = thinned(source, settings.threads);
  const PointCloud& coarse_source = thin.empty() ? source : thin;
  const double source_noise = noise_of(coarse_source, settings);
  auto judge = [&](const Eigen::Isometry3d& T, double reach) {
    return measure_fit(coarse_source, target, T, reach, source_noise, settings.threads);
  };

  IcpSettings coarse = last;
  coarse.covariance = false;
  coarse.method = IcpMethod::kPointToPlane;
  coarse.termination = {kCoarseIterations, 1e-4, true, 1e-5, 1e-6};
  coarse.kernel = RobustKernel::kGemanMcClure;
  Pyramid pyramid(coarse_source, target, settings.threads);
  // A coarse stage: at its level, else on `from`.
  double resolution = 0;  // of the last stage run at a level
  auto stage = [&](const PointCloud& from, const Eigen::Isometry3d& T, const IcpSettings& s) {
    const int j = pyramid.level_of(s.rejection.distance);
    if (j == 0) return run(from, T, s);
    resolution = target.level(j).resolution;
    return run_level(pyramid.source(j, from), target.level(j), T, s);
  };
  // A probe (RefineSettings::probe) gives up before the stages at full resolution when the
  // levels' pose fits weakly at the final reach: its residuals' RMS above kWeakFit times what a
  // right pose leaves (icp/fit.hpp), or a quarter of the last level's resolution, the precision
  // the levels can give where the noise is finer. Measured on the dragon's neighbours: right
  // starts there at RMS 0.4-0.8 of that, wrong ones at 2.7-3.1 with a tenth of the pairs, whose
  // stages at full resolution would slide on to their iteration caps. A run that may hop (step 3)
  // makes the same test and hops at once from a pose that fails it: the stages at full resolution
  // and the final stage would only confirm that it is unconfirmed (on the dragon's 72° pairs, a
  // final stage of 38 iterations, a quarter of the pair's time).
  const bool may_hop = settings.hop || settings.gicp_candidate;
  bool tested = !(settings.probe || may_hop) || pyramid.level_of(kStartFraction * diagonal) == 0;
  auto abandon = [&](const Eigen::Isometry3d& T, double tau) {
    if (tested || pyramid.level_of(tau) > 0) return false;
    tested = true;
    const FitEvidence f = judge(T, floor);
    return f.pairs < min_pairs(IcpMethod::kPointToPlane) ||
           f.rms > kWeakFit * std::max(f.expected, kLevelPrecision * resolution);
  };
  auto never = [](const Eigen::Isometry3d&, double) { return false; };
  // Resumed (RefineSettings::resume), `out` holds the earlier run's steps 2 and 4.
  const CoarseEnd end =
      settings.resume ? out.coarse_end
                      : coarse_stages(coarse_source, init, diagonal, floor, coarse, stage, abandon);
  out.coarse_end = end;
  auto reach_of = [&](const CoarseEnd& e) { return std::max(floor, kFinalSigmas * e.sigma); };
  if (end.abandoned && !may_hop) {
    out.icp = measure(coarse_source, end.T, reach_of(end));
    out.fit = judge(end.T, reach_of(end));
    out.unconfirmed = true;
    out.finished = false;
    return;
  }
  // Step 4 from the end of the coarse stages `e`: onto a mesh, the stages set by its noise first.
  auto finish = [&](const CoarseEnd& e) {
    Eigen::Isometry3d T = e.T;
    double tau = reach_of(e);
    if (target.surface()) tau = noise_stages(coarse_source, *target.surface(), tau, coarse, T, run);
    IcpSettings final_stage =
        final_settings(last, settings, tau, e.sigma, !target.surface(), spacing);
    final_stage.judge = {std::hypot(source_noise, target.noise()), target.spacing()};
    out.icp = run(source, T, final_stage);
    out.fit = out.icp.fit;
  };
  if (!end.abandoned && !settings.resume) finish(end);
  // Step 3 when the answer is not confirmed, from the coarse stages' end; the final stage again
  // from a candidate it keeps (from that end when it was abandoned and none is).
  out.unconfirmed = end.abandoned || out.icp.stop_reason == StopReason::kTooFewCorrespondences ||
                    unconfirmed(out.fit, source.size());
  if (!out.unconfirmed || !may_hop) return;
  PointCloud copy;
  const PointCloud* oriented = nullptr;  // the coarse source with normals, for GICP's candidates
  auto candidate = [&](const Eigen::Isometry3d& start, IcpMethod method) {
    IcpSettings stages = coarse;
    stages.method = method;
    if (!needs_source_normals(method))
      return coarse_stages(coarse_source, start, diagonal, floor, stages, stage, never);
    if (coarse_source.size() < static_cast<std::size_t>(settings.normals.k)) return end;
    if (!oriented) oriented = &with_normals(coarse_source, method, settings, copy);
    return coarse_stages(*oriented, start, diagonal, floor, stages, stage, never);
  };
  const CoarseEnd best = hop_basins(
      coarse_source, target, init, end, source_noise, settings, out, candidate,
      [&](const Eigen::Isometry3d& T, double reach) { return measure(coarse_source, T, reach); },
      judge, reach_of);
  if (out.hopped || end.abandoned) finish(best);
  out.finished = true;
}

}  // namespace

RefineResult refine(const PointCloud& given_source, RefineTarget& target,
                    const Eigen::Isometry3d& init, const RefineSettings& settings) {
  check_registrable(given_source, "source");
  const bool automatic = settings.rejection.kind == RejectionRule::Kind::kAuto;
  if (settings.resume && !automatic)
    throw std::invalid_argument("RefineSettings: resume needs the auto rejection rule");
  RefineResult out = settings.resume ? *settings.resume : RefineResult{};
  NormalCache* normals = target.cache();
  if ((settings.method != IcpMethod::kPointToPoint || automatic) && normals &&
      target.cloud().size() < static_cast<std::size_t>(target.normal_k()))
    throw DataError(
        "target",
        std::to_string(target.cloud().size()) + " points; " +
            (automatic ? std::string("refinement") : std::string(to_string(settings.method))) +
            " needs at least the normal neighbourhood k = " + std::to_string(target.normal_k()));
  // Asked for (RefineSettings::model_error), the schedule's final stage onto a point cloud's
  // tangent planes (point-to-plane, point-to-point: the methods that do not read the source's
  // normals themselves) measures their model error with the symmetric step
  // (IcpResult::model_error), which reads them (where the source has a neighbourhood's worth of
  // points).
  const bool measured_planes = automatic && settings.covariance && settings.model_error &&
                               !needs_source_normals(settings.method) && !target.surface() &&
                               given_source.size() >= static_cast<std::size_t>(settings.normals.k);
  const IcpMethod normals_for = measured_planes ? IcpMethod::kSymmetric : settings.method;
  PointCloud copy;
  const PointCloud& source = with_normals(given_source, normals_for, settings, copy);
  auto unrecorded = [&](const PointCloud& from, const Eigen::Isometry3d& T, const IcpSettings& s) {
    IcpResult r = target.surface() ? icp(from, *target.surface(), T, s)
                  : normals        ? icp(from, *normals, T, s)
                                   : icp(from, target.cloud(), target.tree(), T, s);
    if (normals) {
      out.estimated_normals = normals->estimated();
      out.undefined_normals = normals->undefined();
    }
    return r;
  };
  auto run = [&](const PointCloud& from, const Eigen::Isometry3d& T, const IcpSettings& s) {
    IcpResult r = unrecorded(from, T, s);
    append(out, r, s);
    return r;
  };
  auto run_level = [&](const PointCloud& from, const RefineTarget::Level& level,
                       const Eigen::Isometry3d& T, const IcpSettings& s) {
    IcpResult r = icp(from, level.cloud, *level.tree, T, s);
    append(out, r, s);
    out.stages.back().resolution = level.resolution;
    return r;
  };

  IcpSettings last;
  last.method = settings.method;
  last.threads = settings.threads;
  last.termination = settings.termination;
  last.covariance = settings.covariance;
  if (settings.kernel) {
    last.kernel = *settings.kernel;
    last.kernel_scale = settings.kernel_scale;
  }
  if (!automatic) {
    last.rejection = settings.rejection;
    out.icp = run(source, init, last);
    if (settings.judge && !out.icp.history.empty())
      out.fit =
          measure_fit(source, target, out.icp.T_target_source, out.icp.history.back().threshold,
                      noise_of(source, settings), settings.threads);
    return out;
  }
  // A pose as the schedule judges it (refine.hpp, step 3): the point-to-plane pairs within
  // `reach`, unweighted, and their RMS; no update.
  IcpSettings measured;
  measured.method = IcpMethod::kPointToPlane;
  measured.termination.max_iterations = 0;
  measured.threads = settings.threads;
  auto measure = [&](const PointCloud& from, const Eigen::Isometry3d& T, double reach) {
    measured.rejection = RejectionRule::max_distance(reach);
    return unrecorded(from, T, measured);
  };
  refine_schedule(source, target, init, settings, last, out, run, run_level, measure);
  return out;
}

void set_kernel(CostSettings& settings, std::string_view name, double scale) {
  if (!std::isfinite(scale) || scale < 0)
    throw std::invalid_argument("kernel scale: expected a finite number >= 0");
  if (name == "auto") {
    if (scale > 0)
      throw std::invalid_argument(
          "kernel scale: needs a kernel (the auto schedule sets its own scale)");
    settings.kernel.reset();
    settings.kernel_scale = 0;
    return;
  }
  const std::optional<RobustKernel> k = kernel_from_string(name);
  if (!k) {
    std::string names = "'auto'";
    for (RobustKernel each : kAllKernels) names += std::string(", '") + to_string(each) + "'";
    throw std::invalid_argument("kernel: expected one of " + names + ", got '" + std::string(name) +
                                "'");
  }
  settings.kernel = k;
  settings.kernel_scale = scale;
}

RefineResult refine(const PointCloud& source, const PointCloud& target,
                    const Eigen::Isometry3d& init, const RefineSettings& settings) {
  check_registrable(source, "source");
  RefineTarget prepared(target, settings.normals, settings.threads);
  return refine(source, prepared, init, settings);
}

}  // namespace align3d
