#include "align3d/report/deviation_files.hpp"

#include <cmath>
#include <cstdio>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/ply_attributes.hpp"
#include "align3d/report/colormap.hpp"
#include "align3d/report/inspection_page.hpp"
#include "canvas.hpp"

namespace align3d::report {
namespace {

using detail::to_byte;

// %.9g into `out`; empty for NaN.
void append(std::string& out, double v) {
  if (std::isnan(v)) return;
  char buffer[32];
  const int n = std::snprintf(buffer, sizeof buffer, "%.9g", v);
  out.append(buffer, static_cast<std::size_t>(n));
}

}  // namespace

void write_deviation_ply(const std::filesystem::path& path, const PointCloud& scan,
                         const InspectResult& r) {
  const Eigen::Isometry3d& T = r.registration.transformation;
  std::vector<Eigen::Vector3d> positions(scan.size());
  io::PlyAttributes a;
  a.scalars.push_back({"deviation", std::vector<float>(scan.size())});
  a.colors.resize(scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i) {
    positions[i] = T * scan.positions[i];
    const double d = r.map.deviation[i];
    a.scalars[0].second[i] = static_cast<float>(d);
    const Rgb c = deviation_color(d, r.tolerance);
    a.colors[i] = {to_byte(c[0]), to_byte(c[1]), to_byte(c[2])};
  }
  io::write_ply(path, positions, a);
}

void write_deviation_csv(const std::filesystem::path& path, const PointCloud& scan,
                         const InspectResult& r) {
  const Eigen::Isometry3d& T = r.registration.transformation;
  io::write_atomically(path, [&](std::ostream& out) {
    std::string line = "index,x,y,z,deviation,closest_x,closest_y,closest_z,triangle\n";
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const Eigen::Vector3d p = T * scan.positions[i];
      line += std::to_string(i);
      for (double v : {p.x(), p.y(), p.z(), r.map.deviation[i], r.map.closest[i].x(),
                       r.map.closest[i].y(), r.map.closest[i].z()}) {
        line += ',';
        append(line, v);
      }
      line += ',';
      if (r.map.triangle[i] != kNoTriangle) line += std::to_string(r.map.triangle[i]);
      line += '\n';
      if (line.size() > (1u << 20)) {
        out << line;
        line.clear();
      }
    }
    out << line;
  });
}

void write_histogram_csv(const std::filesystem::path& path, const InspectResult& r) {
  const Histogram& h = r.histogram;
  const double width = h.width();
  const double total = static_cast<double>(r.stats.count);
  std::string text = "bin_lo,bin_hi,count,gauss\n";
  for (std::size_t k = 0; k < h.counts.size(); ++k) {
    const double lo = h.lo + width * static_cast<double>(k), hi = lo + width;
    // The fit's expected count in [lo, hi): the normal CDF's difference times the points.
    double expected = 0;
    if (r.gauss.sigma > 0) {
      const double s = r.gauss.sigma * std::sqrt(2.0);
      expected =
          total * 0.5 * (std::erf((hi - r.gauss.mean) / s) - std::erf((lo - r.gauss.mean) / s));
    }
    append(text, lo);
    text += ',';
    append(text, hi);
    text += ',' + std::to_string(h.counts[k]) + ',';
    append(text, expected);
    text += '\n';
  }
  io::write_text_atomically(path, text);
}

void write_inspection_outputs(const InspectionOutputs& o, const PointCloud& scan,
                              const InspectResult& r) {
  const InspectionPageInfo page{o.scan_path, o.cad_path, o.units};
  if (r.registration.success) {
    if (!o.ply.empty()) write_deviation_ply(o.ply, scan, r);
    if (!o.csv.empty()) write_deviation_csv(o.csv, scan, r);
    if (!o.histogram.empty()) write_histogram_csv(o.histogram, r);
  }
  if (!o.html.empty()) write_inspection_page(o.html, r, scan, r.surface->mesh(), page);
  if (!o.figures.empty() && r.registration.success) {
    std::error_code ec;
    std::filesystem::create_directories(o.figures, ec);
    if (ec) throw OutputError(o.figures, "cannot create the folder: " + ec.message());
    write_inspection_figures(o.figures, r, scan, r.surface->mesh(), page);
  }
}

}  // namespace align3d::report
