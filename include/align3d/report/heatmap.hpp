// Heat maps drawn with cairo: one, or several in rows with a shared colour bar, written as SVG
// and PNG. Used for the convergence basin of `align3d evaluate`.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace align3d::report {

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

// Writes `stem`.svg and `stem`.png atomically, as write_figure (plot.hpp) does: the map, its axis
// labels and a colour bar on the right labelled `value_label`, in `value_format`, plus a "no data"
// key when a cell is non-finite. Throws std::invalid_argument for an empty map, tick counts that
// differ from the value matrix's columns / rows, a non-finite range or min_value >= max_value, an
// unknown value_format, a bad size or text that is not UTF-8; OutputError when a file cannot be
// written.
void write_heatmap(const HeatMap& map, const std::filesystem::path& stem);

// Several heat maps in one image, side by side in rows of `columns` panels (0: all in one row),
// under one `title` (may be empty), with one colour bar right of the first row; each panel's
// `title` names it. The image is as wide as its widest row (the sum of that row's panels' widths)
// and as tall as the rows' tallest panels together; each panel's grid gets width in proportion to
// its `width`. All panels must share min_value and max_value; the colour bar takes the first
// non-empty value_label and the first panel's value_format. A panel whose row labels and y label
// repeat those of the panel on its left does not print them again. Throws as write_heatmap, and
// std::invalid_argument for no panels, ranges that differ between panels or an image wider or
// taller than 16384.
void write_heatmaps(const std::vector<HeatMap>& panels, const std::string& title,
                    const std::filesystem::path& stem, std::size_t columns = 0);

}  // namespace align3d::report
