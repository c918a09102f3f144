// Whether a pose fits at the noise: the residual a right registration leaves, and how far the
// residuals at a pose are from it. refine() (its basin hopping), align() (its confirmation, the
// high_rms warning and the support's band) judge poses by it.
//
// The residuals are the point-to-plane distances of the pairs within a reach, one to one (a pair
// longer than half a point spacing only when it is the shortest of its target point: refine.hpp).
// A right pose leaves
//   e = max(σ₀, min(σ_r, kStructuredSpacings · s)),  σ₀ at least kFitFloorSpacings · s,
//   σ₀ = √(σ_source² + σ_target²), each the cloud's surface_noise (cloud_stats.hpp: local quadric
//        fits of one cloud alone);
//   σ_r = 1.4826 × the median |residual|, the pairs' own robust scale at the pose.
// Two real scans of one surface differ by more than either's local noise: structured error
// (calibration, warped range images) smooth over a few spacings, which a local fit of one scan
// takes for shape (the Stanford dragon's neighbouring scans: σ_r 3-4 σ₀ at the reference pose).
// Where the pairs' bulk shows more than σ₀, e follows it, up to half a point spacing: a pose whose
// residuals are mostly off the surface is not explained away by it. The statistic is
// ratio = RMS / e: the bulk at the noise and no tail beyond it give ≈ 1-1.5; a wrong local minimum
// lays part of the object on the surface and leaves the rest off, a tail that raises the RMS far
// above the bulk's scale, or, off the surface altogether, σ_r far above half a spacing. A pose is
// confirmed with a ratio at most kConfirmedFit and weak above kWeakFit (refine.hpp).
// Calibrated on real and generated pairs: bench/README.md, "Expected residual".
#pragma once

#include <cstddef>
#include <vector>

namespace align3d {

// e at most this many point spacings above σ₀; σ₀ at least kFitFloorSpacings spacings
// (noise-free synthetic data: two samplings of one surface still differ a little).
inline constexpr double kStructuredSpacings = 0.5;
inline constexpr double kFitFloorSpacings = 0.05;

// What a fit is judged against: σ₀ (`noise`, data units; < 0: not judged) and the point spacing.
struct FitScale {
  double noise = -1;
  double spacing = 0;
};

struct FitEvidence {
  double ratio = 0;       // RMS / expected (dimensionless; the test statistic)
  double rms = 0;         // RMS of the residuals (data units)
  double expected = 0;    // e: the residual a right pose leaves (data units)
  double structured = 0;  // √(e² − σ₀²): what the pairs show beyond σ₀ (data units)
  std::size_t pairs = 0;  // pairs judged
};

// The evidence of pairs with `residuals` (data units), given σ₀ (`noise`) and the point spacing s.
// All zero for no pairs. The same residuals in the same order give the same bits.
FitEvidence judge_fit(const std::vector<double>& residuals, double noise, double spacing);

}  // namespace align3d
