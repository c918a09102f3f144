#include "align3d/icp/termination.hpp"

#include <cmath>

#include "align3d/se3.hpp"

namespace align3d {

bool check_termination(const std::vector<IterationRecord>& history, double previous_rms,
                       const Eigen::Isometry3d& delta, double diagonal,
                       const TerminationSettings& settings, StopReason& reason) {
  const IterationRecord& now = history.back();
  // A state seen in the last 4 passes again: the loop is periodic.
  const std::size_t seen = history.size() - 1;
  for (std::size_t back = 2; back <= 4 && back <= seen; ++back) {
    const IterationRecord& then = history[seen - back];
    if (then.kept == now.kept && std::abs(then.rms - now.rms) <= 1e-12 * now.rms) {
      reason = StopReason::kCycle;
      return true;
    }
  }
  const double rms_tolerance =
      settings.rms_change * (settings.rms_change_relative ? previous_rms : 1.0);
  if (std::abs(now.rms - previous_rms) < rms_tolerance) {
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
