// align3d inspect SCAN CAD: inspect() (inspect.hpp) from the command line (README, "Inspect a
// part"; the report's keys: docs/report.md, "inspect").
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>

#include "align3d/error.hpp"
#include "align3d/inspect.hpp"
#include "align3d/report/deviation_files.hpp"
#include "common.hpp"
#include "detail/number.hpp"

namespace align3d::cli {
namespace {

struct InspectOptions {
  std::string scan, cad, tolerance;
  std::string init = to_string(AlignSettings{}.init);
  std::string report, output, html, figures, csv, histogram, units;
  io::MeshReadSettings mesh;
  RefineOptions refine;
  bool strict = false, quiet = false;
  InspectSettings settings;
};

// --tolerance T (the band ±T) or LOWER,UPPER (e.g. -0.05,+0.2), lower <= 0 <= upper.
Tolerance parse_tolerance(const std::string& text) {
  const std::size_t comma = text.find(',');
  const auto bad = [&](const std::string& why) {
    return UsageError("--tolerance: " + why + ", got '" + text +
                      "' (expected T for ±T, or "
                      "LOWER,UPPER such as -0.05,+0.2)");
  };
  if (comma == std::string::npos) {
    const std::optional<double> t = detail::parse_finite(text);
    if (!t || !(*t > 0)) throw bad("a symmetric tolerance must be a finite number > 0");
    return {-*t, *t};
  }
  const std::optional<double> lo = detail::parse_finite(text.substr(0, comma));
  const std::optional<double> hi = detail::parse_finite(text.substr(comma + 1));
  if (!lo || !hi) throw bad("two finite numbers separated by a comma");
  if (!(*lo <= 0 && *hi >= 0 && *lo < *hi)) throw bad("the band must hold 0 and be wide");
  return {*lo, *hi};
}

std::string fixed(double v, int digits = 4, bool sign = true) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, sign ? "%+.*f" : "%.*f", digits, v);
  return buffer;
}

std::string percent(double part, double whole) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.2f %%", whole > 0 ? 100 * part / whole : 0.0);
  return buffer;
}

// The histogram as text, 16 rows of merged bins, for a report without a GUI.
void print_histogram(std::ostream& out, const InspectResult& r) {
  const Histogram& h = r.histogram;
  constexpr std::size_t kRows = 16;
  const std::size_t merge = (h.counts.size() + kRows - 1) / kRows;
  std::vector<std::size_t> rows;
  for (std::size_t k = 0; k < h.counts.size(); k += merge) {
    std::size_t sum = 0;
    for (std::size_t j = k; j < std::min(h.counts.size(), k + merge); ++j) sum += h.counts[j];
    rows.push_back(sum);
  }
  const std::size_t peak = std::max<std::size_t>(1, *std::max_element(rows.begin(), rows.end()));
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const double lo = h.lo + h.width() * static_cast<double>(k * merge);
    const double hi = std::min(h.hi, lo + h.width() * static_cast<double>(merge));
    const bool inside = lo >= r.tolerance.lower && hi <= r.tolerance.upper;
    out << "    [" << fixed(lo) << ", " << fixed(hi) << ") " << (inside ? ' ' : '!') << ' '
        << std::string(40 * rows[k] / peak, '#') << ' ' << rows[k] << "\n";
  }
}

void print_summary(std::ostream& out, const InspectOptions& o, const InspectResult& r,
                   std::size_t points, std::size_t triangles) {
  const DeviationStats& d = r.stats;
  const AlignResult& a = r.registration;
  out << "inspected " << o.scan << " (" << points << " points) against " << o.cad << " ("
      << triangles << " triangles)\n";
  out << "  registration: the " << a.path << " answer, rms " << std::setprecision(4)
      << a.refine.icp.rms << ", " << std::setprecision(3) << 100 * a.support.overlap << " % of the "
      << to_string(a.support.object) << " on the other's surface\n";
  out << "  tolerance [" << fixed(r.tolerance.lower) << ", " << fixed(r.tolerance.upper)
      << "], outliers (farther than " << std::setprecision(4) << r.map.max_distance
      << "): " << r.map.outliers << " (" << percent(r.map.outliers, points) << ")\n";
  out << "  deviation of " << d.count << " points: mean " << fixed(d.mean) << ", std "
      << fixed(d.std, 4, false) << ", rms " << fixed(d.rms, 4, false) << ", min " << fixed(d.min)
      << ", max " << fixed(d.max) << "\n";
  out << "  percentiles: 1 % " << fixed(d.p01) << ", 5 % " << fixed(d.p05) << ", 50 % "
      << fixed(d.p50) << ", 95 % " << fixed(d.p95) << ", 99 % " << fixed(d.p99) << "\n";
  out << "  Gauss fit (median, 1.4826 MAD): mean " << fixed(r.gauss.mean) << ", sigma "
      << fixed(r.gauss.sigma, 4, false) << "\n";
  const auto inliers = static_cast<double>(d.count);
  out << "  below " << r.below << " (" << percent(r.below, inliers) << "), within " << r.within
      << " (" << percent(r.within, inliers) << "), above " << r.above << " ("
      << percent(r.above, inliers) << ")\n";
  if (d.count > 0) print_histogram(out, r);
  out << "  verdict: " << (r.pass ? "PASS" : "FAIL") << " (" << percent(r.within, inliers)
      << " within tolerance, " << percent(o.settings.pass_fraction, 1) << " required)\n";
}

// A DataError about "source" or "target" names the file instead.
[[noreturn]] void rethrow_naming_files(const DataError& e, const InspectOptions& o) {
  if (e.subject() == "source") throw DataError(o.scan + " (scan)", e.problem());
  if (e.subject() == "target") throw DataError(o.cad + " (CAD)", e.problem());
  throw e;
}

