#include "align3d/align.hpp"

#include <cmath>
#include <optional>
#include <stdexcept>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "detail/number.hpp"
#include "detail/target_side.hpp"
#include "detail/timing.hpp"

namespace align3d {
namespace {

using detail::Clock;
using detail::fixed;
using detail::ms_since;
using detail::number;

// What is weak about an answer (align.hpp), as one sentence per finding; empty when nothing.
// "the residuals are X × what a right pose leaves (RMS a, expected b)", of the fit (icp/fit.hpp).
std::string fit_words(const FitEvidence& f) {
  return "the residuals are " + fixed(f.ratio, 1) + " x what a right pose leaves (RMS " +
         number(f.rms) + ", expected " + number(f.expected) + ")";
}

std::vector<Warning> weaknesses(const RefineResult& r, const Support& s) {
  std::vector<Warning> w;
  const IcpResult& icp = r.icp;
  if (icp.stop_reason == StopReason::kTooFewCorrespondences) {
    w.push_back(
        {"too_few_correspondences", "ICP kept too few pairs within the rejection threshold"});
    return w;
  }
  if (s.overlap < kWeakOverlap)
    w.push_back(
        {"weak_overlap", "only " + fixed(100 * s.overlap, 1) + " % of the " + to_string(s.object) +
                             " (the smaller cloud) lies on the other cloud's surface at "
                             "the result (at least " +
                             fixed(100 * kWeakOverlap, 0) + " % expected); the pose may be wrong"});
  if (r.fit.ratio > kWeakFit)
    w.push_back({"high_rms", fit_words(r.fit) + ", more than " + fixed(kWeakFit, 1) +
                                 " x; the pose may be a wrong local minimum"});
  if (!icp.degenerate_directions.empty())
    w.push_back({"degenerate", "the geometry does not constrain " +
                                   std::to_string(icp.degenerate_directions.size()) +
                                   " direction(s) of the pose (a plane, a cylinder, ...); the "
                                   "pose was not moved along them (report: "
                                   "degenerate_directions)"});
  if (!icp.converged)
    w.push_back({"not_converged", std::string("ICP did not converge (") +
                                      to_string(icp.stop_reason) +
                                      "); the pose may be inaccurate"});
  return w;
}

// A warning when ICP stopped short of its stationary point (IcpResult::pending_sigmas): the pose
// is right but less precise than the data allow (its covariance takes the shortfall in), which no
// other start or stage would change, so it does not make an answer weak.
std::optional<Warning> stopped_short(const IcpResult& icp) {
  if (!(icp.pending_sigmas > kStoppedShortSigmas)) return std::nullopt;
  return Warning{"stopped_short",
                 "ICP stopped " + fixed(icp.pending_sigmas, 1) +
                     " standard deviations of its covariance short of its stationary point; the "
                     "covariance includes that distance (a lower --tolerance with more "
                     "--max-iterations goes further; point-to-plane converges in fewer steps)"};
}

// Why an answer that is not weak still needs the global stage's view (align.hpp); empty when it
// does not.
std::string unconfirmed_because(const AlignCandidate& c) {
  if (c.support.overlap < kConfirmedOverlap)
    return "only " + fixed(100 * c.support.overlap, 1) + " % of the " +
           to_string(c.support.object) + " lies on the other cloud's surface (less than " +
           fixed(100 * kConfirmedOverlap, 0) + " %: unconfirmed)";
  if (c.fit.ratio > kConfirmedFit)
    return fit_words(c.fit) + " (more than " + fixed(kConfirmedFit, 1) + " x: unconfirmed)";
  return {};
}

// B replaces A when A failed and B did not, or when B lays clearly more of the object on the
// other cloud's surface (align.hpp). The RMS does not decide: a partial view slid face on face
// keeps fewer pairs, on flat faces, and can show a smaller RMS than the truth.
bool clearly_better(const AlignCandidate& b, const AlignCandidate& a, bool a_failed) {
  return a_failed || b.support.overlap > a.support.overlap + kClearlyBetter;
}

// Is ICP run the other way round (align.hpp)?
bool reverse_icp(const CloudScale& source, const CloudScale& target) {
  return target.extent > kReverseExtentRatio * source.extent;
}

// Two answers are distinct poses when they differ by more than the global stage's distinctness
// (coarse/global.hpp): distinct_rotation_deg, or 2 voxels at the source's centroid; as voxel, the
// support's reach stands in (a few spacings).
bool distinct(const AlignCandidate& a, const AlignCandidate& b, const PointCloud& source,
              double distinct_rotation_deg) {
  const Eigen::Vector3d c = centroid(source);
  return pose_error(a.transformation, b.transformation).rotation_deg > distinct_rotation_deg ||
         (a.transformation * c - b.transformation * c).norm() > 2 * a.support.reach;
}

// Two poses the global stage cannot tell apart: turned by at most two of its voxels over the
// object's extent, the source's centroid moved by at most two voxels.
bool within_resolution(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double voxel,
                       const PointCloud& source, double extent) {
  const Eigen::Vector3d c = centroid(source);
  return deg_to_rad(pose_error(a, b).rotation_deg) <= 2 * voxel / extent &&
         (a * c - b * c).norm() <= 2 * voxel;
}

// Settings no run can use: std::invalid_argument naming the field (align.hpp). The command line
// checks its flags first, with their names; this guards every other caller (the Python binding).
void check_settings(const AlignSettings& s) {
  auto fail = [](const std::string& field, const std::string& rule, double value) {
    throw std::invalid_argument("AlignSettings: " + field + " must be " + rule + ", got " +
                                number(value));
  };
  auto finite_non_negative = [&](const std::string& field, double value) {
    if (!(std::isfinite(value) && value >= 0)) fail(field, "a finite number >= 0", value);
  };
  const TerminationSettings& t = s.refine.termination;
  if (t.max_iterations < 1)
    fail("refine.termination.max_iterations", "at least 1", t.max_iterations);
  finite_non_negative("refine.termination.rms_change", t.rms_change);
  finite_non_negative("refine.termination.rotation", t.rotation);
  finite_non_negative("refine.termination.translation", t.translation);
  if (s.refine.normals.k < 3) fail("refine.normals.k", "at least 3", s.refine.normals.k);
  if (s.threads < 0) fail("threads", ">= 0 (0: all cores)", s.threads);
  finite_non_negative("global.voxel", s.global.voxel);
  if (s.global.ransac_iterations < 0)  // 0: no hypothesis (a global stage that finds nothing)
    fail("global.ransac_iterations", ">= 0", s.global.ransac_iterations);
  if (!(s.global.ransac_confidence > 0 && s.global.ransac_confidence < 1))
    fail("global.ransac_confidence", "in (0, 1)", s.global.ransac_confidence);
  if (!(s.global.min_overlap >= 0 && s.global.min_overlap <= 1))
    fail("global.min_overlap", "in [0, 1]", s.global.min_overlap);
  if (!(s.global.ambiguity_ratio > 0 && s.global.ambiguity_ratio <= 1))
    fail("global.ambiguity_ratio", "in (0, 1]", s.global.ambiguity_ratio);
  finite_non_negative("global.distinct_rotation_deg", s.global.distinct_rotation_deg);
  if (s.ppf_model != nullptr && (s.init == InitPolicy::kIdentity || s.init == InitPolicy::kPose))
    throw std::invalid_argument(
        "AlignSettings: ppf_model needs init global or auto (it feeds the global stage)");
  if (s.ppf_model != nullptr && s.global.voxel > 0)
    throw std::invalid_argument(
        "AlignSettings: global.voxel with a ppf_model: the model's voxel was fixed when it was "
        "built");
}

class Pipeline {
 public:
  // `start`: when the call began, so that the timings' total takes in the preparation (the
  // target's side when it was not prepared beforehand, the source's tree and scale).
  Pipeline(const PointCloud& source, detail::TargetSide& target, const AlignSettings& s,
           Clock::time_point start)
      : start_(start),
        source_(source),
        target_(target),
        s_(s),
        source_tree_(source.positions, s.threads),
        source_scale_(measure_scale(source, source_tree_, s.threads)),
        reversed_(!target.refine.surface() && reverse_icp(source_scale_, target.scale)) {
    if (reversed_)
      source_fixed_ = std::make_unique<RefineTarget>(source, s.refine.normals, s.threads);
    refine_ = s.refine;
    refine_.threads = s.threads;
    refine_.covariance = true;  // the result's covariance and stopped_short
    refine_.judge = true;       // every answer is judged (weaknesses, unconfirmed_because)
    refine_.source_noise = reversed_ ? target.scale.noise : source_scale_.noise;
    // Step 3 of the ICP schedule (basin hopping, the GICP candidate) where ICP is all there is.
    // With init auto an unconfirmed first pose is the global stage's to mend, and step 3 runs
    // only if that stage did not (mend_unconfirmed): it would cost time on every far-off start.
    // From a global pose, the GICP candidate but no hops.
    thorough_ = refine_;
    refine_.hop = s.refine.hop && (s.init == InitPolicy::kIdentity || s.init == InitPolicy::kPose);
    if (s.init == InitPolicy::kAuto) {
      refine_.gicp_candidate = false;
      refine_.probe = true;  // finished only if kept (finish_first)
    }
    global_refine_ = thorough_;
    global_refine_.hop = false;
    global_ = s.global;
    global_.threads = s.threads;
    global_.seed = s.seed;
    if (s.ppf_model) global_.method = GlobalMethod::kPpf;
    out_.reversed = reversed_;
  }

