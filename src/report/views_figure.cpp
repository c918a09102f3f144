// The views figure of views_figure.hpp: the four views of render.cpp laid out in a grid with a
// colour bar (cairo), and the numbers as the inspection prints them.
#include "align3d/report/views_figure.hpp"

#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>
#include <vector>

#include "align3d/io/atomic_file.hpp"
#include "align3d/report/colormap.hpp"
#include "canvas.hpp"
#include "ticks.hpp"

namespace align3d::report {
namespace {

struct ViewsLayout {
  detail::Fonts fonts;
  double pad = 0, gap = 0;
  double title_y = 0;                 // centre of the figure title's capitals
  std::array<Eigen::Vector2d, 4> at;  // each panel image's top-left corner
  double panel_title_h = 0;           // the line above each panel
  double bar_x = 0, bar_w = 0, bar_top = 0, bar_bottom = 0;
  int width = 0, height = 0;
};

struct BarLabels {
  std::string upper, zero, lower, header;
};

BarLabels bar_labels(const Tolerance& band, const std::string& units) {
  return {band_value(band.upper, units), band_value(0, units), band_value(band.lower, units),
          units.empty() ? "deviation" : "deviation (" + units + ")"};
}

constexpr const char* kKeyTexts[] = {"above", "below", "outlier"};
constexpr double kViewsTextScale = 1.25;

// Left to right: the two panel columns, then the colour bar's column; top to bottom: the title,
// then per row a title line over the panels' images. The fonts follow the grid's size.
ViewsLayout layout_views(cairo_t* cr, const ViewsFigureSettings& s, const BarLabels& labels) {
  ViewsLayout L;
  const int pw = s.view.width, ph = s.view.height;
  L.fonts = detail::fonts_for(2.0 * pw, 2.0 * ph, 1.0);
  // The grid is usually shown shrunk (a page is about 1150 pixels wide): text a quarter larger
  // than a plot of its size reads as a plot's would.
  for (detail::FontSpec* f : {&L.fonts.title, &L.fonts.label, &L.fonts.tick, &L.fonts.legend}) {
    f->size *= kViewsTextScale;
  }
  L.pad = L.fonts.tick.size;
  L.gap = 0.5 * L.fonts.tick.size;
  const detail::TitleBand band = detail::title_band(cr, L.fonts, !s.title.empty(), L.pad, L.gap);
  const double top = band.top;
  L.title_y = band.title_y;
  L.panel_title_h = band.panel_title_h;
  for (int k = 0; k < 4; ++k) {
    const int row = k / 2, col = k % 2;
    L.at[static_cast<std::size_t>(k)] = {
        std::round(L.pad + col * (pw + 2 * L.pad)),
        std::round(top + L.panel_title_h + row * (ph + L.panel_title_h + L.pad))};
  }
  detail::set_font(cr, L.fonts.tick);
  double widest = detail::text_width(cr, labels.header);
  for (const std::string* t : {&labels.upper, &labels.zero, &labels.lower}) {
    widest = std::max(widest, detail::text_width(cr, *t) + detail::kTickLength + L.gap);
  }
  L.bar_w = std::round(1.6 * L.fonts.tick.size);
  for (const char* t : kKeyTexts) widest = std::max(widest, detail::text_width(cr, t) + L.gap);
  L.bar_x = std::round(L.at[1].x() + pw + 2 * L.pad);
  L.width = static_cast<int>(std::ceil(L.bar_x + L.bar_w + widest + L.pad));
  const double grid_top = L.at[0].y(), grid_bottom = L.at[3].y() + ph;
  // The bar about two thirds of the grid's height, the keys above and below it, centred.
  const double keys = 4 * L.bar_w + 8 * L.gap;
  const double bar = std::round(0.66 * (grid_bottom - grid_top));
  L.bar_top = std::round(0.5 * (grid_top + grid_bottom - bar - keys) + L.bar_w + 2 * L.gap);
  L.bar_bottom = L.bar_top + bar;
  L.height = static_cast<int>(std::ceil(grid_bottom + L.pad));
  return L;
}

void draw_key(cairo_t* cr, const ViewsLayout& L, double y, const Rgb& color, const char* text) {
  detail::set_color(cr, color, 1);
  cairo_rectangle(cr, L.bar_x, y, L.bar_w, L.bar_w);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  detail::draw_text(cr, text, L.bar_x + L.bar_w + L.gap, y + 0.5 * L.bar_w, 0);
}

// The band from the lower limit (bottom) to the upper, each pixel row in deviation_color of its
// value (exact: no gradient approximates the map), ticked and labelled at the limits and at 0;
// the keys "above" over it, "below" and "outlier" under it.
void draw_colour_bar(cairo_t* cr, const ViewsLayout& L, const Tolerance& band,
                     const BarLabels& labels) {
  const double x0 = L.bar_x, x1 = L.bar_x + L.bar_w, y0 = L.bar_top, y1 = L.bar_bottom;
  const auto rows = static_cast<int>(y1 - y0);
  for (int r = 0; r < rows; ++r) {
    const double value = band.upper - (r + 0.5) / rows * (band.upper - band.lower);
    detail::set_color(cr, deviation_color(value, band), 1);
    cairo_rectangle(cr, x0, y0 + r, L.bar_w, 1);
    cairo_fill(cr);
  }
  auto y_of = [&](double v) {
    return y1 - (v - band.lower) / (band.upper - band.lower) * (y1 - y0);
  };
  detail::set_font(cr, L.fonts.tick);
  const double cap = detail::cap_height(cr);
  cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
  cairo_set_line_width(cr, 1);
  std::vector<std::pair<double, const std::string*>> ticks = {{band.upper, &labels.upper},
                                                              {band.lower, &labels.lower}};
  // 0 gets its own label unless it would touch a limit's (a one-sided band).
  if (std::min(y_of(0) - y0, y1 - y_of(0)) > 1.8 * cap) ticks.emplace_back(0.0, &labels.zero);
  for (const auto& [v, text] : ticks) {
    const double y = std::clamp(detail::snap(y_of(v)), y0 + 0.5, y1 - 0.5);
    cairo_move_to(cr, x1, y);
    cairo_rel_line_to(cr, detail::kTickLength, 0);
    cairo_stroke(cr);
    detail::draw_text(cr, *text, x1 + detail::kTickLength + L.gap, y, 0);
  }
  // The keys a little apart from the bar, so that a limit's label does not crowd its key.
  draw_key(cr, L, y0 - 2 * L.gap - L.bar_w, kAboveColor, kKeyTexts[0]);
  draw_key(cr, L, y1 + 2 * L.gap, kBelowColor, kKeyTexts[1]);
  draw_key(cr, L, y1 + 4 * L.gap + L.bar_w, kOutlierColor, kKeyTexts[2]);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  detail::draw_text(cr, labels.header, x0, y0 - 4 * L.gap - L.bar_w - 0.5 * cap, 0);
}

// The centre of the square of side `box`, in one of the image's corners, that covers the fewest
// drawn pixels (lower left first on ties): where the axis triad hides the least.
Eigen::Vector2d quietest_corner(const Raster& image, int box) {
  const int w = image.width, h = image.height;
  const std::array<Eigen::Vector2i, 4> corners = {
      {{0, h - box}, {w - box, h - box}, {0, 0}, {w - box, 0}}};
  Eigen::Vector2i best = corners[0];
  long fewest = -1;
  for (const Eigen::Vector2i& c : corners) {
    long drawn = 0;
    for (int y = std::max(0, c.y()); y < std::min(h, c.y() + box); ++y) {
      for (int x = std::max(0, c.x()); x < std::min(w, c.x() + box); ++x) {
        drawn += image.at(x, y) != kViewBackground;
      }
    }
    if (fewest < 0 || drawn < fewest) {
      fewest = drawn;
      best = c;
    }
  }
  return best.cast<double>() + Eigen::Vector2d::Constant(0.5 * box);
}

// One axis of the triad: a shaft, an arrowhead and its name beyond the tip. The halo pass only
// builds the path, which the caller strokes wide in white.
void axis_arrow(cairo_t* cr, const Eigen::Vector2d& o, const Eigen::Vector2d& d, double length,
                const char* name, bool halo) {
  const Eigen::Vector2d tip = o + length * d, u = d.normalized(), n(-u.y(), u.x());
  const Eigen::Vector2d b = tip - 0.3 * length * u;
  cairo_move_to(cr, o.x(), o.y());
  cairo_line_to(cr, b.x(), b.y());
  if (!halo) cairo_stroke(cr);
  cairo_move_to(cr, tip.x(), tip.y());
  cairo_line_to(cr, b.x() + 0.14 * length * n.x(), b.y() + 0.14 * length * n.y());
  cairo_line_to(cr, b.x() - 0.14 * length * n.x(), b.y() - 0.14 * length * n.y());
  cairo_close_path(cr);
  if (!halo) cairo_fill(cr);
  const Eigen::Vector2d label = tip + 0.35 * length * u;
  cairo_move_to(cr, label.x() - 0.5 * detail::text_width(cr, name),
                label.y() + 0.5 * detail::cap_height(cr));
  cairo_text_path(cr, name);
  if (!halo) cairo_fill(cr);
}

// Arrows along the data axes as the view shows them (an axis pointing at the viewer is left out),
// in the panel corner where they hide the least, dark on a white halo so they read on any colour.
void draw_axis_triad(cairo_t* cr, const ViewsLayout& L, const ViewImage& view, View kind,
                     const Eigen::Vector2d& at) {
  const double length = std::round(2.0 * L.fonts.tick.size);
  const Eigen::Vector2d centre =
      at + quietest_corner(view.image, static_cast<int>(std::ceil(3.2 * length)));
  const Eigen::Matrix3d R = view_rotation(kind);
  // The triad's own extent is centred in the corner's square.
  Eigen::Vector2d lo = Eigen::Vector2d::Zero(), hi = Eigen::Vector2d::Zero();
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d d(R(0, k), -R(1, k));
    lo = lo.cwiseMin(1.35 * length * d);
    hi = hi.cwiseMax(1.35 * length * d);
  }
  const Eigen::Vector2d o = centre - 0.5 * (lo + hi);
  detail::set_font(cr, {L.fonts.tick.size, true});
  static const char* const kNames[] = {"x", "y", "z"};
  for (bool halo : {true, false}) {
    cairo_set_line_width(cr, halo ? 4.5 : 1.5);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    if (halo) {
      cairo_set_source_rgb(cr, 1, 1, 1);
    } else {
      cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
    }
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d d(R(0, k), -R(1, k));
      if (d.norm() >= 0.2) axis_arrow(cr, o, d, length, kNames[k], halo);
    }
    if (halo) cairo_stroke(cr);
  }
  cairo_set_line_width(cr, 1);
}

