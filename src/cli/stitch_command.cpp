// align3d stitch SCAN...: stitch() (stitch.hpp) from the command line (README, "Stitch scans"; the
// report's keys: docs/report.md, "stitch").
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/report/stitch_files.hpp"
#include "align3d/stitch.hpp"
#include "common.hpp"
#include "detail/number.hpp"

namespace align3d::cli {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxListBytes = std::size_t{16} << 20;
constexpr std::size_t kMaxListLine = 4096;

struct StitchOptions {
  std::vector<std::string> scans;
  std::string list, report, output, figure, html, viewpoint, viewpoints;
  bool no_scan_index = false, strict = false, quiet = false;
  StitchSettings settings;
  RefineOptions refine;
};

std::string trimmed(const std::string& line) {
  const std::size_t first = line.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return line.substr(first, line.find_last_not_of(" \t\r") + 1 - first);
}

// The lines of a small text file given to the command (--list, --viewpoints), trimmed, with their
// numbers; blank lines and lines starting with '#' skipped. A file that is not text (a NUL byte, a
// line longer than a path can be, more than 16 MiB) is an input error naming it and the line.
struct TextLine {
  std::size_t number = 0;
  std::string text;
};

std::vector<TextLine> read_lines(const std::string& file, const std::string& what) {
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw IoError(file, "a folder, not " + what);
  std::ifstream in(file, std::ios::binary);
  if (!in) throw IoError(file, "cannot open " + what);
  const std::uintmax_t size = fs::file_size(file, ec);
  if (!ec && size > kMaxListBytes) throw IoError(file, "larger than 16 MiB: not " + what);
  std::vector<TextLine> lines;
  std::string line;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    const std::string where = "line " + std::to_string(n) + ": ";
    if (line.find('\0') != std::string::npos)
      throw IoError(file, where + "a NUL byte: not " + what);
    if (line.size() > kMaxListLine)
      throw IoError(file, where + "longer than " + std::to_string(kMaxListLine) + " bytes");
    std::string entry = trimmed(line);
    if (!entry.empty() && entry[0] != '#') lines.push_back({n, std::move(entry)});
  }
  if (in.bad()) throw IoError(file, "cannot read " + what);
  return lines;
}

// --list FILE: one scan a line, a relative path relative to FILE's folder.
std::vector<std::string> read_list(const std::string& list) {
  if (list.empty()) return {};
  const fs::path folder = fs::path(list).parent_path();
  std::vector<std::string> files;
  for (const TextLine& line : read_lines(list, "a list of scans (one file a line)")) {
    const fs::path path(line.text);
    files.push_back(path.is_relative() ? (folder / path).string() : line.text);
  }
  return files;
}

// A line of --viewpoints: three finite numbers separated by spaces, tabs or commas; nullopt
// otherwise.
std::optional<Eigen::Vector3d> parse_point(const std::string& text) {
  std::string spaced = text;
  std::replace(spaced.begin(), spaced.end(), ',', ' ');
  std::istringstream words(spaced);
  std::vector<std::string> w{std::istream_iterator<std::string>(words), {}};
  if (w.size() != 3) return std::nullopt;
  Eigen::Vector3d p;
  for (int i = 0; i < 3; ++i) {
    const std::optional<double> v = detail::parse_finite(w[static_cast<std::size_t>(i)]);
    if (!v) return std::nullopt;
    p[i] = *v;
  }
  return p;
}

// --viewpoints FILE: one line per scan in input order, "X Y Z" (its sensor in its own frame) or
// "auto" (not known: the file's, else the origin or an estimate).
std::vector<std::optional<Eigen::Vector3d>> read_viewpoints(const std::string& file,
                                                            std::size_t scans) {
  std::vector<std::optional<Eigen::Vector3d>> out;
  for (const TextLine& line : read_lines(file, "a list of viewpoints (X Y Z or auto a line)")) {
    std::optional<Eigen::Vector3d> p = parse_point(line.text);
    if (!p && line.text != "auto")
      throw IoError(file, "line " + std::to_string(line.number) +
                              ": expected 3 finite numbers (X Y Z) or 'auto'");
    out.push_back(p);
  }
  if (out.size() != scans)
    throw IoError(file, std::to_string(out.size()) + " viewpoints for " + std::to_string(scans) +
                            " scans (one line per scan, in input order)");
  return out;
}

// The scans with each one's sensor position where its file gives one (io::sensor_position).
struct Scans {
  std::vector<PointCloud> clouds;
  std::vector<report::InputInfo> inputs;
  std::vector<std::optional<Eigen::Vector3d>> viewpoints;
};

