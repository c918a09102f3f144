// Robust kernels for iteratively re-weighted least squares: a pair with residual d gets the weight
// w(d) = ρ'(d)/d of the kernel ρ, recomputed every iteration, so the weighted Gauss-Newton step
// minimises Σ ρ(d) (Zhang 1997, "Parameter estimation techniques", M-estimators; the formulas as in
// Open3D's robust_kernel.h and Barron 2019's survey). With u = d / c, c the kernel's scale:
//   none           ρ = d²/2                                   w = 1
//   huber          ρ = d²/2 (|d| ≤ c), c(|d| − c/2)           w = 1, c/|d|
//   cauchy         ρ = c²/2 · log(1 + u²)                     w = 1 / (1 + u²)
//   geman-mcclure  ρ = c²/2 · u² / (1 + u²)                   w = 1 / (1 + u²)²
//   tukey          ρ = c²/6 · (1 − (1 − u²)³) (|u| ≤ 1), c²/6  w = (1 − u²)², 0
//   welsch         ρ = c²/2 · (1 − exp(−u²))                  w = exp(−u²)
// The weight is what the ICP sums use; ρ is given for tests and documentation.
#pragma once

#include <cmath>
#include <optional>
#include <string_view>

namespace align3d {

enum class RobustKernel { kNone, kHuber, kCauchy, kGemanMcClure, kTukey, kWelsch };

inline constexpr RobustKernel kAllKernels[] = {RobustKernel::kNone,   RobustKernel::kHuber,
                                               RobustKernel::kCauchy, RobustKernel::kGemanMcClure,
                                               RobustKernel::kTukey,  RobustKernel::kWelsch};

inline const char* to_string(RobustKernel k) {
  switch (k) {
    case RobustKernel::kNone:
      return "none";
    case RobustKernel::kHuber:
      return "huber";
    case RobustKernel::kCauchy:
      return "cauchy";
    case RobustKernel::kGemanMcClure:
      return "geman-mcclure";
    case RobustKernel::kTukey:
      return "tukey";
    case RobustKernel::kWelsch:
      return "welsch";
  }
  return "none";
}

// The kernel named by to_string(); nullopt for any other name.
inline std::optional<RobustKernel> kernel_from_string(std::string_view name) {
  for (RobustKernel k : kAllKernels)
    if (name == to_string(k)) return k;
  return std::nullopt;
}

// The scale of each kernel as a multiple of the noise σ when none is given: the classic tuning
// constants for 95 % efficiency on Gaussian residuals (Huber 1.345, Cauchy 2.385, Tukey 4.685,
// Welsch 2.985; Zhang 1997, table 1), and 2 for Geman-McClure (the weight refine()'s `auto`
// schedule gives its final stage: scale τ/2 with τ ≥ 4σ).
inline double kernel_tuning(RobustKernel k) {
  switch (k) {
    case RobustKernel::kNone:
      return 0.0;
    case RobustKernel::kHuber:
      return 1.345;
    case RobustKernel::kCauchy:
      return 2.3849;
    case RobustKernel::kGemanMcClure:
      return 2.0;
    case RobustKernel::kTukey:
      return 4.6851;
    case RobustKernel::kWelsch:
      return 2.9846;
  }
  return 0.0;
}

// The scale of a chosen kernel: `scale` when positive (data units), else kernel_tuning(k) × σ̂,
// `sigma` being the noise of the residuals as the caller estimates it (CostSettings, refine.hpp).
inline double kernel_scale_or_tuned(RobustKernel k, double scale, double sigma) {
  return scale > 0 ? scale : kernel_tuning(k) * sigma;
}

// w(d) for scale c > 0 (the table above); 1 for kNone or c <= 0 (plain least squares).
inline double kernel_weight(RobustKernel k, double d, double c) {
  if (k == RobustKernel::kNone || !(c > 0)) return 1.0;
  const double a = std::abs(d), u2 = (d / c) * (d / c);
  switch (k) {
    case RobustKernel::kHuber:
      return a <= c ? 1.0 : c / a;
    case RobustKernel::kCauchy:
      return 1.0 / (1.0 + u2);
    case RobustKernel::kGemanMcClure:
      return 1.0 / ((1.0 + u2) * (1.0 + u2));
    case RobustKernel::kTukey:
      return u2 >= 1.0 ? 0.0 : (1.0 - u2) * (1.0 - u2);
    case RobustKernel::kWelsch:
      return std::exp(-u2);
    case RobustKernel::kNone:
      break;
  }
  return 1.0;
}

// ψ'(d) = d(w·d)/dd, the slope of the influence function, for scale c > 0 (1 for kNone or c <= 0):
// an M-estimate's covariance is A⁻¹ B A⁻¹ with A = Σ ψ'(r) JJᵀ, B = Σ ψ(r)² JJᵀ (Huber 1981, §6).
//   huber 1, 0   cauchy (1 − u²)/(1 + u²)²   geman-mcclure (1 − 3u²)/(1 + u²)³
//   tukey (1 − u²)(1 − 5u²), 0   welsch (1 − 2u²) exp(−u²)
inline double kernel_slope(RobustKernel k, double d, double c) {
  if (k == RobustKernel::kNone || !(c > 0)) return 1.0;
  const double u2 = (d / c) * (d / c), s = 1.0 + u2;
  switch (k) {
    case RobustKernel::kHuber:
      return std::abs(d) <= c ? 1.0 : 0.0;
    case RobustKernel::kCauchy:
      return (1.0 - u2) / (s * s);
    case RobustKernel::kGemanMcClure:
      return (1.0 - 3.0 * u2) / (s * s * s);
    case RobustKernel::kTukey:
      return u2 >= 1.0 ? 0.0 : (1.0 - u2) * (1.0 - 5.0 * u2);
    case RobustKernel::kWelsch:
      return (1.0 - 2.0 * u2) * std::exp(-u2);
    case RobustKernel::kNone:
      break;
  }
  return 1.0;
}

// ρ(d) for scale c > 0 (the table above); d²/2 for kNone or c <= 0.
inline double kernel_rho(RobustKernel k, double d, double c) {
  if (k == RobustKernel::kNone || !(c > 0)) return 0.5 * d * d;
  const double a = std::abs(d), u2 = (d / c) * (d / c), c2 = c * c;
  switch (k) {
    case RobustKernel::kHuber:
      return a <= c ? 0.5 * d * d : c * (a - 0.5 * c);
    case RobustKernel::kCauchy:
      return 0.5 * c2 * std::log1p(u2);
    case RobustKernel::kGemanMcClure:
      return 0.5 * c2 * u2 / (1.0 + u2);
    case RobustKernel::kTukey:
      return u2 >= 1.0 ? c2 / 6.0 : c2 / 6.0 * (1.0 - (1.0 - u2) * (1.0 - u2) * (1.0 - u2));
    case RobustKernel::kWelsch:
      return 0.5 * c2 * (1.0 - std::exp(-u2));
    case RobustKernel::kNone:
      break;
  }
  return 0.5 * d * d;
}

}  // namespace align3d