void draw_panel(cairo_t* cr, const ViewsLayout& L, const ViewImage& view, View kind) {
  const Eigen::Vector2d& at = L.at[static_cast<std::size_t>(kind)];
  const detail::SurfacePtr surface = detail::raster_surface(view.image);
  cairo_set_source_surface(cr, surface.get(), at.x(), at.y());
  cairo_paint(cr);
  cairo_set_source_rgb(cr, 0.8, 0.8, 0.8);
  cairo_set_line_width(cr, 1);
  cairo_rectangle(cr, at.x() - 0.5, at.y() - 0.5, view.image.width + 1, view.image.height + 1);
  cairo_stroke(cr);
  draw_axis_triad(cr, L, view, kind, at);
  const double y = at.y() - 0.5 * L.panel_title_h;
  detail::set_font(cr, {L.fonts.label.size, true});
  cairo_set_source_rgb(cr, 0, 0, 0);
  const std::string title = view_title(kind);
  detail::draw_text(cr, title, at.x(), y, 0);
  const double indent = detail::text_width(cr, title + "  ");
  detail::set_font(cr, L.fonts.tick);
  cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
  detail::draw_text(cr, view_axes(kind), at.x() + indent, y, 0);
}

void draw_views_figure(cairo_t* cr, const ViewsLayout& L, const std::vector<ViewImage>& views,
                       const ViewsFigureSettings& s, const Tolerance& band,
                       const BarLabels& labels) {
  for (View kind : kViews) draw_panel(cr, L, views[static_cast<std::size_t>(kind)], kind);
  draw_colour_bar(cr, L, band, labels);
  if (!s.title.empty()) {
    detail::set_font(cr, L.fonts.title);
    cairo_set_source_rgb(cr, 0, 0, 0);
    detail::draw_text(cr, s.title, L.at[0].x(), L.title_y, 0);
  }
}

}  // namespace

