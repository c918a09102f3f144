#include "align3d/icp/termination.hpp"

#include <cmath>

#include "align3d/se3.hpp"

namespace align3d {

bool check_termination(const std::vector<IterationRecord>& history, double previous_rms,
                       const Eigen::Isometry3d& delta, double diagonal,
                       const TerminationSettings& settings, StopReason& reason,
                       double step_sigmas) {
  const IterationRecord& now = history.back();
  // A state of the last kCycleLookback passes seen again: the loop is periodic. Periods up to 7
  // were met on real scans (the Stanford dragon 312° onto 336°, one-to-one pairs at the final
  // reach: 60 iterations to the cap at a 7-cycle), hence a window well above the 2-4 of
  // synthetic data.
  const std::size_t seen = history.size() - 1;
  for (std::size_t back = 2; back <= kCycleLookback && back <= seen; ++back) {
    const IterationRecord& then = history[seen - back];
    if (then.kept == now.kept && std::abs(then.rms - now.rms) <= 1e-12 * now.rms) {
      reason = StopReason::kCycle;
      return true;
    }
  }
  const double rms_tolerance =
      settings.rms_change * (settings.rms_change_relative ? previous_rms : 1.0);
  const bool still_moving = settings.step_sigmas > 0 && step_sigmas > settings.step_sigmas;
  if (std::abs(now.rms - previous_rms) < rms_tolerance && !still_moving) {
    reason = StopReason::kRmsChange;
    return true;
  }
  if (settings.rotation > 0 && rotation_angle(delta.linear()) < settings.rotation &&
      delta.translation().norm() < settings.translation * diagonal) {
    reason = StopReason::kTransformChange;
    return true;
  }
  return false;
}

}  // namespace align3d
