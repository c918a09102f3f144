#include "align3d/report/colormap.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace align3d::report {
namespace {

// Moreland's cool-warm map at 9 anchors from −1 to 1 (sRGB / 255), interpolated linearly.
constexpr std::array<Rgb, 9> kCoolWarm = {{{0.230, 0.299, 0.754},
                                           {0.353, 0.472, 0.866},
                                           {0.485, 0.627, 0.947},
                                           {0.619, 0.756, 0.993},
                                           {0.865, 0.865, 0.865},
                                           {0.958, 0.754, 0.652},
                                           {0.958, 0.603, 0.481},
                                           {0.885, 0.396, 0.311},
                                           {0.706, 0.016, 0.150}}};

Rgb cool_warm(double t) {  // t in [−1, 1]
  const double x = (std::clamp(t, -1.0, 1.0) + 1) * 0.5 * (kCoolWarm.size() - 1);
  const auto k = std::min(static_cast<std::size_t>(x), kCoolWarm.size() - 2);
  const double f = x - static_cast<double>(k);
  Rgb c;
  for (int i = 0; i < 3; ++i) c[i] = (1 - f) * kCoolWarm[k][i] + f * kCoolWarm[k + 1][i];
  return c;
}

}  // namespace

Rgb deviation_color(double d, const Tolerance& band) {
  if (std::isnan(d)) return kOutlierColor;
  if (d < band.lower) return kBelowColor;
  if (d > band.upper) return kAboveColor;
  if (d < 0) return cool_warm(band.lower < 0 ? d / -band.lower : 0);
  return cool_warm(band.upper > 0 ? d / band.upper : 0);
}

}  // namespace align3d::report
