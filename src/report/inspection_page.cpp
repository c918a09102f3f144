// The inspection's page and figures (inspection_page.hpp).
#include "align3d/report/inspection_page.hpp"

#include <stdlib.h>  // mkdtemp (POSIX)

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/icp/termination.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/report/histogram.hpp"
#include "align3d/report/html.hpp"
#include "align3d/report/render.hpp"
#include "align3d/report/views_figure.hpp"

namespace align3d::report {
namespace {

namespace fs = std::filesystem;

constexpr const char* kViewsPng = "views.png";
constexpr const char* kHistogramStem = "histogram";

bool measured(const InspectResult& r) { return r.registration.success; }

void check_map(const InspectResult& r, const PointCloud& scan) {
  if (r.map.deviation.size() != scan.size()) {
    throw std::invalid_argument("inspection page: the deviation map has " +
                                std::to_string(r.map.deviation.size()) + " values for " +
                                std::to_string(scan.size()) + " scan points");
  }
}

// A folder of its own under the system's temporary folder, removed with everything in it.
class ScratchFolder {
 public:
  explicit ScratchFolder(const fs::path& destination) {
    std::error_code ec;
    std::string name = (fs::temp_directory_path(ec) / "align3d-inspection-XXXXXX").string();
    if (ec || mkdtemp(name.data()) == nullptr) {
      throw OutputError(destination, "cannot write: no temporary folder for the figures");
    }
    path_ = name;
  }
  ~ScratchFolder() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string esc(const std::string& s) { return html_escape(s); }

// Rounded first, so that a tiny negative value prints as 0, not −0.
std::string fixed(double v, int decimals) {
  const double scale = std::pow(10.0, decimals);
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, std::round(v * scale) / scale + 0.0);
  return buffer;
}

// A share as a percentage with two decimals, truncated rather than rounded: a part with one point
// out of a million outside the band reads 99.99 %, never 100.00 %.
std::string percent(double share) {
  return fixed(std::floor(share * 10000 + 1e-9) / 100, 2) + "\u2009%";
}

std::string band_text(const Tolerance& band, const std::string& units) {
  return band_value(band.lower, "") + " \u2026 " + band_value(band.upper, units);
}

std::string row(const std::string& label, const std::string& value) {
  return "<tr><th scope=row style=\"text-align:left;font-weight:normal\">" + esc(label) +
         "</th><td class=n>" + esc(value) + "</td></tr>\n";
}

// Tables side by side (wrapping on a narrow window), each under its caption.
std::string side_by_side(const std::vector<std::pair<std::string, std::string>>& tables) {
  std::string out =
      "<div style=\"display:flex;flex-wrap:wrap;gap:1em 2.5em;align-items:flex-start\">";
  for (const auto& [caption, rows] : tables) {
    out += "<table><caption style=\"text-align:left;font-weight:bold;padding:4px 0\">" +
           esc(caption) + "</caption>\n" + rows + "</table>\n";
  }
  return out + "</div>\n";
}

std::string verdict_html(const InspectResult& r, const InspectionPageInfo& info) {
  const std::string colour = r.pass ? "#1a7f37" : "#c62828";
  std::string detail;
  if (!measured(r)) {
    detail = "the scan could not be registered onto the CAD model (" + r.registration.failure +
             "): nothing was measured";
  } else {
    const std::size_t inliers = r.within + r.below + r.above;
    detail = percent(r.within_tolerance) + " of " + format_count(inliers) +
             " measured points lie within the tolerance band " +
             band_text(r.tolerance, info.units) + " (" + format_count(r.below) + " below, " +
             format_count(r.above) + " above)";
  }
  return "<div style=\"background:" + colour +
         ";color:#fff;padding:14px 20px;border-radius:6px;margin:1.5em 0\">"
         "<span style=\"font-size:2em;font-weight:bold;letter-spacing:0.05em\">" +
         std::string(r.pass ? "PASS" : "FAIL") + "</span><span style=\"font-size:1.15em\">" +
         " &nbsp;" + esc(detail) + "</span></div>\n";
}

std::string inputs_html(const InspectResult& r, const PointCloud& scan,
                        const InspectionPageInfo& info) {
  return "<p>Scan <b>" + esc(info.scan_name) + "</b> (" + esc(format_count(scan.size())) +
         " points) against the CAD model <b>" + esc(info.cad_name) + "</b> (" +
         esc(format_count(r.mesh.triangles)) + " triangles)" +
         (info.units.empty() ? "" : "; units: " + esc(info.units)) + ".</p>\n";
}

std::string figures_html(const fs::path& dir, const InspectResult& r,
                         const InspectionPageInfo& info) {
  const std::string band = band_text(r.tolerance, info.units);
  return "<h2>Deviation from the CAD model</h2>\n" +
         html_figure(dir / kViewsPng,
                     "The scan in the CAD frame, each point coloured by its signed deviation from "
                     "the surface (+ outside the material), over the CAD model (shaded grey where "
                     "nothing was measured); band " +
                         band +
                         ". A pixel shows the mean deviation of the points drawn on it; points "
                         "farther than the outlier distance are grey.") +
         html_figure(dir / (std::string(kHistogramStem) + ".png"),
                     "The deviations of the measured points (outliers left out), each bar in the "
                     "colour of its centre, the tolerance band shaded, and the robust Gauss fit "
                     "(median and 1.4826 \u00d7 MAD) scaled to the counts.");
}

std::string stats_html(const InspectResult& r, const InspectionPageInfo& info) {
  const Tolerance& b = r.tolerance;
  const std::string& u = info.units;
  const DeviationStats& s = r.stats;
  std::string moments = row("measured points", format_count(s.count));
  moments += row("mean", format_deviation(s.mean, b, u));
  moments += row("standard deviation", format_deviation(s.std, b, u, false));
  moments += row("RMS", format_deviation(s.rms, b, u, false));
  moments += row("minimum", format_deviation(s.min, b, u));
  moments += row("maximum", format_deviation(s.max, b, u));
  moments += row("Gauss fit mean", format_deviation(r.gauss.mean, b, u));
  moments += row("Gauss fit \u03c3", format_deviation(r.gauss.sigma, b, u, false));
  std::string percentiles = row("1st", format_deviation(s.p01, b, u));
  percentiles += row("5th", format_deviation(s.p05, b, u));
  percentiles += row("50th (median)", format_deviation(s.p50, b, u));
  percentiles += row("95th", format_deviation(s.p95, b, u));
  percentiles += row("99th", format_deviation(s.p99, b, u));
  std::string counts = row("tolerance band", band_text(b, u));
  counts += row("below the band", format_count(r.below));
  counts += row("within the band", format_count(r.within));
  counts += row("above the band", format_count(r.above));
  counts += row("within tolerance", percent(r.within_tolerance));
  counts += row("outliers (left out)", format_count(r.map.outliers));
  counts += row("outlier distance", format_deviation(r.map.max_distance, b, u, false));
  return "<h2>Statistics</h2>\n" +
         side_by_side(
             {{"Deviations", moments}, {"Percentiles", percentiles}, {"Against the band", counts}});
}

std::string matrix_html(const Eigen::Isometry3d& T) {
  std::string out = "<table>\n";
  for (int i = 0; i < 4; ++i) {
    out += "<tr>";
    for (int j = 0; j < 4; ++j) {
      out += "<td class=n>" + fixed(T.matrix()(i, j), 6) + "</td>";
    }
    out += "</tr>\n";
  }
  return out + "</table>\n";
}

// The registration's table and the transformation, scan → CAD.
std::string registration_html(const InspectResult& r, const std::string& units) {
  const AlignResult& a = r.registration;
  std::string t;
  t += row("result", a.success ? "registered" : "failed: " + a.failure);
  t += row("answer kept", a.path.empty() ? "\u2013" : a.path);
  if (!a.reason.empty()) t += row("global stage ran because", a.reason);
  t += row("ICP iterations", std::to_string(a.refine.total_iterations));
  t += row("ICP stopped", std::string(to_string(a.refine.icp.stop_reason)) +
                              (a.refine.icp.converged ? " (converged)" : " (not converged)"));
  t += row("RMS of the kept pairs", format_deviation(a.refine.icp.rms, r.tolerance, units, false));
  t += row("support overlap", percent(a.support.overlap));
  return t;
}

std::string mesh_html(const InspectResult& r, const std::string& units) {
  const MeshTopology& m = r.mesh;
  const MeshRepair& f = r.repair;
  std::string t;
  t += row("triangles", format_count(m.triangles));
  t += row("vertices", format_count(m.vertices));
  t += row("closed", m.closed() ? "yes"
                                : "no (" + format_count(m.boundary_edges) + " boundary, " +
                                      format_count(m.non_manifold_edges) + " non-manifold edges)");
  t += row("connected pieces", format_count(m.components));
  if (m.closed())
    t += row("volume", fixed(m.signed_volume, 1) + (units.empty() ? "" : " " + units + "\u00b3"));
  t += row("re-wound triangles", format_count(f.flipped_triangles));
  t += row("pieces turned outward", format_count(f.inverted_components));
  t += row("welded vertices", format_count(f.welded_vertices));
  t += row("dropped triangles (zero area)", format_count(f.dropped_triangles));
  return t;
}

// The page's body; `figures` is the folder holding the figures when something was measured.
std::string body_html(const fs::path& figures, const InspectResult& r, const PointCloud& scan,
                      const InspectionPageInfo& info) {
  std::string body = "<h1>" + esc(info.title) + "</h1>\n" + inputs_html(r, scan, info) +
                     verdict_html(r, info) + html_warnings(r.warnings);
  if (measured(r)) body += figures_html(figures, r, info) + stats_html(r, info);
  return body + "<h2>Registration and CAD model</h2>\n" +
         side_by_side({{"Registration", registration_html(r, info.units)},
                       {"CAD mesh check", mesh_html(r, info.units)}}) +
         "<p>The transformation, scan \u2192 CAD (CAD \u2248 T \u00b7 scan):</p>\n" +
         matrix_html(r.registration.transformation);
}

DeviationPoints deviation_points(const InspectResult& r, const PointCloud& scan) {
  DeviationPoints p;
  p.positions = scan.positions;
  p.deviation = r.map.deviation;
  p.T_mesh_points = r.registration.transformation;
  p.band = r.tolerance;
  p.depth_tolerance = r.map.max_distance;
  return p;
}

}  // namespace

void write_inspection_figures(const fs::path& dir, const InspectResult& result,
                              const PointCloud& scan, const TriangleMesh& cad,
                              const InspectionPageInfo& info) {
  if (!measured(result)) {
    throw std::invalid_argument(
        "inspection figures: nothing was measured (the registration "
        "failed)");
  }
  check_map(result, scan);
  ViewsFigureSettings views;
  views.units = info.units;
  write_views_figure(cad, deviation_points(result, scan), dir / kViewsPng, views);
  HistogramFigureSettings histogram;
  histogram.units = info.units;
  write_deviation_histogram(result.histogram, result.gauss, result.tolerance, result.map.outliers,
                            dir / kHistogramStem, histogram);
}

void write_inspection_page(const fs::path& page, const InspectResult& result,
                           const PointCloud& scan, const TriangleMesh& cad,
                           const InspectionPageInfo& info) {
  if (measured(result)) check_map(result, scan);
  // Fail before drawing anything when the page cannot land.
  const fs::path folder = page.has_parent_path() ? page.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw OutputError(page, "cannot write: the folder " + folder.string() + " does not exist");
  }
  const ScratchFolder scratch(page);
  if (measured(result)) {
    try {
      write_inspection_figures(scratch.path(), result, scan, cad, info);
    } catch (const OutputError& e) {  // name the page, not the scratch file
      throw OutputError(page, std::string("cannot write a figure: ") + e.what());
    }
  }
  io::write_text_atomically(page,
                            html_page(info.title, body_html(scratch.path(), result, scan, info)));
}

}  // namespace align3d::report
