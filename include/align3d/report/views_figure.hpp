// The inspection's views figure: the four views of render.hpp in a 2 × 2 grid (top, front; side,
// isometric), each titled with its name and its axes and marked with an axis triad, and on the
// right one vertical colour bar of the band: the in-band colours from the lower limit (bottom)
// through 0 to the upper limit, labelled with their values and `units`, the out-of-band colours as
// "above" and "below" boxes at its ends and the outlier grey as an "outlier" box under it.
//
// Also the numbers as the inspection's figures (this one and histogram.hpp) and its page
// (inspection_page.hpp) print them, so that all three agree to the digit.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include "align3d/inspect.hpp"
#include "align3d/mesh.hpp"
#include "align3d/report/render.hpp"

namespace align3d::report {

struct ViewsFigureSettings {
  ViewSettings view{640, 480};  // each panel's view
  std::string units = "mm";     // appended to the colour bar's values (may be empty)
  std::string title;            // above the grid (may be empty)
};
// Writes `png` atomically; throws as render_view, OutputError when the file cannot be written and
// std::invalid_argument when a text is not UTF-8.
void write_views_figure(const TriangleMesh& mesh, const DeviationPoints& points,
                        const std::filesystem::path& png, const ViewsFigureSettings& settings = {});

// Numbers as the inspection's figures and page print them (`units` may be empty):
// a limit of the band as given: "+0.1 mm", "0 mm", "−0.05 mm" (six significant digits at most);
std::string band_value(double value, const std::string& units);
// a measured deviation to a thousandth of the band's width (0.2 mm wide: 4 decimals), with a sign
// when `sign` ("+0.0123 mm", "−0.0040 mm"); NaN as "–".
std::string format_deviation(double value, const Tolerance& band, const std::string& units,
                             bool sign = true);
// a count with thin spaces (U+2009) between groups of three digits: "1 234 567".
std::string format_count(std::size_t n);

}  // namespace align3d::report
