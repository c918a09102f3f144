// When the ICP loop stops (chapter 39.2, "Termination criterion"), and why.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

namespace align3d {

struct TerminationSettings {
  int max_iterations = 60;
  // Stop when |RMS_k − RMS_(k−1)| < rms_change, times RMS_(k−1) when rms_change_relative (the
  // default: unit-free). The chapter's rule is absolute: rms_change = 1e-5 mm, relative = false.
  double rms_change = 1e-5;
  bool rms_change_relative = true;
  // Stop when one update rotates by less than `rotation` radians AND moves by less than
  // `translation` × (target bounding-box diagonal). 0 disables this criterion.
  double rotation = 1e-7;
  double translation = 1e-8;
  // > 0: the RMS criterion stops the loop only where the update it would apply next is shorter
  // than this many standard deviations of the pose (√(ξᵀHξ)/σ̂: H the pairs' system, σ̂ their
  // RMS, the covariance σ̂²H⁻¹), since along a valley the RMS barely changes while the pose still
  // moves. 0: off. (A zero system, point-to-point's, never holds the loop.)
  double step_sigmas = 0;
};

// How many evaluations back a repeated state counts as a cycle (check_termination).
inline constexpr std::size_t kCycleLookback = 10;

enum class StopReason {
  kRmsChange,              // converged: RMS settled
  kTransformChange,        // converged: the update became negligible
  kCycle,                  // converged: the loop repeats a state of the last kCycleLookback
                           // iterations exactly
                           // (same RMS to 1e-12 and same number of pairs): discrete
                           // correspondences flipping back and forth, no further progress
  kMaxIterations,          // not converged: iteration cap
  kTooFewCorrespondences,  // not converged: fewer pairs than the metric needs
};

inline const char* to_string(StopReason r) {
  switch (r) {
    case StopReason::kRmsChange:
      return "rms_change";
    case StopReason::kTransformChange:
      return "transform_change";
    case StopReason::kCycle:
      return "cycle";
    case StopReason::kMaxIterations:
      return "max_iterations";
    case StopReason::kTooFewCorrespondences:
      return "too_few_correspondences";
  }
  return "unknown";
}

inline bool is_convergence(StopReason r) {
  return r == StopReason::kRmsChange || r == StopReason::kTransformChange ||
         r == StopReason::kCycle;
}

// One evaluation of a pose: the initial one, then one after each update.
struct IterationRecord {
  double rms = 0;        // RMS residual of the kept pairs at that pose: Euclidean distance
                         // (point-to-point) or plane distance (the others; IcpStep::rms)
  std::size_t kept = 0;  // pairs that passed rejection
  double threshold = 0;  // rejection threshold used (data units; infinity for "none")
};

// The convergence criteria, checked on the pose just evaluated (history.back(), whose update is
// `delta`; `previous_rms` is the RMS of the evaluation before it, NaN for the first): true, with
// the reason, when the loop should stop there and return that pose. In order: a state of the last
// kCycleLookback evaluations repeats (kCycle), |ΔRMS| below rms_change (kRmsChange), the update
// below both rotation and translation × `diagonal` (kTransformChange). The iteration cap is the
// caller's. `step_sigmas`: the length of `delta` in standard deviations of the pose
// (settings.step_sigmas; NaN or 0 where it was not measured).
bool check_termination(const std::vector<IterationRecord>& history, double previous_rms,
                       const Eigen::Isometry3d& delta, double diagonal,
                       const TerminationSettings& settings, StopReason& reason,
                       double step_sigmas = 0);

}  // namespace align3d
