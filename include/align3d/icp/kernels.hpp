// Robust kernels for iteratively re-weighted least squares: a pair with residual d gets the weight
// w(d) = ρ'(d)/d of the kernel ρ, recomputed every iteration, so the weighted Gauss-Newton step
// minimises Σ ρ(d) (Zhang 1997, "Parameter estimation techniques", M-estimators).
#pragma once

namespace align3d {

// Geman-McClure weight w = (1 + (d/scale)²)^−2: ~1 for d ≪ scale, falling as d⁻⁴ beyond it, so
// pairs far outside the scale barely pull. scale <= 0: 1 (plain least squares).
inline double geman_mcclure_weight(double d, double scale) {
  if (scale <= 0) return 1.0;
  const double u = d / scale;
  const double s = 1.0 + u * u;
  return 1.0 / (s * s);
}

}  // namespace align3d
