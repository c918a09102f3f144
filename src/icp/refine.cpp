#include "align3d/icp/refine.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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
constexpr int kCoarseIterations = 30;
// The final stage's reciprocity (icp.hpp): a pair longer than half a point spacing enters only when
// it is the shortest pair of its target point (refine.hpp, step 4).
constexpr double kFinalReciprocity = 1.0;
constexpr double kReciprocityFloorSpacings = 0.5;
constexpr int kMaxStages = 12;  // L/8 · 2^-12 is far below any useful spacing
// Coarse-to-fine in resolution too: the coarse stages see at most this many source points (every
// m-th along the Morton curve, an even thinning), the final stage all of them.
constexpr std::size_t kCoarsePoints = 50000;
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
PointCloud thinned(const PointCloud& source) {
  if (source.size() <= kCoarsePoints) return {};
  const std::vector<std::uint32_t> order = spatial_order(source.positions);
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
    : normal_k_(normals.k) {
  check_registrable(target, "target");
  cloud_ = reordered(target, spatial_order(target.positions));
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
    : surface_(std::move(surface)) {
  const PointCloud sample = mesh_target_sample(*surface_);
  cloud_ = reordered(sample, spatial_order(sample.positions));
  tree_ = std::make_unique<KdTree>(cloud_.positions, threads);
}

RefineTarget::~RefineTarget() = default;

const std::vector<Eigen::Vector3d>& RefineTarget::normals(
    const std::vector<std::uint32_t>& indices) {
  if (!cache_) return cloud_.normals;
  cache_->require(indices);
  return cache_->normals();
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
}

double RefineTarget::extent() {
  if (extent_ < 0) extent_ = robust_extent(cloud_);
  return extent_;
}

double RefineTarget::noise() {
  if (noise_ < 0) noise_ = surface_noise(cloud_, *tree_);
  return noise_;
}

double RefineTarget::spacing() {
  if (spacing_ < 0) spacing_ = point_spacing(cloud_, *tree_);
  return spacing_;
}

FitEvidence measure_fit(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& T,
                        double reach, double source_noise, int threads) {
  const double spacing = target.spacing();
  const double noise = std::hypot(source_noise, target.noise());
  Correspondences c;
  std::vector<double> residuals;
  if (const MeshIndex* surface = target.surface()) {
    find_surface_correspondences(source.positions, *surface, T, reach, threads, c);
    for (std::size_t i = 0; i < source.size(); ++i)
      if (is_kept(c, i, reach))
        residuals.push_back(c.normal[i].dot(T * source.positions[i] - c.point[i]));
    return judge_fit(residuals, noise, spacing);
  }
  const PointCloud& cloud = target.cloud();
  find_correspondences(source.positions, cloud, target.tree(), T, reach, threads, c);
  set_aside_crowded(cloud.size(), reach, kFinalReciprocity, kReciprocityFloorSpacings * spacing,
                    threads, c);
  auto judged = [&](std::size_t i) { return is_kept(c, i, reach) && !c.aside[i]; };
  std::vector<std::uint32_t> partners;
  for (std::size_t i = 0; i < source.size(); ++i)
    if (judged(i)) partners.push_back(static_cast<std::uint32_t>(c.target[i]));
  const std::vector<Eigen::Vector3d>& normals = target.normals(partners);
  for (std::size_t i = 0; i < source.size(); ++i)
    if (judged(i))
      residuals.push_back(
          normals[c.target[i]].dot(T * source.positions[i] - cloud.positions[c.target[i]]));
  return judge_fit(residuals, noise, spacing);
}

namespace {

// Where the coarse stages (step 2 of refine.hpp) end: the pose, σ̂ (the last stage's RMS) and that
// stage's system (zero when no stage ran).
struct CoarseEnd {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  double sigma = 0;
  Matrix6d hessian = Matrix6d::Zero();
};

// Step 2 from `init`: point-to-plane at τ = L/8, halved per stage down to `floor`.
template <class Run>
CoarseEnd coarse_stages(const PointCloud& source, const Eigen::Isometry3d& init, double diagonal,
                        double floor, IcpSettings coarse, Run&& run) {
  CoarseEnd end;
  end.T = init;
  double tau = kStartFraction * diagonal;
  for (int stage = 0; stage < kMaxStages && tau > floor; ++stage, tau *= kShrink) {
    coarse.rejection = RejectionRule::max_distance(tau);
    coarse.kernel_scale = kKernelFraction * tau;
    const IcpResult r = run(source, end.T, coarse);
    if (r.stop_reason == StopReason::kTooFewCorrespondences) break;
    end.T = r.T_target_source;
    end.sigma = r.rms;  // the plane distance's RMS: the noise along the normal once settled
    end.hessian = r.hessian;
  }
  return end;
}

// Step 3 of refine.hpp, basin hopping: `end` when its pose is confirmed (its fit within `reach`,
// icp/fit.hpp, at most kConfirmedFit; `judge(T, reach)`); else candidates are tried, each the
// coarse stages (`coarse(start, method)`) from a start, and one that lays clearly more source
// points within max(3 s, 4 σ₀) of the target is kept: hops along the weakest direction of the kept
// pose's system (settings.hop; again from a kept pose still unconfirmed, at most kHopChain times),
// then, if still unconfirmed, GICP's from `init` (settings.gicp_candidate), and if it is kept, hops
// from it with GICP's stages. The candidates' stages are recorded with StageRecord::hop.
template <class Coarse, class Measure, class Judge>
CoarseEnd hop_basins(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& init,
                     const CoarseEnd& end, double reach, double source_noise,
                     const RefineSettings& settings, RefineResult& out, Coarse&& coarse,
                     Measure&& measure, Judge&& judge) {
  IcpResult here = measure(end.T, reach);
  double ratio = judge(end.T, reach).ratio;
  // Too few pairs within the reach (the coarse stages broke off far from the object) is no
  // confirmation, whatever the fit of those few.
  auto unconfirmed = [&] {
    return here.stop_reason == StopReason::kTooFewCorrespondences || ratio > kConfirmedFit;
  };
  out.unconfirmed = unconfirmed();
  if (!out.unconfirmed || !(settings.hop || settings.gicp_candidate)) return end;
  // Candidates are compared by the source points they lay within a reach of the data's noise
  // (not `reach`, which grows with the RMS of the pose the coarse stages reached: where those
  // broke off far from the object it let almost every point count for any candidate).
  const double spacing = target.spacing();
  const double overlap_reach =
      std::max(kFinalSpacings * spacing,
               kFinalSigmas * noise_floor(std::hypot(source_noise, target.noise()), spacing));
  auto overlap = [&](const Eigen::Isometry3d& T) {
    return static_cast<double>(measure(T, overlap_reach).correspondences);
  };
  const double margin = kClearlyBetter * static_cast<double>(source.size());
  CoarseEnd best = end;
  double best_overlap = overlap(end.T);
  IcpMethod method = IcpMethod::kPointToPlane;  // the cost that reached `best`
  auto try_candidate = [&](const Eigen::Isometry3d& start, IcpMethod cost) {
    const std::size_t first = out.stages.size();
    const CoarseEnd candidate = coarse(start, cost);
    ++out.hops;
    for (std::size_t k = first; k < out.stages.size(); ++k) out.stages[k].hop = true;
    const double there = overlap(candidate.T);
    if (there <= best_overlap + margin) return false;
    best = candidate;
    best_overlap = there;
    here = measure(candidate.T, reach);
    ratio = judge(candidate.T, reach).ratio;
    method = cost;
    out.hopped = true;
    return true;
  };
  // From a kept pose still unconfirmed, hops along the weakest direction of its system, with the
  // cost that reached it.
  auto hops = [&] {
    for (int chain = 0; chain < kHopChain && unconfirmed(); ++chain) {
      const SystemAnalysis system = analyse_system(best.hessian);
      if (!system.usable) return;
      // The weakest eigenvector y of the dimensionless system (a unit of it turns by 1 rad or
      // moves by the lever arm ℓ = 1 / scale(0), analyse_system) as the update
      // (ω, v) = ℓ · scale ⊙ y about the system's centre, times the hop's size.
      const Vector6d unit = system.scale.cwiseProduct(system.vectors.col(0)) / system.scale(0);
      const Eigen::Translation3d to_world(here.centre);
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
  if (settings.hop) hops();
  if (settings.gicp_candidate && unconfirmed() && try_candidate(init, IcpMethod::kGicp) &&
      settings.hop)
    hops();
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
  return surface_noise(source, tree);
}

// The `auto` schedule (refine.hpp): coarse stages at a shrinking τ, basin hopping when their pose
// is not confirmed, then the final stage with `last` (method, termination, threads, covariance, and
// the kernel when one was asked for). `measure` evaluates a pose without moving it (an ICP run of
// no update).
template <class Run, class Measure>
void refine_schedule(const PointCloud& source, RefineTarget& target, const Eigen::Isometry3d& init,
                     const RefineSettings& settings, IcpSettings last, RefineResult& out, Run&& run,
                     Measure&& measure) {
  // L: the extent of the object, the smaller of the two clouds (cloud_stats.hpp), so that a part
  // registered into a wide scene is not pulled by clutter within an eighth of the scene's size. A
  // cloud of duplicated points has no measurable spacing; fall back to a fine fraction of L.
  const double diagonal = std::min(target.extent(), robust_extent(source));
  double spacing = target.spacing();
  if (!(spacing > 0)) spacing = 1e-4 * diagonal;
  out.point_spacing = spacing;
  const double floor = kFinalSpacings * spacing;
  const PointCloud thin = thinned(source);
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
  CoarseEnd end = coarse_stages(coarse_source, init, diagonal, floor, coarse, run);
  {  // Step 3, in a block of its own: the source's copy with normals lives only while it hops.
    PointCloud copy;
    const PointCloud* oriented = nullptr;  // the coarse source with normals, for GICP's candidates
    auto candidate = [&](const Eigen::Isometry3d& start, IcpMethod method) {
      IcpSettings stages = coarse;
      stages.method = method;
      if (!needs_source_normals(method))
        return coarse_stages(coarse_source, start, diagonal, floor, stages, run);
      if (coarse_source.size() < static_cast<std::size_t>(settings.normals.k)) return end;
      if (!oriented) oriented = &with_normals(coarse_source, method, settings, copy);
      return coarse_stages(*oriented, start, diagonal, floor, stages, run);
    };
    end = hop_basins(
        coarse_source, target, init, end, std::max(floor, kFinalSigmas * end.sigma), source_noise,
        settings, out, candidate,
        [&](const Eigen::Isometry3d& T, double reach) { return measure(coarse_source, T, reach); },
        judge);
  }
  Eigen::Isometry3d T = end.T;
  const double sigma = end.sigma;
  double tau = std::max(floor, kFinalSigmas * sigma);
  if (target.surface()) tau = noise_stages(coarse_source, *target.surface(), tau, coarse, T, run);
  last.rejection = RejectionRule::max_distance(tau);
  if (!target.surface()) {
    last.reciprocity = kFinalReciprocity;
    last.reciprocity_floor = kReciprocityFloorSpacings * spacing;
    last.tangent_planes = true;
  }
  if (!settings.kernel) {
    last.kernel = RobustKernel::kGemanMcClure;
    last.kernel_scale = kKernelFraction * tau;
  } else {
    last.kernel_scale = kernel_scale_or_tuned(last.kernel, settings.kernel_scale, sigma);
  }
  out.icp = run(source, T, last);
  if (settings.judge) out.fit = judge(out.icp.T_target_source, tau);
}

}  // namespace

RefineResult refine(const PointCloud& given_source, RefineTarget& target,
                    const Eigen::Isometry3d& init, const RefineSettings& settings) {
  check_registrable(given_source, "source");
  RefineResult out;
  const bool automatic = settings.rejection.kind == RejectionRule::Kind::kAuto;
  NormalCache* normals = target.cache();
  if ((settings.method != IcpMethod::kPointToPoint || automatic) && normals &&
      target.cloud().size() < static_cast<std::size_t>(target.normal_k()))
    throw DataError(
        "target",
        std::to_string(target.cloud().size()) + " points; " +
            (automatic ? std::string("refinement") : std::string(to_string(settings.method))) +
            " needs at least the normal neighbourhood k = " + std::to_string(target.normal_k()));
  // The schedule's final stage onto a point cloud's tangent planes (point-to-plane, point-to-point:
  // the methods that do not read the source's normals themselves) measures their model error with
  // the symmetric step (IcpResult::model_error), which reads them (where the source has a
  // neighbourhood's worth of points).
  const bool measured_planes = automatic && settings.covariance &&
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
  refine_schedule(source, target, init, settings, last, out, run, measure);
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