Scans load_scans(const std::vector<std::string>& files, Streams io, ProgressLine& progress) {
  Scans s;
  const ProgressCallback show = progress.callback();
  for (std::size_t k = 0; k < files.size(); ++k) {
    if (show) show({"reading scans", k, files.size()});
    io::ReadInfo info;
    s.clouds.push_back(load_cloud(files[k], io.err, &info));
    s.inputs.push_back({files[k], s.clouds.back().size(), 0});
    s.viewpoints.push_back(io::sensor_position(info));
  }
  return s;
}

void print_summary(std::ostream& out, const std::vector<std::string>& files,
                   const StitchResult& r) {
  std::size_t connected = 0, kept = 0, sensors[3] = {0, 0, 0};
  for (const StitchScan& s : r.scans) {
    connected += s.connected ? 1 : 0;
    ++sensors[static_cast<int>(s.sensor)];
  }
  for (const StitchEdge& e : r.edges) kept += e.kept ? 1 : 0;
  out << "stitched " << r.scans.size() << " scans into the frame of " << files.front() << ": "
      << connected << " connected, " << r.edges.size() << " overlapping pairs (" << kept
      << " kept); merged " << r.merged.size() << " points (voxel " << std::setprecision(4)
      << r.voxel << ", diameter " << r.diameter << "; " << std::setprecision(3)
      << r.timings.total_ms / 1000 << " s)\n";
  out << "sensor positions: " << sensors[static_cast<int>(SensorSource::kGiven)] << " given, "
      << sensors[static_cast<int>(SensorSource::kEstimated)] << " estimated from the scan, "
      << sensors[static_cast<int>(SensorSource::kOrigin)] << " taken at the origin\n";
  for (std::size_t k = 0; k < r.scans.size(); ++k) {
    const StitchScan& s = r.scans[k];
    const Eigen::Vector3d t = s.transformation.translation();
    char line[200];
    std::snprintf(line, sizeof line,
                  "  %2zu  %-13s edges %zu  rms %.3g  p95 %.3g  rotation %.2f deg  at (%.4g, "
                  "%.4g, %.4g)  ",
                  k, s.connected ? "connected" : "NOT CONNECTED", s.edges, s.rms, s.p95,
                  rad_to_deg(rotation_angle(s.transformation.linear())), t.x(), t.y(), t.z());
    out << line << files[k] << "\n";
  }
}

int run_stitch(StitchOptions& o, Streams io) {
  std::vector<std::string> files = o.scans;
  for (std::string& f : read_list(o.list)) files.push_back(std::move(f));
  if (files.size() < 2)
    throw UsageError("stitch: needs at least two scans (SCAN... or --list FILE), got " +
                     std::to_string(files.size()) + " (see align3d stitch --help)");
  // The sensors given on the command line, checked before any scan is read.
  std::vector<std::optional<Eigen::Vector3d>> given(files.size());
  if (!o.viewpoints.empty()) given = read_viewpoints(o.viewpoints, files.size());
  if (!o.viewpoint.empty()) given.assign(files.size(), parse_vector(o.viewpoint, "--viewpoint"));
  ProgressLine progress(io.err, o.quiet, "stitch");
  Scans scans = load_scans(files, io, progress);
  StitchSettings& s = o.settings;
  apply_refine_options(o.refine, s.cost);
  s.viewpoints = scans.viewpoints;
  for (std::size_t k = 0; k < given.size(); ++k)
    if (given[k]) s.viewpoints[k] = given[k];
  s.progress = progress.callback();
  StitchResult r;
  try {
    r = stitch(scans.clouds, s);
  } catch (const DataError& e) {
    throw report::naming_scan_file(e, files);
  } catch (const std::invalid_argument& e) {  // a setting no run can use (the flags' checks pass)
    throw UsageError(std::string("stitch: ") + e.what());
  }
  scans.clouds.clear();  // the merged cloud is what is written
  report::StitchOutputs outputs{o.output, o.figure, o.html, !o.no_scan_index, {}};
  outputs.info.files = files;
  report::write_stitch_outputs(outputs, r);
  if (!o.report.empty())
    write_json(o.report, report::stitch_report(r, s, scans.inputs, o.output, !o.no_scan_index),
               io.out);
  if (o.report != "-" && !o.quiet) print_summary(io.out, files, r);
  const int code = report_warnings(r.warnings, o.strict, io.err);
  for (const StitchScan& scan : r.scans)
    if (!scan.connected) return static_cast<int>(ExitCode::kUnconnected);
  return code;
}

std::string number(double v) {
  std::ostringstream text;
  text << v;
  return text.str();
}

