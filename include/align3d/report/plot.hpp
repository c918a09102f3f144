// Scientific 2-D plots drawn with cairo: scatter and line series, bars (histograms), reference
// lines and shaded intervals, with axes, ticks, labels, a legend and a title, written as SVG and
// PNG. Used for the chapter's figures 39.1-39.6 and the inspection's histogram (histogram.hpp).
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace align3d::report {

using Rgb = std::array<double, 3>;  // components in [0, 1]

// Non-finite points are skipped (and break a polyline). A scatter series is painted as one layer:
// `alpha` blends it with what lies below, not with itself, so a dense cloud keeps one even tone.
struct Series {
  std::string label;  // shown in the legend (empty: not listed)
  Rgb color{0, 0, 0};
  std::vector<Eigen::Vector2d> points;  // data coordinates
  bool line = false;  // true: polyline, with markers up to 200 points; false: scatter of dots
  double size = 1.5;  // dot radius or line width, in pixels; must be > 0
  double alpha = 0.8;
};

struct HorizontalLine {  // a reference line across the plot (e.g. the noise floor, z = 0)
  double y = 0;
  std::string label;
  Rgb color{0.5, 0.5, 0.5};
  bool dashed = true;
};

// A bar from x0 to x1 (x0 < x1), rising from y = 0 to `height` (a histogram's bin), filled with
// `color` and outlined in a darker shade of it, so that light bars stand out from the page.
struct Bar {
  double x0 = 0, x1 = 0, height = 0;
  Rgb color{0.5, 0.5, 0.5};
};

struct VerticalLine {  // a reference line up the plot (e.g. a tolerance limit)
  double x = 0;
  std::string label;  // above the plot, centred on the line (empty: none)
  Rgb color{0.3, 0.3, 0.3};
  bool dashed = true;
};

struct VerticalBand {  // an interval x0 <= x <= x1 shaded across the plot's height, behind the data
  double x0 = 0, x1 = 0;
  std::string label;  // in the legend (empty: not listed)
  Rgb color{0.9, 0.9, 0.9};
};

struct Figure {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<Series> series;
  std::vector<HorizontalLine> lines;
  // On a linear y axis y = 0 is the axis' bottom unless data lies below; on a log axis the bars
  // rise from the axis' bottom, and those of height <= 0 are left out.
  std::vector<Bar> bars;
  std::vector<VerticalLine> vertical_lines;
  std::vector<VerticalBand> bands;
  std::string note;           // one line under the plot, left-aligned (empty: none)
  bool log_y = false;         // logarithmic y axis (all y, including lines', must be > 0)
  bool equal_aspect = false;  // same data scale on both axes (orthographic views); not with log_y
  int width = 900;            // pixels (PNG) / points (SVG), each in [64, 16384]
  int height = 600;
};

// Writes `stem`.svg and `stem`.png (the same drawing), each atomically; both are fully rendered
// before either replaces an existing file. The legend goes in the first plot corner it hides no
// data in (upper right, upper left, lower left, lower right), else outside the plot on the right;
// vertical lines and bands do not count as hidden (they are labelled elsewhere and span the plot).
// Throws OutputError naming the file when one cannot be written, and std::invalid_argument for a
// figure with nothing to draw (no finite point, bar or vertical line), non-positive y on a log
// axis, a non-finite line, bar or band, a bad size or text that is not UTF-8.
// Text uses the "DejaVu Sans" font through fontconfig (Debian: fonts-dejavu-core).
void write_figure(const Figure& figure, const std::filesystem::path& stem);

}  // namespace align3d::report
