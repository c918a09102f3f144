// acos and atan2 to within 2e-8 rad (Abramowitz & Stegun 4.4.46 and 4.4.49), for angles that are
// only binned: the point pair features' three angles a pair (coarse/ppf.cpp), quantised in 6°
// bins, where libm's acos took 6 % of `align3d find`; FPFH's θ (coarse/fpfh.cpp), where libm's
// atan2 took an eighth of the descriptors' time.
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

// atan2(y, x) in [−π, π] with |error| ≤ 2e-8 (atan on [0, 1], then by octant); 0 at the origin.
inline double fast_atan2(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  const double hi = std::max(ax, ay);
  if (hi == 0) return 0;
  const double z = std::min(ax, ay) / hi, z2 = z * z;
  double p = 0.0028662257;
  p = p * z2 - 0.0161657367;
  p = p * z2 + 0.0429096138;
  p = p * z2 - 0.0752896400;
  p = p * z2 + 0.1065626393;
  p = p * z2 - 0.1420889944;
  p = p * z2 + 0.1999355085;
  p = p * z2 - 0.3333314528;
  double a = z * (1 + p * z2);
  if (ay > ax) a = std::numbers::pi / 2 - a;
  if (x < 0) a = std::numbers::pi - a;
  return y < 0 ? -a : a;
}

}  // namespace align3d::detail
