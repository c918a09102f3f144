// The deviation histogram (histogram.hpp): a Figure of bars, band, limit lines and a curve.
#include "align3d/report/histogram.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "align3d/report/colormap.hpp"
#include "align3d/report/plot.hpp"
#include "align3d/report/views_figure.hpp"  // band_value, format_deviation, format_count

namespace align3d::report {
namespace {

// A pale green behind the bars: the band where deviations pass (no deviation colour is green, so
// the shading cannot be read as one).
constexpr Rgb kBandShade{0.88, 0.95, 0.87};
constexpr Rgb kLimitColor{0.2, 0.2, 0.2};
constexpr Rgb kGaussColor{0.1, 0.1, 0.1};
constexpr int kCurveSamples = 400;

std::string points(std::size_t n) { return format_count(n) + (n == 1 ? " point" : " points"); }

void check(const Histogram& h, const Tolerance& band) {
  if (h.counts.empty() || !(h.lo < h.hi) || !std::isfinite(h.hi - h.lo)) {
    throw std::invalid_argument("deviation histogram: needs bins over a finite range lo < hi");
  }
  if (!(band.lower <= 0 && band.upper >= 0 && band.lower < band.upper) ||
      !std::isfinite(band.upper - band.lower)) {
    throw std::invalid_argument("deviation histogram: the band must hold 0 with lower < upper");
  }
}

Series gauss_curve(const Histogram& h, const GaussFit& g, const Tolerance& band,
                   const std::string& units, bool log_y) {
  std::size_t total = h.below + h.above;
  for (std::size_t c : h.counts) total += c;
  Series s;
  s.label = "Gauss fit: mean " + format_deviation(g.mean, band, units) + ", \u03c3 " +
            format_deviation(g.sigma, band, units, false);
  s.color = kGaussColor;
  s.line = true;
  s.size = 2;
  s.alpha = 0.9;
  const double scale =
      static_cast<double>(total) * h.width() / (g.sigma * std::sqrt(2 * std::numbers::pi));
  // On a log axis, only where the curve is at least half a point per bin: |z| <= √(2 ln(2·scale)).
  // Sampled densely there, so the curve is smooth (and too long for plot markers).
  double x0 = h.lo, x1 = h.hi;
  if (log_y) {
    const double z_max = scale > 0.5 ? std::sqrt(2 * std::log(2 * scale)) : 0;
    x0 = std::max(h.lo, g.mean - z_max * g.sigma);
    x1 = std::min(h.hi, g.mean + z_max * g.sigma);
  }
  if (!(x0 < x1)) return s;
  for (int i = 0; i <= kCurveSamples; ++i) {
    const double x = x0 + (x1 - x0) * i / kCurveSamples;
    const double z = (x - g.mean) / g.sigma;
    s.points.emplace_back(x, std::max(scale * std::exp(-0.5 * z * z), log_y ? 0.5 : 0.0));
  }
  return s;
}

std::string note(const Histogram& h, std::size_t outliers) {
  std::string text = points(h.below + h.above) + " beyond the plotted range";
  if (h.below + h.above > 0) {
    text += " (" + format_count(h.below) + " below, " + format_count(h.above) + " above)";
  }
  return text + "; " + format_count(outliers) + (outliers == 1 ? " outlier" : " outliers") +
         " left out";
}

}  // namespace

void write_deviation_histogram(const Histogram& histogram, const GaussFit& gauss,
                               const Tolerance& band, std::size_t outliers,
                               const std::filesystem::path& stem,
                               const HistogramFigureSettings& settings) {
  check(histogram, band);
  const std::string& units = settings.units;
  Figure f;
  f.title = settings.title;
  f.x_label = units.empty() ? "deviation" : "deviation (" + units + ")";
  f.y_label = "points per bin";
  f.width = settings.width;
  f.height = settings.height;
  f.log_y = settings.log_counts && std::any_of(histogram.counts.begin(), histogram.counts.end(),
                                               [](std::size_t c) { return c > 0; });
  const double w = histogram.width();
  for (std::size_t i = 0; i < histogram.counts.size(); ++i) {
    const double x0 = histogram.lo + static_cast<double>(i) * w;
    f.bars.push_back({x0, x0 + w, static_cast<double>(histogram.counts[i]),
                      deviation_color(x0 + 0.5 * w, band)});
  }
  f.bands.push_back(
      {band.lower, band.upper,
       "tolerance band " + band_value(band.lower, "") + " \u2026 " + band_value(band.upper, units),
       kBandShade});
  f.vertical_lines.push_back({band.lower, "lower " + band_value(band.lower, units), kLimitColor});
  f.vertical_lines.push_back({band.upper, "upper " + band_value(band.upper, units), kLimitColor});
  if (gauss.sigma > 0 && std::isfinite(gauss.sigma) && std::isfinite(gauss.mean)) {
    f.series.push_back(gauss_curve(histogram, gauss, band, units, f.log_y));
  }
  f.note = note(histogram, outliers);
  write_figure(f, stem);
}

}  // namespace align3d::report