int run_inspect(InspectOptions& o, Streams io) {
  InspectSettings s = o.settings;
  s.tolerance = parse_tolerance(o.tolerance);
  apply_init(o.init, s.align);
  apply_refine_options(o.refine, s.align.refine);
  const auto start_read = std::chrono::steady_clock::now();
  const PointCloud scan = load_cloud(o.scan, io.err);
  io::MeshReadInfo mesh_info;
  const TriangleMesh cad = load_mesh(o.cad, io.err, o.mesh, &mesh_info);
  const double read_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_read)
          .count();
  ProgressLine progress(io.err, o.quiet, "inspect");
  s.align.progress = progress.callback();
  InspectResult r;
  try {
    r = inspect(scan, cad, s);
  } catch (const DataError& e) {
    rethrow_naming_files(e, o);
  }
  if (mesh_info.chord_tolerance > 0.1 * (s.tolerance.upper - s.tolerance.lower))
    r.warnings.push_back({"coarse_tessellation",
                          "the CAD surface was tessellated to a chord tolerance of " +
                              fixed(mesh_info.chord_tolerance, 6) +
                              ", more than a tenth of the tolerance band: deviations carry that "
                              "error (--chord-tolerance)"});
  // The CAD model as measured: welded and cleaned (as the package reports it, from an index).
  const TriangleMesh& measured = r.surface->mesh();
  nlohmann::json report = report::inspection_report(
      r, s, {o.scan, scan.size()}, {o.cad, measured.vertices.size(), measured.triangles.size()});
  report["timing_ms"]["read"] = read_ms;
  if (mesh_info.chord_tolerance > 0) report["mesh"]["chord_tolerance"] = mesh_info.chord_tolerance;
  report::write_inspection_outputs(
      {o.output, o.csv, o.histogram, o.html, o.figures, o.scan, o.cad, o.units}, scan, r);
  if (!o.report.empty()) write_json(o.report, report, io.out);
  if (!r.registration.success) {
    report_warnings(r.warnings, false, io.err);
    throw Error(ExitCode::kNoSolution, o.scan + ": no solution: " + r.registration.failure);
  }
  if (o.report != "-" && !o.quiet) print_summary(io.out, o, r, scan.size(), cad.triangles.size());
  const int code = report_warnings(r.warnings, o.strict, io.err);
  return r.pass ? code : static_cast<int>(ExitCode::kRejected);
}

}  // namespace

Command add_inspect(CLI::App& app, Streams io) {
  auto o = std::make_shared<InspectOptions>();
  InspectSettings& s = o->settings;
  CLI::App* sub = app.add_subcommand(
      "inspect",
      "Inspect a measured part against its CAD model: register SCAN onto the exact surface of CAD\n"
      "(a best fit that local dents and bumps do not pull), then measure every scan point's "
      "signed\n"
      "deviation (+ outside the material, - inside) and judge it against --tolerance. Points\n"
      "farther than --max-distance from every surface (fixtures, clamps, background) are "
      "outliers,\n"
      "counted apart. Prints the statistics, a histogram and the verdict; exit code 9 when the "
      "part\n"
      "fails (every output is written first).");
  sub->add_option("SCAN", o->scan, "The measured part (.ply .pcd .xyz .txt .csv)")->required();
  sub->add_option("CAD", o->cad,
                  "Its CAD model, a mesh (.stl .obj .off, .ply with faces, .step .stp .iges .igs)")
      ->required();
  sub->add_option("--tolerance", o->tolerance,
                  "The band: T for ±T, or LOWER,UPPER (e.g. -0.05,+0.2), in data units")
      ->required();
  add_init(sub, o->init, "a file with a 4x4 matrix (scan → CAD; ICP starts there)");
  add_refine_options(sub, o->refine, schedule_refine_help());
  sub->add_option("--max-distance", s.max_distance,
                  "Points farther than this from every surface are outliers (data units); 0: the "
                  "larger of 5 x the band's larger half and 1 % of the CAD model's diagonal")
      ->check(finite_non_negative())
      ->capture_default_str();
  sub->add_option("--pass-fraction", s.pass_fraction,
                  "The part passes when at least this share of the measured points is within "
                  "the band (1: every one)")
      ->check(CLI::Range(1e-9, 1.0))
      ->capture_default_str();
  sub->add_option("--report", o->report, "Write the JSON report to FILE, or to stdout with -");
  sub->add_option("--output", o->output,
                  "Write the scan in the CAD frame with a `deviation` property and colours (PLY)");
  sub->add_option("--csv", o->csv,
                  "Write every point's deviation and its closest CAD point as CSV, in scan order");
  sub->add_option("--histogram", o->histogram,
                  "Write the histogram and the Gauss fit's expected counts as CSV");
  sub->add_option("--html", o->html, "Write an offline HTML page: views, histogram, statistics");
  sub->add_option("--figures", o->figures,
                  "Write views.png (four colour-mapped views) and histogram.png/.svg into DIR");
  sub->add_option("--units", o->units, "Unit label for the page and figures (e.g. mm); a label");
  sub->add_option("--chord-tolerance", o->mesh.chord_tolerance,
                  "STEP/IGES: tessellation chord tolerance (data units); 0: 1e-4 x the diagonal")
      ->check(finite_non_negative())
      ->capture_default_str();
  add_seed(sub, s.align.seed);
  add_strict(sub, o->strict);
  add_quiet(sub, o->quiet);
  add_threads(sub, s.threads);
  return {sub, [o, io] { return run_inspect(*o, io); }};
}

}  // namespace align3d::cli
