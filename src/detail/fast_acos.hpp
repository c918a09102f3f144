// acos to within 2e-8 rad (Abramowitz & Stegun 4.4.46): the point pair features' three angles a
// pair (coarse/ppf.cpp), quantised in 6° bins, where libm's acos took 6 % of `align3d find`.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

namespace align3d::detail {

// For x in [−1, 1] (clamped): acos(x) with |error| ≤ 2e-8.
inline double fast_acos(double x) {
  x = std::clamp(x, -1.0, 1.0);
  const double a = std::abs(x);
  double p = -0.0012624911;
  p = p * a + 0.0066700901;
  p = p * a - 0.0170881256;
  p = p * a + 0.0308918810;
  p = p * a - 0.0501743046;
  p = p * a + 0.0889789874;
  p = p * a - 0.2145988016;
  p = p * a + 1.5707963050;
  const double r = std::sqrt(1 - a) * p;
  return x >= 0 ? r : std::numbers::pi - r;
}

}  // namespace align3d::detail