  AlignResult run();

 private:
  void step(const std::string& task) {
    if (s_.progress) s_.progress({task, steps_done_++, 0});
  }
  // ICP from `init` with `settings`, measured; appended to the result's candidates.
  AlignCandidate refine_from(const Eigen::Isometry3d& init, const std::string& path,
                             const RefineSettings& settings, RefineResult& r);
  void mend_unconfirmed(const Eigen::Isometry3d& init, const AlignCandidate& first);
  void finish_first();
  void keep_as_first(const AlignCandidate& done, RefineResult r);
  GlobalResult run_global();
  AlignCandidate refine_global(RefineResult& r, bool& ambiguous);
  void warn_ambiguous_global();
  void keep(const AlignCandidate& c, RefineResult r);

  Clock::time_point start_;
  const PointCloud& source_;
  detail::TargetSide&
      target_;  // the target in spatial order, its scale, tree, normals, descriptors
  const AlignSettings& s_;
  KdTree source_tree_;
  CloudScale source_scale_;
  bool reversed_;  // ICP moves the target onto the source (align.hpp) ...
  std::unique_ptr<RefineTarget> source_fixed_;  // ... prepared here
  RefineSettings refine_;                       // from the initial pose
  RefineSettings global_refine_;                // from a global pose
  RefineSettings thorough_;                     // from the initial pose, step 3 whatever the policy
  GlobalSettings global_;
  std::unique_ptr<SupportMeter> meter_;
  AlignResult out_;
  std::size_t steps_done_ = 0;
};

AlignCandidate Pipeline::refine_from(const Eigen::Isometry3d& init, const std::string& path,
                                     const RefineSettings& settings, RefineResult& r) {
  step("icp from the " + (path == "initial" ? std::string("initial") : path) + " pose");
  auto start = Clock::now();
  r = reversed_ ? refine(target_.refine.cloud(), *source_fixed_, init.inverse(), settings)
                : refine(source_, target_.refine, init, settings);
  const Eigen::Isometry3d T = reversed_ ? r.icp.T_target_source.inverse() : r.icp.T_target_source;
  out_.timings.refine_ms += ms_since(start);
  start = Clock::now();
  if (!meter_)
    meter_ = std::make_unique<SupportMeter>(source_, target_.refine.cloud(), s_.threads,
                                            &source_tree_, &target_.refine.tree(), &source_scale_,
                                            &target_.scale, target_.refine.cache());
  // The structured noise the fit found is allowed for where the pose fits at the noise
  // (support.hpp).
  const bool fits = r.fit.ratio <= kConfirmedFit;
  AlignCandidate c{path, T, meter_->measure(T, fits ? r.fit.structured : 0), r.icp.rms, r.fit};
  c.weak = !weaknesses(r, c.support).empty();
  out_.timings.support_ms += ms_since(start);
  out_.candidates.push_back(c);
  return c;
}

GlobalResult Pipeline::run_global() {
  step(std::string("global registration (") + to_string(global_.method) + ")");
  const auto start = Clock::now();
  GlobalResult g;
  if (s_.ppf_model) {
    try {
      g = ppf_match(*s_.ppf_model, source_, global_);  // the model describes the target
    } catch (const DataError& e) {
      throw DataError("source", e.problem());
    }
    g.object = Role::kTarget;
  } else {
    g = global_register(source_, target_.refine.cloud(), global_,
                        {&source_scale_, &target_.scale, &target_.global});
  }
  g.time_ms = ms_since(start);
  out_.timings.global_ms += g.time_ms;
  return g;
}

void Pipeline::keep(const AlignCandidate& c, RefineResult r) {
  out_.transformation = c.transformation;
  out_.path = c.path;
  out_.support = c.support;
  out_.refine = std::move(r);
  out_.covariance = out_.refine.icp.covariance;
  if (reversed_) {  // the run estimated T⁻¹ = exp(ξ)·T⁻¹, so T = exp(−Ad(T)·ξ)·T
    const Matrix6d A = adjoint(c.transformation);
    out_.covariance = A * out_.covariance * A.transpose();
  }
  out_.success = out_.refine.icp.stop_reason != StopReason::kTooFewCorrespondences;
  if (!out_.success)
    out_.failure =
        "too few correspondences within the rejection threshold (try a larger distance, or "
        "rejection auto)";
}

// ICP from the global pose and, when the global stage found a distinct runner-up, from that too;
// the better supported answer is returned, its ICP in `r`. `ambiguous` is set when neither answer
// is clearly better supported than the other.
AlignCandidate Pipeline::refine_global(RefineResult& r, bool& ambiguous) {
  AlignCandidate best = refine_from(out_.global->T_target_source, "global", global_refine_, r);
  ambiguous = false;
  if (!out_.global->ambiguous) return best;
  RefineResult r2;
  const AlignCandidate second =
      refine_from(out_.global->second_T_target_source, "global runner-up", global_refine_, r2);
  const bool failed = r.icp.stop_reason == StopReason::kTooFewCorrespondences;
  if (clearly_better(second, best, failed)) {
    r = std::move(r2);
    return second;
  }
  ambiguous = !clearly_better(best, second, false) &&
              distinct(best, second, source_, global_.distinct_rotation_deg);
  return best;
}

void Pipeline::warn_ambiguous_global() {
  out_.warnings.push_back({"ambiguous", "global registration: " + out_.global->message +
                                            "; ICP from either pose is supported alike"});
}

// Init auto, after an unconfirmed or weak first answer: the global stage, its answer kept when
// clearly better supported; if it is not (or found nothing) and the first run's step 3 test found
// its pose unconfirmed, the first run continued with step 3 (hops, the GICP candidate;
// RefineSettings::resume), kept when clearly better than the first, or when the first was a probe
// that gave up and no hop was kept (it is then the first run finished).
void Pipeline::mend_unconfirmed(const Eigen::Isometry3d& init, const AlignCandidate& first) {
  const bool step3 = out_.refine.unconfirmed && (thorough_.hop || thorough_.gicp_candidate);
  out_.global = run_global();
  // The global stage, from no initial pose, found the first answer's pose (its winner clear):
  // independent evidence for it, which its ICP would only repeat.
  if (out_.global->success && !out_.global->ambiguous && !first.weak &&
      within_resolution(out_.global->T_target_source, first.transformation, out_.global->voxel,
                        source_, std::min(source_scale_.extent, target_.scale.extent)))
    return;
  std::optional<AlignCandidate> second;
  if (out_.global->success) {
    RefineResult r2;
    bool ambiguous = false;
    second = refine_global(r2, ambiguous);
    if (clearly_better(*second, first, !out_.success)) {
      keep(*second, std::move(r2));
      if (ambiguous) warn_ambiguous_global();
      return;
    }
  }
  AlignCandidate kept = first;
  if (step3) {  // else the rerun would only repeat the first
    RefineResult r3;
    RefineSettings continued = thorough_;  // the first run, continued with step 3
    continued.resume = &out_.refine;
    const AlignCandidate third = refine_from(init, "initial", continued, r3);
    if (clearly_better(third, first, !out_.success)) {
      keep(third, std::move(r3));
      kept = third;
    } else if (!out_.refine.finished && !r3.hopped) {  // no hop kept: the first run, finished
      keep_as_first(third, std::move(r3));
      kept = third;
    }
  }
  if (second && !clearly_better(kept, *second, false) &&
      distinct(kept, *second, source_, global_.distinct_rotation_deg))
    out_.warnings.push_back(
        {"ambiguous",
         "ICP from the initial pose and from the global pose end " +
             fixed(pose_error(kept.transformation, second->transformation).rotation_deg, 1) +
             " deg apart, supported alike (overlap " + fixed(kept.support.overlap, 2) + " and " +
             fixed(second->support.overlap, 2) + "); the initial pose's answer was kept"});
  if (!second && kept.weak)
    out_.warnings.push_back({"global_failed",
                             "the answer from the initial pose is weak and global registration "
                             "found no pose either: " +
                                 out_.global->message});
}

// The kept answer is the first run's, a probe that gave up (init auto, RefineSettings::probe): ICP
// from there to the end, its answer in its place (the first of the candidates).
void Pipeline::finish_first() {
  RefineSettings finishing = refine_;
  finishing.probe = false;
  RefineResult r;
  const AlignCandidate done = refine_from(out_.transformation, "initial", finishing, r);
  keep_as_first(done, std::move(r));
}

// `done`, the first run finished (the last candidate refine_from appended), kept in the first
// run's place among the candidates.
void Pipeline::keep_as_first(const AlignCandidate& done, RefineResult r) {
  out_.candidates.front() = done;
  out_.candidates.pop_back();
  keep(done, std::move(r));
}

AlignResult Pipeline::run() {
  out_.timings.prepare_ms = ms_since(start_);
  const InitPolicy policy = s_.init;
  RefineResult r;
  if (policy != InitPolicy::kGlobal) {
    const Eigen::Isometry3d init =
        policy == InitPolicy::kIdentity ? Eigen::Isometry3d::Identity() : s_.initial_pose;
    const AlignCandidate first = refine_from(init, "initial", refine_, r);
    keep(first, std::move(r));
    const std::string unconfirmed = unconfirmed_because(first);
    if (policy == InitPolicy::kAuto && (first.weak || !unconfirmed.empty())) {
      out_.reason =
          "ICP from the initial pose: " +
          (first.weak ? weaknesses(out_.refine, first.support).front().message : unconfirmed);
      mend_unconfirmed(init, first);
      if (!out_.refine.finished) finish_first();
    }
  } else {
    out_.global = run_global();
    if (!out_.global->success) {
      out_.failure = "global registration found no pose: " + out_.global->message;
      out_.timings.total_ms = ms_since(start_);
      return std::move(out_);
    }
    bool ambiguous = false;
    const AlignCandidate c = refine_global(r, ambiguous);
    keep(c, std::move(r));
    if (ambiguous) warn_ambiguous_global();
  }
  if (out_.success) {
    for (Warning& w : weaknesses(out_.refine, out_.support)) out_.warnings.push_back(std::move(w));
    if (auto w = stopped_short(out_.refine.icp)) out_.warnings.push_back(std::move(*w));
  }
  out_.timings.total_ms = ms_since(start_);
  return std::move(out_);
}

}  // namespace

const char* to_string(InitPolicy p) {
  switch (p) {
    case InitPolicy::kIdentity:
      return "identity";
    case InitPolicy::kPose:
      return "pose";
    case InitPolicy::kGlobal:
      return "global";
    case InitPolicy::kAuto:
      return "auto";
  }
  return "?";
}

AlignResult align(const PointCloud& source, const PointCloud& target,
                  const AlignSettings& settings) {
  const Clock::time_point start = Clock::now();
  check_settings(settings);
  check_registrable(source, "source");  // the source's problems are named first
  detail::TargetSide side(target, settings.refine.normals, settings.threads, false);
  Pipeline pipeline(source, side, settings, start);
  return pipeline.run();
}

AlignResult align(const PointCloud& source, const TriangleMesh& target,
                  const AlignSettings& settings) {
  const Clock::time_point start = Clock::now();
  check_settings(settings);
  check_registrable(source, "source");
  detail::TargetSide side(std::make_shared<const MeshIndex>(target, settings.threads, "target"),
                          settings.threads, false);
  Pipeline pipeline(source, side, settings, start);
  return pipeline.run();
}

AlignResult align(const PointCloud& source, const PreparedTarget& target,
                  const AlignSettings& settings) {
  const Clock::time_point start = Clock::now();
  check_settings(settings);
  check_registrable(source, "source");
  detail::TargetSide& side = detail::TargetSide::of(target);
  if (!side.refine.cloud().has_normals() && settings.refine.normals.k != side.refine.normal_k())
    throw std::invalid_argument(
        "align: the target was prepared with normal k = " + std::to_string(side.refine.normal_k()) +
        ", the settings ask for " + std::to_string(settings.refine.normals.k));
  Pipeline pipeline(source, side, settings, start);
  return pipeline.run();
}

}  // namespace align3d
