// Scientific figures drawn with cairo: 2D scatter and line plots with axes, ticks, labels, a legend
// and a title, and heat maps (one, or several side by side with a shared colour bar), written as
// SVG and PNG. Used for the chapter's figures 39.1-39.5 and evaluation plots.
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

// A grid of values drawn as coloured cells (e.g. an ICP convergence basin: success rate over
// initial rotation angle x translation magnitude). Colours come from a viridis-like sequential map,
// dark purple at min_value to yellow at max_value; values outside the range take the end colours.
// Non-finite cells (no data) are drawn light gray and hatched, without a number.
struct HeatMap {
  std::string title;                 // above the map (write_heatmaps: the panel's title)
  std::string x_label;               // below the column labels
  std::string y_label;               // left of the row labels
  std::string value_label;           // along the colour bar
  std::vector<std::string> x_ticks;  // one label per column, centred under it
  std::vector<std::string> y_ticks;  // one label per row, row 0 at the bottom
  Eigen::MatrixXd values;            // rows = y (row 0 at the BOTTOM), cols = x
  double min_value = 0;              // colour scale range: finite, min_value < max_value
  double max_value = 1;
  bool annotate = true;  // print each cell's value in it, black or white for contrast (left out
                         // when the cells are too small for legible text)
  std::string value_format = "percent";  // "percent": 0.973 -> "97%"; "fixed2": "0.97"
  int width = 700;                       // pixels (PNG) / points (SVG), each in [64, 16384]
  int height = 520;
};

// Writes `stem`.svg and `stem`.png atomically, as write_figure does: the map, its axis labels and a
// colour bar on the right labelled `value_label`, in `value_format`, plus a "no data" key when a
// cell is non-finite. Throws std::invalid_argument for an empty map, tick counts that differ from
// the value matrix's columns / rows, a non-finite range or min_value >= max_value, an unknown
// value_format, a bad size or text that is not UTF-8; OutputError when a file cannot be written.
void write_heatmap(const HeatMap& map, const std::filesystem::path& stem);

// Several heat maps side by side in one image, under one `title` (may be empty), with one colour
// bar on the right; each panel's `title` names it. The image is the sum of the panels' widths wide
// and their largest height tall; each panel's grid gets width in proportion to its `width`. All
// panels must share min_value and max_value; the colour bar takes the first non-empty value_label
// and the first panel's value_format. A panel whose row labels and y label repeat those of the
// panel on its left does not print them again. Throws as write_heatmap, and std::invalid_argument
// for no panels, ranges that differ between panels or a total width above 16384.
void write_heatmaps(const std::vector<HeatMap>& panels, const std::string& title,
                    const std::filesystem::path& stem);

}  // namespace align3d::report
