// The stitch's merged PLY, page and outputs (stitch_files.hpp).
#include "align3d/report/stitch_files.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "align3d/io/atomic_file.hpp"
#include "align3d/io/ply_attributes.hpp"
#include "align3d/report/html.hpp"
#include "align3d/report/stitch_figure.hpp"
#include "align3d/report/views_figure.hpp"  // format_count
#include "align3d/se3.hpp"

namespace align3d::report {
namespace {

// Four significant digits, a typographic minus; NaN (nothing measured) as "–".
std::string num(double v, const char* format = "%.4g") {
  if (std::isnan(v)) return "\u2013";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v + 0.0);
  std::string s = buffer;
  if (!s.empty() && s[0] == '-') s.replace(0, 1, "\u2212");
  return s;
}

std::string rounded_percent(double share) { return num(100 * share, "%.1f") + "\u2009%"; }

std::string file_of(const StitchPageInfo& info, std::size_t k) {
  return k < info.files.size() && !info.files[k].empty() ? info.files[k]
                                                         : "scan " + std::to_string(k);
}

std::string cell(const std::string& text, bool number = false) {
  return (number ? "<td class=n>" : "<td>") + html_escape(text) + "</td>";
}

// "a, b, c".
std::string comma_list(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

std::string header(std::initializer_list<const char*> names) {
  std::string out = "<tr>";
  for (const char* n : names) out += "<th>" + html_escape(n) + "</th>";
  return out + "</tr>\n";
}

std::string summary_html(const StitchResult& r, const StitchPageInfo& info) {
  std::size_t connected = 0, kept = 0;
  for (const StitchScan& s : r.scans) connected += s.connected ? 1 : 0;
  for (const StitchEdge& e : r.edges) kept += e.kept ? 1 : 0;
  const std::string u = info.units.empty() ? "" : " " + info.units;
  return "<p>" + format_count(r.scans.size()) + " scans into the frame of the first, <b>" +
         html_escape(file_of(info, 0)) + "</b>: " + format_count(connected) + " connected, " +
         format_count(r.edges.size()) + " overlapping pairs found, " + format_count(kept) +
         " kept. The merged cloud holds " + format_count(r.merged.size()) + " points (voxel " +
         num(r.voxel) + html_escape(u) + "); the object's diameter is " + num(r.diameter) +
         html_escape(u) +
         ". Each pose maps its scan into the first scan's frame (scan\u2080 \u2248 T\u00b7scan); "
         "an "
         "edge's maps its source scan into its target's frame (target \u2248 T\u00b7source).</p>\n";
}

std::string poses_html(const StitchResult& r, const StitchPageInfo& info) {
  std::string t = "<h2>Poses</h2>\n<table>\n" +
                  header({"#", "file", "sensor", "connected", "points", "kept edges",
                          "rotation (\u00b0)", "translation (x, y, z)", "residual pairs",
                          "residual RMS", "residual p95", "warnings"});
  for (std::size_t k = 0; k < r.scans.size(); ++k) {
    const StitchScan& s = r.scans[k];
    const Eigen::Vector3d p = s.transformation.translation();
    // The codes of the warnings that name this scan: with any, its pose may be wrong.
    const std::string warnings = comma_list(s.warnings);
    // Where the scan's sensor position came from: its file or --viewpoint (given), estimated from
    // the scan, or the origin taken for want of either (stitch.hpp, SensorSource).
    t += "<tr>" + cell(std::to_string(k), true) + cell(file_of(info, k)) +
         cell(std::string(to_string(s.sensor))) + "<td" +
         (s.connected ? ">yes" : " class=warn>no") + "</td>" + cell(format_count(s.points), true) +
         cell(std::to_string(s.edges), true) +
         cell(num(rad_to_deg(rotation_angle(s.transformation.linear())), "%.3f"), true) +
         cell(num(p.x()) + ", " + num(p.y()) + ", " + num(p.z()), true) +
         cell(format_count(s.pairs), true) + cell(num(s.rms), true) + cell(num(s.p95), true) +
         (warnings.empty() ? "<td></td>" : "<td class=warn>" + html_escape(warnings) + "</td>") +
         "</tr>\n";
  }
  return t + "</table>\n";
}

std::string edges_html(const StitchResult& r) {
  if (r.edges.empty()) return "<h2>Edges</h2>\n<p>No two scans overlap.</p>\n";
  std::string t = "<h2>Edges</h2>\n<table>\n" +
                  header({"source", "target", "overlap", "RMS", "status",
                          "rotation residual (\u00b0)", "translation residual", "warnings"});
  for (const StitchEdge& e : r.edges) {
    std::vector<std::string> codes;
    for (const Warning& w : e.warnings) codes.push_back(w.code);
    const std::string warnings = comma_list(codes);
    t += "<tr>" + cell(std::to_string(e.source), true) + cell(std::to_string(e.target), true) +
         cell(rounded_percent(e.overlap), true) + cell(num(e.rms), true) + "<td" +
         (e.kept ? ">kept" : " class=warn>" + html_escape(e.status)) + "</td>" +
         cell(num(e.rotation_residual_deg, "%.3f"), true) +
         cell(num(e.translation_residual), true) + cell(warnings) + "</tr>\n";
  }
  return t + "</table>\n";
}

std::string timings_html(const StitchResult& r) {
  const StitchTimings& t = r.timings;
  const std::pair<const char*, double> rows[] = {
      {"pairs (coarse)", t.pairs_ms},     {"edges (ICP)", t.edges_ms}, {"pose graph", t.graph_ms},
      {"multi-view ICP", t.multiview_ms}, {"merge", t.merge_ms},       {"total", t.total_ms}};
  std::string out = "<h2>Timings</h2>\n<table>\n";
  for (const auto& [name, ms] : rows)
    out += "<tr><th scope=row style=\"text-align:left;font-weight:normal\">" + html_escape(name) +
           "</th>" + cell(num(ms, "%.0f") + " ms", true) + "</tr>\n";
  return out + "</table>\n<p>Multi-view ICP iterations: " + std::to_string(r.multiview_iterations) +
         ".</p>\n";
}

StitchFigureSettings figure_settings(const StitchPageInfo& info) {
  StitchFigureSettings s;
  for (const std::string& f : info.files)
    s.names.push_back(f.empty() ? "" : std::filesystem::path(f).filename().string());
  s.units = info.units;
  return s;
}

}  // namespace

void write_merged_ply(const std::filesystem::path& path, const StitchResult& r, bool scan_index) {
  if (r.merged_scan.size() != r.merged.size())
    throw std::invalid_argument("merged PLY: " + std::to_string(r.merged_scan.size()) +
                                " scan indices for " + std::to_string(r.merged.size()) +
                                " merged points");
  io::PlyAttributes a;
  a.normals = r.merged.normals;
  if (scan_index) a.ints.emplace_back("scan", r.merged_scan);
  io::write_ply(path, r.merged.positions, a);
}

void write_stitch_page(const std::filesystem::path& page, const StitchResult& r,
                       const StitchPageInfo& info) {
  const std::string png = stitch_figure_png(r, figure_settings(info));
  const std::string body =
      "<h1>" + html_escape(info.title) + "</h1>\n" + summary_html(r, info) +
      html_warnings(r.warnings) +
      html_figure_png(png, "stitch",
                      "The merged cloud from above (looking down \u2212z) and from the front "
                      "(looking along +y), at one scale, each point in the colour of the scan it "
                      "came from; nearer points cover farther ones.") +
      poses_html(r, info) + edges_html(r) + timings_html(r);
  io::write_text_atomically(page, html_page(info.title, body));
}

DataError naming_scan_file(const DataError& e, const std::vector<std::string>& files) {
  const std::string& subject = e.subject();
  std::size_t k = 0;
  const char* last = subject.data() + subject.size();
  if (subject.rfind("scan ", 0) == 0 && std::from_chars(subject.data() + 5, last, k).ptr == last &&
      k < files.size() && !files[k].empty())
    return DataError(files[k], e.problem());
  return e;
}

void write_stitch_outputs(const StitchOutputs& o, const StitchResult& r) {
  if (!o.merged.empty()) write_merged_ply(o.merged, r, o.scan_index);
  if (!o.figure.empty()) write_stitch_figure(r, o.figure, figure_settings(o.info));
  if (!o.html.empty()) write_stitch_page(o.html, r, o.info);
}

}  // namespace align3d::report