void write_views_figure(const TriangleMesh& mesh, const DeviationPoints& points,
                        const std::filesystem::path& png, const ViewsFigureSettings& settings) {
  std::vector<ViewImage> views;
  for (View kind : kViews) views.push_back(render_view(mesh, points, kind, settings.view));
  const BarLabels labels = bar_labels(points.band, settings.units);
  // Measure the layout on a scratch surface: text extents need a context.
  const detail::SurfacePtr scratch(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, 16, 16));
  const detail::ContextPtr measure(cairo_create(scratch.get()));
  detail::begin_page(measure.get());
  const ViewsLayout layout = layout_views(measure.get(), settings, labels);
  const detail::SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_ARGB32, layout.width, layout.height));
  detail::check_cairo(cairo_surface_status(surface.get()), png);
  const detail::ContextPtr cr(cairo_create(surface.get()));
  detail::begin_page(cr.get());
  draw_views_figure(cr.get(), layout, views, settings, points.band, labels);
  const cairo_status_t status = cairo_status(cr.get());
  if (status == CAIRO_STATUS_INVALID_STRING) {
    throw std::invalid_argument("views figure: the title or the units are not valid UTF-8");
  }
  detail::check_cairo(status, png);
  cairo_surface_flush(surface.get());
  io::write_via_temporary(png, [&](const std::filesystem::path& tmp) {
    detail::check_cairo(cairo_surface_write_to_png(surface.get(), tmp.c_str()), png);
  });
}

std::string band_value(double value, const std::string& units) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, value > 0 ? "+%.6g" : "%.6g", value == 0 ? 0.0 : value);
  return detail::with_unicode_minus(buffer) + (units.empty() ? "" : " " + units);
}

std::string format_deviation(double value, const Tolerance& band, const std::string& units,
                             bool sign) {
  if (std::isnan(value)) return "\u2013";
  const double width = band.upper - band.lower;
  const int decimals =
      width > 0 && std::isfinite(width)
          ? std::clamp(static_cast<int>(std::ceil(-std::log10(width / 1000) - 1e-9)), 0, 9)
          : 3;
  char buffer[64];
  // + 0.0 turns a rounded −0 into 0; the sign is then left off.
  const double rounded = std::round(value * std::pow(10.0, decimals)) / std::pow(10.0, decimals);
  std::snprintf(buffer, sizeof buffer, sign && rounded > 0 ? "+%.*f" : "%.*f", decimals,
                rounded + 0.0);
  return detail::with_unicode_minus(buffer) + (units.empty() ? "" : " " + units);
}

std::string format_count(std::size_t n) {
  const std::string digits = std::to_string(n);
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += "\u2009";
    out += digits[i];
  }
  return out;
}

}  // namespace align3d::report