constexpr const char* kStitchHelp =
    "Stitch many scans of one object into one consistent surface in the frame of the first scan:\n"
    "every pair gets a few candidate poses (point pair features and ICP; any order of the scans,\n"
    "no neighbours assumed), each kept when it overlaps enough, fits at the noise and puts "
    "neither\n"
    "scan where the other's sensor saw through (free space); one pose per scan is chosen for the\n"
    "whole set at once (candidates that close loops first; a scan that fits elsewhere as well or\n"
    "better is flagged, ambiguous_scans); the chosen pairs are refined by ICP, a pose graph over\n"
    "them is optimised with a robust loss (edges that disagree with it are pruned), a multi-view\n"
    "ICP spreads the residual over every loop, and the scans are merged into one cloud, one point\n"
    "per voxel, with normals towards each scan's sensor and the scan each point came from.\n"
    "Sensors: --viewpoint, --viewpoints, else a PCD's VIEWPOINT (away from the origin), else the\n"
    "scan's origin unless the scan could not have been seen from there (depth cameras and\n"
    "scanners write their own coordinates), else estimated from the scan (a range scan is one\n"
    "side of its object, seen along the axis its normals face most); the report says which\n"
    "(poses[k].sensor).\n"
    "Last, every two stitched scans are checked against each other's free space: a warning\n"
    "(inconsistent_scans) says when some pose must be wrong. Each scan's warnings are also in\n"
    "its pose's entry of the report.\n"
    "Each pose maps its scan into the first scan's frame (scan_0 ≈ T·scan_k); an edge's maps its\n"
    "source into its target's frame. Prints each scan's pose, connection and residual.\n"
    "Exit codes: 0 ok, 2 usage (fewer than two scans), 3 a scan or the list cannot be read, 4 a\n"
    "scan cannot be used, 5 an output cannot be written, 7 warnings with --strict, 10 some scans\n"
    "overlap no other: the others were stitched and every output written, those left out.";

}  // namespace

Command add_stitch(CLI::App& app, Streams io) {
  auto o = std::make_shared<StitchOptions>();
  StitchSettings& s = o->settings;
  CLI::App* sub = app.add_subcommand("stitch", kStitchHelp);
  sub->add_option("SCAN", o->scans,
                  "The scans (.ply .pcd .xyz .txt .csv), the first the frame of the result");
  sub->add_option("--list", o->list,
                  "A file of scans, one a line (relative to the list's folder; blank lines and "
                  "# comments skipped), after those given as SCAN");
  sub->add_option("--min-overlap", s.min_overlap,
                  "Two scans are an edge when at least this share of the smaller lies on the "
                  "other at their pose")
      ->check(CLI::Range(1e-6, 1.0))
      ->capture_default_str();
  sub->add_option("--voxel", s.voxel,
                  "Voxel of the merged cloud (data units); 0: " + number(kMergeVoxelSpacings) +
                      " x the scans' median point spacing")
      ->check(finite_non_negative())
      ->capture_default_str();
  sub->add_option("--prune-rotation", s.prune_rotation_deg,
                  "Prune an edge disagreeing with the optimised graph by more than this (deg)")
      ->check(CLI::Range(1e-6, 180.0))
      ->capture_default_str();
  sub->add_option("--prune-translation", s.prune_translation,
                  "Prune an edge disagreeing with the optimised graph by more than this share of "
                  "the object's diameter")
      ->check(CLI::Range(1e-9, 1.0))
      ->capture_default_str();
  sub->add_option("--multiview-iterations", s.multiview_iterations,
                  "Cap of the iterations of each of the multi-view ICP's two stages (each stops "
                  "when the poses settle)")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  sub->add_option("--report", o->report, "Write the JSON report to FILE, or to stdout with -");
  sub->add_option("--output", o->output,
                  "Write the merged cloud (PLY: x y z, nx ny nz, int `scan`: the input index of "
                  "the scan each point came from)");
  sub->add_flag("--no-scan-index", o->no_scan_index,
                "Leave the `scan` property out of the merged PLY");
  sub->add_option("--figure", o->figure,
                  "Write the merged cloud from above and from the front, coloured by scan (PNG)");
  sub->add_option("--html", o->html,
                  "Write an offline HTML page: the figure, the poses, the edges, the warnings");
  sub->add_option("--viewpoint", o->viewpoint,
                  "Every scan's sensor position in its own frame, X,Y,Z (data units): for scans "
                  "in their scanner's coordinates whose files carry none")
      ->type_name("X,Y,Z");
  sub->add_option("--viewpoints", o->viewpoints,
                  "A file of sensor positions, one line per scan in input order: X Y Z in that "
                  "scan's frame, or auto (the file's, else the origin or an estimate)")
      ->excludes("--viewpoint");
  add_refine_options(sub, o->refine,
                     {"each chosen pair's refinement and of the multi-view ICP (which runs "
                      "point-to-plane for point-to-point)",
                      "Geman-McClure at half the reach, for the pairs and the multi-view ICP"});
  add_strict(sub, o->strict);
  add_quiet(sub, o->quiet);
  add_threads(sub, s.threads);
  return {sub, [o, io] { return run_stitch(*o, io); }};
}

}  // namespace align3d::cli
