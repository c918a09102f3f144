// Axis ticks and their labels (ticks.hpp).
#include "ticks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace align3d::report::detail {
namespace {

// The 1-2-5 step at or above `raw`.
double nice_step(double raw) {
  const double e = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / e;
  return (f <= 1.0 ? 1.0 : f <= 2.0 ? 2.0 : f <= 5.0 ? 5.0 : 10.0) * e;
}

double next_nice_step(double step) { return nice_step(step * 1.01); }

std::string superscript(int k) {
  static const char* const kDigits[] = {"\u2070", "\u00b9", "\u00b2", "\u00b3", "\u2074",
                                        "\u2075", "\u2076", "\u2077", "\u2078", "\u2079"};
  std::string out = k < 0 ? "\u207b" : "";
  for (char c : std::to_string(std::abs(k))) out += kDigits[c - '0'];
  return out;
}

// A value on a grid of `step`, printed with as many decimals as the step needs; beyond six digits
// before or after the point, as a mantissa with just enough digits and a power of ten: 1.205×10⁷.
std::string format_linear(double v, double step) {
  if (std::abs(v) < step * 1e-6) return "0";
  const int step_exponent = static_cast<int>(std::floor(std::log10(step) + 1e-9));
  char buf[64];
  if (std::max(std::abs(v), step) < 1e6 && step_exponent >= -5) {
    std::snprintf(buf, sizeof buf, "%.*f", std::max(0, -step_exponent), v);
    return with_unicode_minus(buf);
  }
  int k = static_cast<int>(std::floor(std::log10(std::abs(v))));
  const int decimals = std::max(0, k - step_exponent);
  double mantissa = v / std::pow(10.0, k);
  const double rounding = 0.5 * std::pow(10.0, -decimals);
  if (std::abs(mantissa) >= 10 - rounding) {
    ++k;
    mantissa /= 10;
  }
  std::snprintf(buf, sizeof buf, "%.*f", decimals, mantissa);
  return with_unicode_minus(buf) + "\u00d710" + superscript(k);
}

// m * 10^k for a mantissa m in 1..9: plain decimals for 0.001 .. 10000, else 10⁻⁶ or 2×10⁻⁶.
std::string format_power(int m, int k) {
  if (k >= -3 && k <= 4) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*f", std::max(0, -k), m * std::pow(10.0, k));
    return buf;
  }
  return (m == 1 ? std::string() : std::to_string(m) + "\u00d7") + "10" + superscript(k);
}

}  // namespace

std::string with_unicode_minus(std::string s) {
  if (!s.empty() && s[0] == '-') s.replace(0, 1, "\u2212");
  return s;
}

Ticks linear_ticks(cairo_t* cr, Range r, double length_px, double target_px, bool horizontal) {
  Ticks t;
  const double target_count = std::max(2.0, length_px / target_px);
  double step = nice_step(r.span() / target_count);
  for (int attempt = 0; attempt < 8; ++attempt) {
    t.major.clear();
    const auto first = static_cast<long long>(std::ceil(r.lo / step - 1e-9));
    const auto last = static_cast<long long>(std::floor(r.hi / step + 1e-9));
    double widest = 0;
    for (long long i = first; i <= last && t.major.size() < 100; ++i) {
      const double v = static_cast<double>(i) * step;
      t.major.push_back({v, format_linear(v, step)});
      widest = std::max(widest, text_width(cr, t.major.back().label));
    }
    // Horizontal labels must not touch each other; vertical ones are spaced by target_px already.
    const double step_px = step / r.span() * length_px;
    if (!horizontal || widest + 12 <= step_px) break;
    step = next_nice_step(step);
  }
  return t;
}

Ticks log_ticks(cairo_t* cr, Range r, double length_px) {
  Ticks t;
  const double max_major = std::max(2.0, std::floor(length_px / 40));
  const int k0 = static_cast<int>(std::ceil(r.lo - 1e-9));
  const int k1 = static_cast<int>(std::floor(r.hi + 1e-9));
  const int decades = k1 - k0 + 1;
  const double decade_px = length_px / r.span();
  if (decades >= 2) {
    const int stride = static_cast<int>(std::ceil(decades / max_major));
    for (int k = k0; k <= k1; ++k) {
      if (((k % stride) + stride) % stride == 0)
        t.major.push_back({static_cast<double>(k), format_power(1, k)});
    }
    if (stride == 1 && decade_px >= 25) {
      for (int k = k0 - 1; k <= k1; ++k) {
        for (int m = 2; m <= 9; ++m) {
          const double pos = k + std::log10(m);
          if (pos >= r.lo && pos <= r.hi) t.minor.push_back(pos);
        }
      }
    }
    return t;
  }
  // Less than two decades visible: label 1, 2 and 5 times powers of ten.
  for (int k = static_cast<int>(std::floor(r.lo)) - 1; k <= static_cast<int>(std::ceil(r.hi));
       ++k) {
    for (int m = 1; m <= 9; ++m) {
      const double pos = k + std::log10(m);
      if (pos < r.lo - 1e-9 || pos > r.hi + 1e-9) continue;
      if (m == 1 || m == 2 || m == 5) {
        t.major.push_back({pos, format_power(m, k)});
      } else {
        t.minor.push_back(pos);
      }
    }
  }
  if (t.major.size() >= 2) return t;
  // Within a factor of ~2.5: ordinary 1-2-5 steps of the value, placed logarithmically.
  t = {};
  const Range values{std::pow(10.0, r.lo), std::pow(10.0, r.hi)};
  for (const Tick& lin : linear_ticks(cr, values, length_px, 60, false).major) {
    if (lin.pos > 0) t.major.push_back({std::log10(lin.pos), lin.label});
  }
  return t;
}

}  // namespace align3d::report::detail
