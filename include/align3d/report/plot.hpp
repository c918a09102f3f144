// Scientific 2-D plots drawn with cairo: scatter and line series with axes, ticks, labels, a legend
// and a title, written as SVG and PNG. Used for the chapter's figures 39.1-39.6.
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

struct Figure {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<Series> series;
  std::vector<HorizontalLine> lines;
  bool log_y = false;         // logarithmic y axis (all y, including lines', must be > 0)
  bool equal_aspect = false;  // same data scale on both axes (orthographic views); not with log_y
  int width = 900;            // pixels (PNG) / points (SVG), each in [64, 16384]
  int height = 600;
};

// Writes `stem`.svg and `stem`.png (the same drawing), each atomically; both are fully rendered
// before either replaces an existing file. The legend goes in the first plot corner it hides no
// data in (upper right, upper left, lower left, lower right), else outside the plot on the right.
// Throws OutputError naming the file when one cannot be written, and std::invalid_argument for a
// figure with no finite point, non-positive y on a log axis, a non-finite line y, a bad size
// or text that is not UTF-8.
// Text uses the "DejaVu Sans" font through fontconfig (Debian: fonts-dejavu-core).
void write_figure(const Figure& figure, const std::filesystem::path& stem);

}  // namespace align3d::report
