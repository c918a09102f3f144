// What every figure kind (plot.cpp, heatmap.cpp, views_figure.cpp) draws with: fonts and text,
// colours, the page, and the output. A figure kind paints its drawing onto any cairo context;
// write_svg_and_png runs it once on an SVG surface and once on an ARGB32 image surface saved as
// PNG, so both files show the same picture. Layout is measured with the context being drawn on.
// Private to the report library.
#pragma once

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <string>

#include "align3d/report/plot.hpp"  // Rgb

namespace align3d::report {
struct Raster;  // render.hpp
}  // namespace align3d::report

namespace align3d::report::detail {

constexpr int kMaxSide = 16384;  // largest width or height in pixels; cairo's image limit is 32767
constexpr double kTickLength = 5;  // outward tick marks, pixels

// An interval of plot coordinates, empty (lo > hi) until a value is added.
struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  double span() const { return hi - lo; }
};

// Text

struct FontSpec {
  double size;
  bool bold;
};

struct Fonts {
  FontSpec title, label, tick, legend;
};

// Sizes in pixels for the default 900 x 600 figure, scaled with the figure's smaller side and
// clamped to [min_scale, 3]: small figures keep text readable rather than proportional.
Fonts fonts_for(double width, double height, double min_scale = 0.85);

void set_font(cairo_t* cr, FontSpec f);  // "DejaVu Sans" through fontconfig
double text_width(cairo_t* cr, const std::string& s);
// Height of digits and capitals above the baseline: the box that vertical centring uses.
double cap_height(cairo_t* cr);
// Draws s with its horizontal anchor at fraction `ha` of its width (0 left, 0.5 centre, 1 right)
// and its capitals vertically centred on y.
void draw_text(cairo_t* cr, const std::string& s, double x, double y, double ha);

// The header of a figure of titled panels, from `pad` down: the figure's title line when it has
// one (`title_y`: the centre of its capitals), then where the panels' title lines start (`top`) and
// the height of such a line in the bold label font (`panel_title_h`). `gap` spaces the lines.
struct TitleBand {
  double title_y = 0, top = 0, panel_title_h = 0;
};
TitleBand title_band(cairo_t* cr, const Fonts& fonts, bool has_title, double pad, double gap);
// Text rotated to read upwards, centred on (x, y).
void draw_vertical_text(cairo_t* cr, const std::string& s, double x, double y);

// Colours and lines

double clamp01(double v);  // NaN as 0
// A colour component in [0, 1] as a byte, rounded (clamped to [0, 1] first).
inline std::uint8_t to_byte(double c) {
  return static_cast<std::uint8_t>(std::lround(255 * std::clamp(c, 0.0, 1.0)));
}
// Crisp 1-pixel lines: put coordinates on pixel centres.
double snap(double v);
void set_color(cairo_t* cr, const Rgb& c, double alpha);  // components and alpha clamped to [0, 1]

// Text options shared by every figure, and a white page.
void begin_page(cairo_t* cr);

// Output

// Owners of cairo's objects: destroyed when they go out of scope.
struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

// Throws OutputError naming `destination` ("cannot write: " and cairo's reason) unless `status`
// is CAIRO_STATUS_SUCCESS.
void check_cairo(cairo_status_t status, const std::filesystem::path& destination);

// A cairo surface over the raster's pixels (no copy; the raster must outlive the surface, which
// only reads them: use it as a source or write it to PNG).
SurfacePtr raster_surface(const Raster& image);

using Painter = std::function<void(cairo_t*)>;

// Paints `paint` into `stem`.svg and `stem`.png of width x height pixels, each written atomically;
// both are fully rendered before either replaces an existing file. Throws OutputError naming the
// file when one cannot be written, std::invalid_argument when a text is not UTF-8.
void write_svg_and_png(const std::filesystem::path& stem, int width, int height,
                       const Painter& paint);

}  // namespace align3d::report::detail
