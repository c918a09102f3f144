#include "align3d/icp/fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace align3d {

FitEvidence judge_fit(const std::vector<double>& residuals, double noise, double spacing) {
  FitEvidence out;
  const std::size_t n = residuals.size();
  if (n == 0) return out;
  std::vector<double> magnitude(n);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    magnitude[i] = std::abs(residuals[i]);
    sum += residuals[i] * residuals[i];
  }
  // The upper median of |r|, scaled to σ for Gaussian residuals.
  std::nth_element(magnitude.begin(), magnitude.begin() + static_cast<std::ptrdiff_t>(n / 2),
                   magnitude.end());
  const double robust = 1.4826 * magnitude[n / 2];
  const double floor = std::max(noise, kFitFloorSpacings * spacing);
  out.expected = std::max(floor, std::min(robust, kStructuredSpacings * spacing));
  out.structured = std::sqrt(out.expected * out.expected - floor * floor);
  out.rms = std::sqrt(sum / static_cast<double>(n));
  out.ratio = out.expected > 0 ? out.rms / out.expected
                               : (out.rms > 0 ? std::numeric_limits<double>::infinity() : 0.0);
  out.pairs = n;
  return out;
}

}  // namespace align3d
