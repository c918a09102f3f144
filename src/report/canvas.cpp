// Fonts and text, colours, the page and the SVG + PNG output shared by the figure kinds.
#include "canvas.hpp"

#include <cairo-svg.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/report/render.hpp"  // Raster

namespace align3d::report::detail {
namespace {

constexpr const char* kFontFamily = "DejaVu Sans";  // fontconfig falls back to the default sans

void render(cairo_surface_t* surface, const Painter& paint,
            const std::filesystem::path& destination) {
  check_cairo(cairo_surface_status(surface), destination);
  const ContextPtr cr(cairo_create(surface));
  check_cairo(cairo_status(cr.get()), destination);
  paint(cr.get());
  if (cairo_status(cr.get()) == CAIRO_STATUS_INVALID_STRING) {
    throw std::invalid_argument("figure: a title, label, tick or legend text is not valid UTF-8");
  }
  check_cairo(cairo_status(cr.get()), destination);
}

void write_svg(const Painter& paint, int width, int height, const std::filesystem::path& tmp,
               const std::filesystem::path& destination) {
  const SurfacePtr surface(cairo_svg_surface_create(tmp.c_str(), width, height));
  render(surface.get(), paint, destination);
  cairo_surface_finish(surface.get());  // writes and closes the file; errors land in the status
  check_cairo(cairo_surface_status(surface.get()), destination);
}

void write_png(const Painter& paint, int width, int height, const std::filesystem::path& tmp,
               const std::filesystem::path& destination) {
  const SurfacePtr surface(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width, height));
  render(surface.get(), paint, destination);
  cairo_surface_flush(surface.get());
  check_cairo(cairo_surface_write_to_png(surface.get(), tmp.c_str()), destination);
}

std::filesystem::path with_suffix(const std::filesystem::path& stem, const char* suffix) {
  auto path = stem;
  path += suffix;
  return path;
}

}  // namespace

void check_cairo(cairo_status_t status, const std::filesystem::path& destination) {
  if (status != CAIRO_STATUS_SUCCESS) {
    throw OutputError(destination, std::string("cannot write: ") + cairo_status_to_string(status));
  }
}

SurfacePtr raster_surface(const Raster& image) {
  const int stride = cairo_format_stride_for_width(CAIRO_FORMAT_ARGB32, image.width);
  if (stride != 4 * image.width) throw std::logic_error("render: unexpected ARGB32 stride");
  // cairo only reads through this pointer here: the surfaces are sources or written to PNG.
  auto* data = reinterpret_cast<unsigned char*>(const_cast<std::uint32_t*>(image.pixels.data()));
  return SurfacePtr(cairo_image_surface_create_for_data(data, CAIRO_FORMAT_ARGB32, image.width,
                                                        image.height, stride));
}

Fonts fonts_for(double width, double height, double min_scale) {
  const double s = std::clamp(std::min(width / 900.0, height / 600.0), min_scale, 3.0);
  return {{17 * s, true}, {14 * s, false}, {12 * s, false}, {12.5 * s, false}};
}

void set_font(cairo_t* cr, FontSpec f) {
  cairo_select_font_face(cr, kFontFamily, CAIRO_FONT_SLANT_NORMAL,
                         f.bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, f.size);
}

double text_width(cairo_t* cr, const std::string& s) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  return e.x_advance;
}

double cap_height(cairo_t* cr) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, "0", &e);
  return -e.y_bearing;
}

TitleBand title_band(cairo_t* cr, const Fonts& fonts, bool has_title, double pad, double gap) {
  TitleBand b;
  b.top = pad;
  if (has_title) {
    set_font(cr, fonts.title);
    b.title_y = b.top + 0.5 * cap_height(cr);
    b.top += 1.35 * cap_height(cr) + 2 * gap;
  }
  set_font(cr, {fonts.label.size, true});
  b.panel_title_h = std::round(1.35 * cap_height(cr) + 1.5 * gap);
  return b;
}

void draw_text(cairo_t* cr, const std::string& s, double x, double y, double ha) {
  cairo_move_to(cr, x - ha * text_width(cr, s), y + 0.5 * cap_height(cr));
  cairo_show_text(cr, s.c_str());
}

void draw_vertical_text(cairo_t* cr, const std::string& s, double x, double y) {
  cairo_save(cr);
  cairo_translate(cr, x, y);
  cairo_rotate(cr, -std::numbers::pi / 2);
  draw_text(cr, s, 0, 0, 0.5);
  cairo_restore(cr);
}

double clamp01(double v) { return std::isfinite(v) ? std::clamp(v, 0.0, 1.0) : 0.0; }

double snap(double v) { return std::floor(v) + 0.5; }

void set_color(cairo_t* cr, const Rgb& c, double alpha) {
  cairo_set_source_rgba(cr, clamp01(c[0]), clamp01(c[1]), clamp01(c[2]), clamp01(alpha));
}

void begin_page(cairo_t* cr) {
  cairo_font_options_t* options = cairo_font_options_create();
  // Unhinted metrics: the SVG and the PNG get the same text widths, hence the same layout.
  cairo_font_options_set_hint_metrics(options, CAIRO_HINT_METRICS_OFF);
  cairo_font_options_set_hint_style(options, CAIRO_HINT_STYLE_NONE);
  cairo_font_options_set_antialias(options, CAIRO_ANTIALIAS_GRAY);
  cairo_set_font_options(cr, options);
  cairo_font_options_destroy(options);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
}

void write_svg_and_png(const std::filesystem::path& stem, int width, int height,
                       const Painter& paint) {
  const auto svg = with_suffix(stem, ".svg");
  const auto png = with_suffix(stem, ".png");
  // Nested so that both files are fully rendered before either is renamed into place: a failure
  // while drawing or writing leaves neither new file behind.
  io::write_via_temporary(svg, [&](const std::filesystem::path& svg_tmp) {
    write_svg(paint, width, height, svg_tmp, svg);
    io::write_via_temporary(png, [&](const std::filesystem::path& png_tmp) {
      write_png(paint, width, height, png_tmp, png);
    });
  });
}

}  // namespace align3d::report::detail
