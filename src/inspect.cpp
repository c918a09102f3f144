#include "align3d/inspect.hpp"

#include <cmath>
#include <stdexcept>

#include "detail/number.hpp"
#include "detail/timing.hpp"

namespace align3d {
namespace {

using detail::Clock;
using detail::ms_since;
using detail::number;

void check_settings(const InspectSettings& s) {
  const Tolerance& t = s.tolerance;
  if (!(std::isfinite(t.lower) && std::isfinite(t.upper) && t.lower <= 0 && t.upper >= 0 &&
        t.lower < t.upper))
    throw std::invalid_argument(
        "InspectSettings: tolerance must be a band lower <= 0 <= upper "
        "with lower < upper, got [" +
        number(t.lower) + ", " + number(t.upper) + "]");
  if (!(s.pass_fraction > 0 && s.pass_fraction <= 1))
    throw std::invalid_argument("InspectSettings: pass_fraction must be in (0, 1], got " +
                                number(s.pass_fraction));
  if (!(std::isfinite(s.max_distance) && s.max_distance >= 0))
    throw std::invalid_argument("InspectSettings: max_distance must be a finite number >= 0, got " +
                                number(s.max_distance));
  if (s.threads < 0)
    throw std::invalid_argument("InspectSettings: threads must be >= 0 (0: all cores)");
}

// What the CAD mesh's cleaning found (mesh.hpp): each may make signs or distances wrong somewhere.
void warn_about_mesh(const MeshIndex& cad, std::vector<Warning>& w) {
  const MeshTopology& t = cad.topology();
  const MeshRepair& r = cad.repair();
  if (r.inconsistent_edges > 0)
    w.push_back(
        {"mesh_winding", "the CAD mesh's triangles are wound inconsistently (" +
                             std::to_string(r.inconsistent_edges) + " edges); " +
                             std::to_string(r.flipped_triangles) +
                             " triangles were re-wound before measuring (check the export)"});
  if (r.inverted_components > 0)
    w.push_back({"mesh_inverted", std::to_string(r.inverted_components) +
                                      " closed piece(s) of the CAD mesh faced inward and were "
                                      "turned outward"});
  if (t.boundary_edges > 0)
    w.push_back({"mesh_open", "the CAD mesh is open (" + std::to_string(t.boundary_edges) +
                                  " boundary edges): the sign of deviations near its holes may be "
                                  "wrong"});
  if (t.non_manifold_edges > 0)
    w.push_back({"mesh_non_manifold", "the CAD mesh has " + std::to_string(t.non_manifold_edges) +
                                          " edges shared by three or more triangles: signs near "
                                          "them may be wrong"});
}

// The counts against the band, the verdict, and the warnings about the measurement itself.
void judge(const InspectSettings& s, std::size_t points, InspectResult& r) {
  const Tolerance& t = s.tolerance;
  for (double d : r.map.deviation) {
    if (std::isnan(d)) continue;
    if (d < t.lower) {
      ++r.below;
    } else if (d > t.upper) {
      ++r.above;
    } else {
      ++r.within;
    }
  }
  const std::size_t inliers = r.within + r.below + r.above;
  r.within_tolerance = inliers ? static_cast<double>(r.within) / static_cast<double>(inliers) : 0;
  r.pass = inliers > 0 && r.within_tolerance >= s.pass_fraction;
  if (inliers == 0) {
    r.warnings.push_back({"no_points", "no scan point lies within " + number(r.map.max_distance) +
                                           " of the CAD surface: nothing was measured"});
    return;
  }
  const double outliers = static_cast<double>(r.map.outliers) / static_cast<double>(points);
  if (outliers > kManyOutliers)
    r.warnings.push_back(
        {"many_outliers", number(100 * outliers) + " % of the scan points lie farther than " +
                              number(r.map.max_distance) +
                              " from the CAD surface: the scan holds much besides the part, or "
                              "the registration is wrong"});
  if (r.gauss.sigma > kNoisyBand * (t.upper - t.lower))
    r.warnings.push_back(
        {"noisy_for_tolerance", "the measuring noise (sigma " + number(r.gauss.sigma) +
                                    ") is more than a sixth of the tolerance band's width " +
                                    number(t.upper - t.lower) +
                                    ": points outside the band may be noise, not form error"});
}

InspectResult run(const PointCloud& scan, const PreparedTarget& cad, const InspectSettings& s) {
  const auto start = Clock::now();
  check_settings(s);
  const std::shared_ptr<const MeshIndex> surface = cad.shared_surface();
  if (!surface) throw std::invalid_argument("inspect: the CAD model must be a mesh");
  InspectResult r;
  r.surface = surface;
  AlignSettings a = s.align;
  a.threads = s.threads;
  r.registration = align(scan, cad, a);
  r.align_ms = ms_since(start);
  r.tolerance = s.tolerance;
  r.mesh = surface->topology();
  r.repair = surface->repair();
  r.warnings = r.registration.warnings;
  warn_about_mesh(*surface, r.warnings);
  if (!r.registration.success) {
    r.total_ms = ms_since(start);
    return r;
  }
  const auto measure = Clock::now();
  r.map = measure_deviations(scan.positions, *surface, r.registration.transformation,
                             outlier_distance(s, surface->diagonal()), s.threads);
  r.deviation_ms = ms_since(measure);
  r.stats = deviation_stats(r.map.deviation);
  r.gauss = gauss_fit(r.map.deviation);
  const double lo = std::max(-r.map.max_distance, std::min(1.5 * s.tolerance.lower, r.stats.min));
  const double hi = std::min(r.map.max_distance, std::max(1.5 * s.tolerance.upper, r.stats.max));
  r.histogram = histogram(r.map.deviation, lo, std::nextafter(hi, INFINITY), kHistogramBins);
  judge(s, scan.size(), r);
  r.total_ms = ms_since(start);
  return r;
}

}  // namespace

double outlier_distance(const InspectSettings& s, double cad_diagonal) {
  if (s.max_distance > 0) return s.max_distance;
  const double half_band = std::max(-s.tolerance.lower, s.tolerance.upper);
  return std::max(kOutlierTolerances * half_band, kOutlierDiagonal * cad_diagonal);
}

InspectResult inspect(const PointCloud& scan, const TriangleMesh& cad,
                      const InspectSettings& settings) {
  check_settings(settings);  // before the mesh is indexed
  return run(scan, PreparedTarget(cad, settings.threads), settings);
}

InspectResult inspect(const PointCloud& scan, const PreparedTarget& cad,
                      const InspectSettings& settings) {
  return run(scan, cad, settings);
}

}  // namespace align3d
