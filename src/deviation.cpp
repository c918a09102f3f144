#include "align3d/deviation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<double> finite(const std::vector<double>& values) {
  std::vector<double> out;
  out.reserve(values.size());
  for (double v : values)
    if (std::isfinite(v)) out.push_back(v);
  return out;
}

// The p-quantile of v (type 7), reordering v; increasing p on one vector reuses the order built so
// far: nth_element leaves everything above the k-th element after it.
double quantile(std::vector<double>& v, double p, std::size_t& sorted_from) {
  const double h = p * static_cast<double>(v.size() - 1);
  const auto k = static_cast<std::size_t>(std::floor(h));
  auto first = v.begin() + static_cast<std::ptrdiff_t>(std::min(sorted_from, k));
  std::nth_element(first, v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  sorted_from = k;
  if (k + 1 >= v.size()) return v[k];
  const double next = *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(k + 1), v.end());
  return v[k] + (h - static_cast<double>(k)) * (next - v[k]);
}

double median(std::vector<double> v) {
  std::size_t from = 0;
  return v.empty() ? 0.0 : quantile(v, 0.5, from);
}

}  // namespace

DeviationMap measure_deviations(const std::vector<Eigen::Vector3d>& points, const MeshIndex& cad,
                                const Eigen::Isometry3d& T, double max_distance, int threads) {
  const std::size_t n = points.size();
  // Queried in the input's order when it is coherent (a scanner's raster), else in spatial order,
  // each search warm from its neighbour's (MeshIndex::closest_points), each answer written
  // straight to the input's place.
  DeviationMap map;
  map.max_distance = max_distance;
  // Three threads at most size the arrays at once: zeroing their fresh pages is the kernel's work
  // (~10 ms for 2 M points on one thread).
  parallel_tasks(3, threads, [&](std::size_t k) {
    if (k == 0) map.deviation.resize(n);
    if (k == 1) map.closest.resize(n);
    if (k == 2) map.triangle.resize(n);
  });
  cad.closest_points(points, T, max_distance, threads,
                     [&](std::size_t i, const Eigen::Vector3d& q, const SurfacePoint& c) {
                       map.triangle[i] = c.triangle;
                       map.closest[i] = c.found() ? c.point : Eigen::Vector3d::Constant(kNaN);
                       map.deviation[i] = c.found() ? cad.signed_distance(q, c) : kNaN;
                     });
  for (double d : map.deviation) map.outliers += std::isnan(d) ? 1 : 0;
  return map;
}

DeviationStats deviation_stats(const std::vector<double>& deviation) {
  DeviationStats s;
  std::vector<double> v = finite(deviation);
  s.count = v.size();
  if (v.empty()) return s;
  double sum = 0, sum_sq = 0;
  for (double d : v) {
    sum += d;
    sum_sq += d * d;
  }
  const double n = static_cast<double>(v.size());
  s.mean = sum / n;
  s.rms = std::sqrt(sum_sq / n);
  double var = 0;  // about the mean, a second pass: no cancellation
  for (double d : v) var += (d - s.mean) * (d - s.mean);
  s.std = std::sqrt(var / n);
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  s.min = *lo;
  s.max = *hi;
  std::size_t from = 0;
  s.p01 = quantile(v, 0.01, from);
  s.p05 = quantile(v, 0.05, from);
  s.p50 = quantile(v, 0.50, from);
  s.p95 = quantile(v, 0.95, from);
  s.p99 = quantile(v, 0.99, from);
  return s;
}

GaussFit gauss_fit(const std::vector<double>& deviation) {
  std::vector<double> v = finite(deviation);
  GaussFit g;
  if (v.empty()) return g;
  g.mean = median(v);
  for (double& d : v) d = std::abs(d - g.mean);
  g.sigma = 1.4826 * median(std::move(v));
  return g;
}

Histogram histogram(const std::vector<double>& deviation, double lo, double hi, int bins) {
  Histogram h;
  h.lo = lo;
  h.hi = hi;
  if (bins < 1 || !(hi > lo)) return h;
  h.counts.assign(static_cast<std::size_t>(bins), 0);
  const double scale = bins / (hi - lo);
  for (double d : deviation) {
    if (!std::isfinite(d)) continue;
    if (d < lo) {
      ++h.below;
    } else if (d >= hi) {
      ++h.above;
    } else {
      const auto k = std::min(static_cast<std::size_t>((d - lo) * scale), h.counts.size() - 1);
      ++h.counts[k];
    }
  }
  return h;
}

}  // namespace align3d
