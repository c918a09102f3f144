// The figure of a stitch (`align3d stitch --figure`, and its --html page): the merged cloud, in the
// first scan's frame, in two orthographic views side by side at one scale, each point a small
// square in the colour of the scan it came from (StitchResult::merged_scan), so that a seam, a
// doubled wall or a scan that went astray shows as a band of one colour where another belongs.
//
// Views, as render.hpp names them: "top" looking down −z (x right, y up) on the left, "front"
// looking along +y (x right, z up) on the right; both axes of a view have the same scale, and the
// two views the same one, so lengths compare across them. Each view is framed, its axes ticked in
// the data's units and labelled; a legend under the views names each scan (its file, or "scan k")
// by its colour, "(not connected)" after one that is not in the merged cloud.
//
// Colours: scan k has instance_color(k + 1) (find_overlay.hpp): 12 saturated, distinct colours in
// the order that puts the most distinct first, cycling from the 13th scan; the legend then tells
// repeated colours apart by their place only. Points are drawn far to near (ties by index), so a
// nearer surface covers a farther one as in a photograph. More than `max_points` merged points are
// thinned evenly for drawing (every k-th, k = ⌈points ÷ max_points⌉): the same picture for the same
// result, and a million points draw in well under a second. Deterministic, one thread.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "align3d/report/render.hpp"
#include "align3d/stitch.hpp"

namespace align3d::report {

struct StitchFigureSettings {
  int width = 1200, height = 640;  // the whole figure, pixels, each in [320, 16384]
  // One per scan (its file's name), or none; an empty one (or none) reads "scan k".
  std::vector<std::string> names;
  std::string units;                // after the axis names: "x (mm)" (may be empty)
  std::string title;                // above the views (may be empty)
  std::size_t max_points = 500000;  // drawn at most (>= 1)
};

// Where a view landed, for those who look at the pixels (the tests): its plot area in figure
// pixels ([x, x + width) × [y, y + height)) and the projection of a merged point into the figure's
// pixels (ViewCamera, render.hpp: its offset includes the area's corner).
struct StitchFigurePanel {
  View view = View::kTop;
  int x = 0, y = 0, width = 0, height = 0;
  ViewCamera camera;
};

struct StitchFigureInfo {
  std::array<StitchFigurePanel, 2> panels;  // top, front
  std::size_t drawn_points = 0;             // merged points drawn (after thinning)
  int splat = 0;                            // the side of a point's square, pixels
};

// Writes the figure as a PNG of settings.width × settings.height pixels, atomically. Throws
// std::invalid_argument for a result whose merged_scan does not hold one scan index in
// [0, scans) per merged point, names that are neither empty nor one per scan, a bad size (or one
// leaving no room for the views under the legend) or max_points 0, or a text that is not UTF-8;
// OutputError naming `png` when it cannot be written.
StitchFigureInfo write_stitch_figure(const StitchResult& result, const std::filesystem::path& png,
                                     const StitchFigureSettings& settings = {});

// The same figure as PNG bytes (the --html page embeds them). Throws as write_stitch_figure, an
// OutputError naming "stitch figure" when cairo fails.
std::string stitch_figure_png(const StitchResult& result, const StitchFigureSettings& settings = {},
                              StitchFigureInfo* info = nullptr);

}  // namespace align3d::report
