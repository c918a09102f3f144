// 2-D plots (plot.hpp): the data in plot coordinates, the layout (margins from the tick labels,
// the legend in the first corner where it hides no data) and the drawing.
#include "align3d/report/plot.hpp"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "canvas.hpp"
#include "ticks.hpp"

namespace align3d::report {
namespace detail {
namespace {

constexpr double kPadFraction = 0.05;          // data range padding on each side
constexpr std::size_t kMaxMarkedPoints = 200;  // line series with more points get no markers
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------
// Data preparation (independent of the surface)

// A series in plot coordinates: y is log10(y) on a log axis; a non-finite point is stored as NaN
// (it breaks a polyline and is not drawn).
struct PreparedSeries {
  const Series* source = nullptr;
  std::vector<Eigen::Vector2d> points;
  std::size_t finite_count = 0;
};

struct Prepared {
  std::vector<PreparedSeries> series;
  std::vector<double> line_y;  // HorizontalLine y in plot coordinates
  Range x, y;                  // padded data range in plot coordinates
};

// Bars, vertical lines and bands: checked, and their extent added to the data ranges (a bar spans
// y = 0 to its height; on a log axis only its height counts, and a bar of height <= 0 none).
void prepare_bars_and_verticals(const Figure& figure, Range& x, Range& y) {
  for (const Bar& b : figure.bars) {
    if (!std::isfinite(b.x0) || !std::isfinite(b.x1) || !std::isfinite(b.height) ||
        !(b.x0 < b.x1)) {
      throw std::invalid_argument("figure: a bar needs finite x0 < x1 and a finite height, got [" +
                                  std::to_string(b.x0) + ", " + std::to_string(b.x1) + "] x " +
                                  std::to_string(b.height));
    }
    x.add(b.x0);
    x.add(b.x1);
    if (figure.log_y) {
      if (b.height > 0) y.add(std::log10(b.height));
    } else {
      y.add(0);
      y.add(b.height);
    }
  }
  for (const VerticalLine& l : figure.vertical_lines) {
    if (!std::isfinite(l.x)) {
      throw std::invalid_argument("figure: vertical line '" + l.label + "' has a non-finite x");
    }
    x.add(l.x);
  }
  for (const VerticalBand& b : figure.bands) {
    if (!std::isfinite(b.x0) || !std::isfinite(b.x1) || !(b.x0 <= b.x1)) {
      throw std::invalid_argument("figure: band '" + b.label + "' needs finite x0 <= x1");
    }
    x.add(b.x0);
    x.add(b.x1);
  }
}

// Pads a range by kPadFraction of its span on each side. A degenerate range (one value, or a spread
// below 1e-9 of its magnitude: rounding noise) gets a span of 20% of its magnitude, at least 1,
// about its centre, so mapping to pixels never divides by zero and tick indices stay small.
Range padded(Range r, double degenerate_half_span) {
  const double magnitude = std::max(std::abs(r.lo), std::abs(r.hi));
  if (!(r.span() > 1e-9 * magnitude)) {
    const double centre = 0.5 * (r.lo + r.hi);
    const double half =
        degenerate_half_span > 0 ? degenerate_half_span : std::max(magnitude * 0.1, 0.5);
    return {centre - half, centre + half};
  }
  const double pad = r.span() * kPadFraction;
  return {r.lo - pad, r.hi + pad};
}

Prepared prepare(const Figure& figure) {
  if (figure.width < 64 || figure.height < 64 || figure.width > kMaxSide ||
      figure.height > kMaxSide) {
    throw std::invalid_argument("figure: width and height must be in [64, 16384] pixels, got " +
                                std::to_string(figure.width) + " x " +
                                std::to_string(figure.height));
  }
  Prepared p;
  Range x, y;
  for (const auto& s : figure.series) {
    if (!(s.size > 0) || !std::isfinite(s.size)) {
      throw std::invalid_argument("figure: series '" + s.label + "' has a non-positive size");
    }
    PreparedSeries ps;
    ps.source = &s;
    ps.points.reserve(s.points.size());
    for (const auto& q : s.points) {
      if (!q.allFinite()) {
        ps.points.emplace_back(kNan, kNan);
        continue;
      }
      if (figure.log_y && q.y() <= 0) {
        throw std::invalid_argument("figure: series '" + s.label + "' has y = " +
                                    std::to_string(q.y()) + " <= 0 on a logarithmic y axis");
      }
      const Eigen::Vector2d v(q.x(), figure.log_y ? std::log10(q.y()) : q.y());
      ps.points.push_back(v);
      x.add(v.x());
      y.add(v.y());
      ++ps.finite_count;
    }
    p.series.push_back(std::move(ps));
  }
  prepare_bars_and_verticals(figure, x, y);
  if (!(x.lo <= x.hi) || !(y.lo <= y.hi)) {
    throw std::invalid_argument("figure: no series has a finite point to draw");
  }
  for (const auto& line : figure.lines) {
    if (!std::isfinite(line.y) || (figure.log_y && line.y <= 0)) {
      throw std::invalid_argument("figure: horizontal line '" + line.label + "' at y = " +
                                  std::to_string(line.y) + " cannot be drawn on this y axis");
    }
    p.line_y.push_back(figure.log_y ? std::log10(line.y) : line.y);
    y.add(p.line_y.back());
  }
  p.x = padded(x, 0);
  p.y = padded(y, figure.log_y ? 0.5 : 0);  // half a decade each way for a flat log curve
  // Bars stand on the axis' bottom: no padding below y = 0 when nothing lies below it.
  if (!figure.bars.empty() && !figure.log_y && y.lo >= 0) p.y.lo = 0;
  if (!std::isfinite(p.x.span()) || !std::isfinite(p.y.span())) {
    throw std::invalid_argument("figure: data range too large to plot (beyond 1e307)");
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// Layout

enum class EntryKind { kScatter, kLine, kReference, kBox };

struct LegendEntry {
  EntryKind kind;
  std::string label;
  Rgb color;
  double alpha;
  double size;
  bool dashed;
  bool markers;  // line entries: the series draws markers at its points
};

struct Legend {
  std::vector<LegendEntry> entries;
  double width = 0, height = 0, row = 0, pad = 0, sample = 0;
};

Legend make_legend(cairo_t* cr, const Figure& f, const Fonts& fonts) {
  Legend legend;
  for (const auto& s : f.series) {
    if (s.label.empty()) continue;
    const auto finite = static_cast<std::size_t>(std::count_if(
        s.points.begin(), s.points.end(), [](const auto& q) { return q.allFinite(); }));
    legend.entries.push_back({s.line ? EntryKind::kLine : EntryKind::kScatter, s.label, s.color,
                              s.alpha, s.size, false, finite <= kMaxMarkedPoints});
  }
  for (const auto& l : f.lines) {
    if (l.label.empty()) continue;
    legend.entries.push_back({EntryKind::kReference, l.label, l.color, 1.0, 1.5, l.dashed, false});
  }
  for (const auto& b : f.bands) {
    if (b.label.empty()) continue;
    legend.entries.push_back({EntryKind::kBox, b.label, b.color, 1.0, 0, false, false});
  }
  if (legend.entries.empty()) return legend;
  set_font(cr, fonts.legend);
  double widest = 0;
  for (const auto& e : legend.entries) widest = std::max(widest, text_width(cr, e.label));
  legend.row = fonts.legend.size * 1.55;
  legend.pad = fonts.legend.size * 0.7;
  legend.sample = fonts.legend.size * 2.2;
  legend.width = 2 * legend.pad + legend.sample + 0.6 * fonts.legend.size + widest;
  legend.height = 2 * legend.pad + legend.row * static_cast<double>(legend.entries.size());
  return legend;
}

struct Layout {
  double x0 = 0, y0 = 0, w = 0, h = 0;  // plot area in pixels (y0 is the top)
  Range x, y;                           // plot coordinates shown
  Ticks x_ticks, y_ticks;
  double legend_x = 0, legend_y = 0;
  bool has_title = false;
  double title_y = 0;          // centre of the title's capitals
  std::vector<int> label_row;  // per vertical line: its label's row above the plot (0 nearest), or
                               // -1 for none
  double label_row_h = 0;

  double px(double x_value) const { return x0 + (x_value - x.lo) / x.span() * w; }
  double py(double y_value) const { return y0 + h - (y_value - y.lo) / y.span() * h; }
};

// Each vertical line's label on the lowest row above the plot where it keeps a gap to the label
// before it (left to right); returns the number of rows.
int assign_label_rows(cairo_t* cr, const Figure& f, Layout& L, double gap) {
  L.label_row.assign(f.vertical_lines.size(), -1);
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < f.vertical_lines.size(); ++i) {
    if (!f.vertical_lines[i].label.empty()) order.push_back(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return f.vertical_lines[a].x < f.vertical_lines[b].x;
  });
  std::vector<double> row_end;  // right end of the last label on each row
  for (std::size_t i : order) {
    const double half = 0.5 * text_width(cr, f.vertical_lines[i].label);
    const double start = L.px(f.vertical_lines[i].x) - half;
    std::size_t row = 0;
    while (row < row_end.size() && row_end[row] + gap > start) ++row;
    if (row == row_end.size()) row_end.push_back(0);
    row_end[row] = start + 2 * half;
    L.label_row[i] = static_cast<int>(row);
  }
  return static_cast<int>(row_end.size());
}

// A bar's top and base in pixels: from y = 0, or on a log axis from the axis' bottom (a bar of
// height <= 0 there has top == base).
std::pair<double, double> bar_span(const Figure& f, const Layout& L, const Bar& b) {
  if (!f.log_y) return {L.py(b.height), L.py(0)};
  const double base = L.py(L.y.lo);
  return {b.height > 0 ? L.py(std::log10(b.height)) : base, base};
}

enum class LegendPlace { kUpperRight, kUpperLeft, kLowerLeft, kLowerRight, kOutside };

// The legend box's corner: inset from a corner of the plot area, or right of the plot area.
void place_legend(Layout& L, const Legend& legend, LegendPlace place, const Fonts& fonts) {
  const double pad = fonts.tick.size;  // outer margin, as in make_layout
  const double inset = 0.8 * fonts.tick.size;
  switch (place) {
    case LegendPlace::kUpperRight:
      L.legend_x = L.x0 + L.w - inset - legend.width;
      L.legend_y = L.y0 + inset;
      break;
    case LegendPlace::kUpperLeft:
      L.legend_x = L.x0 + inset;
      L.legend_y = L.y0 + inset;
      break;
    case LegendPlace::kLowerLeft:
      L.legend_x = L.x0 + inset;
      L.legend_y = L.y0 + L.h - inset - legend.height;
      break;
    case LegendPlace::kLowerRight:
      L.legend_x = L.x0 + L.w - inset - legend.width;
      L.legend_y = L.y0 + L.h - inset - legend.height;
      break;
    case LegendPlace::kOutside:
      L.legend_x = L.x0 + L.w + pad;
      L.legend_y = L.y0;
      break;
  }
}

// Margins fitted to the tick labels (which depend on the plot area's size: up to four passes), the
// plot area, its ranges and ticks, and the legend at `place`.
Layout make_layout(cairo_t* cr, const Figure& f, const Prepared& p, const Fonts& fonts,
                   const Legend& legend, LegendPlace place) {
  Layout L;
  const double pad = fonts.tick.size;  // outer margin
  const double gap = 0.5 * fonts.tick.size;
  const bool outside = place == LegendPlace::kOutside && !legend.entries.empty();

  set_font(cr, fonts.tick);
  const double tick_text_h = cap_height(cr);
  set_font(cr, fonts.label);
  const double label_h = cap_height(cr) * 1.35;  // room for descenders
  set_font(cr, fonts.title);
  L.has_title = !f.title.empty();
  const double title_h = L.has_title ? cap_height(cr) * 1.35 : 0;
  L.title_y = pad + 0.5 * cap_height(cr);

  const double top = pad + (L.has_title ? title_h + 1.2 * gap : 0.5 * tick_text_h);
  set_font(cr, fonts.legend);
  const double note_h = f.note.empty() ? 0 : 1.35 * cap_height(cr) + 2 * gap;
  const double bottom =
      kTickLength + gap + tick_text_h + (f.x_label.empty() ? 0 : 2 * gap + label_h) + note_h + pad;
  L.label_row_h = 1.35 * tick_text_h + 0.5 * gap;
  L.y0 = top;
  L.h = std::max(10.0, f.height - top - bottom);

  double left = pad + 40, right = pad;
  int rows = 0;
  L.x = p.x;
  L.y = p.y;
  for (int pass = 0; pass < 4; ++pass) {
    L.x0 = left;
    L.w = std::max(10.0, f.width - left - right);
    L.x = p.x;
    L.y = p.y;
    set_font(cr, fonts.tick);
    const int new_rows = assign_label_rows(cr, f, L, gap);
    L.y0 = top + new_rows * L.label_row_h;
    L.h = std::max(10.0, f.height - L.y0 - bottom);
    if (f.equal_aspect && !f.log_y) {
      // Same data units per pixel on both axes: widen the tighter range about its centre.
      const double units_per_px = std::max(L.x.span() / L.w, L.y.span() / L.h);
      const double cx = 0.5 * (L.x.lo + L.x.hi), cy = 0.5 * (L.y.lo + L.y.hi);
      L.x = {cx - 0.5 * units_per_px * L.w, cx + 0.5 * units_per_px * L.w};
      L.y = {cy - 0.5 * units_per_px * L.h, cy + 0.5 * units_per_px * L.h};
    }
    set_font(cr, fonts.tick);
    L.y_ticks = f.log_y ? log_ticks(cr, L.y, L.h) : linear_ticks(cr, L.y, L.h, 55, false);
    L.x_ticks = linear_ticks(cr, L.x, L.w, 90, true);
    double widest_y = 0;
    for (const auto& t : L.y_ticks.major) widest_y = std::max(widest_y, text_width(cr, t.label));
    // A centred x tick label at the right end may stick out of the plot area.
    double overhang = 0;
    if (!L.x_ticks.major.empty()) {
      const Tick& t = L.x_ticks.major.back();
      overhang = std::max(0.0, 0.5 * text_width(cr, t.label) - (L.x0 + L.w - L.px(t.pos)));
    }
    const double new_left =
        pad + (f.y_label.empty() ? 0 : label_h + 2 * gap) + widest_y + gap + kTickLength;
    const double new_right = std::max(pad, overhang + 4) + (outside ? legend.width + 1.5 * pad : 0);
    if (new_left == left && new_right == right && new_rows == rows) break;
    left = new_left;
    right = new_right;
    rows = new_rows;
  }

  place_legend(L, legend, place, fonts);
  return L;
}

// Does segment a-b touch the axis-aligned box [x0, x1] x [y0, y1]? (Liang-Barsky clipping.)
bool segment_hits_box(Eigen::Vector2d a, Eigen::Vector2d b, double x0, double y0, double x1,
                      double y1) {
  double t0 = 0, t1 = 1;
  const Eigen::Vector2d d = b - a;
  const double p[4] = {-d.x(), d.x(), -d.y(), d.y()};
  const double q[4] = {a.x() - x0, x1 - a.x(), a.y() - y0, y1 - a.y()};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
  }
  return true;
}

// How much data the legend box would hide at this layout's legend position: points under it, plus
// a heavy weight for every polyline segment or reference line crossing it.
double legend_overlap(const Figure& f, const Layout& L, const Prepared& p, const Legend& legend) {
  const double m = 4;  // keep a few pixels of air around the box
  const double x0 = L.legend_x - m, y0 = L.legend_y - m;
  const double x1 = L.legend_x + legend.width + m, y1 = L.legend_y + legend.height + m;
  double cost = 0;
  for (const auto& s : p.series) {
    const double r = s.source->line ? 0 : s.source->size;
    Eigen::Vector2d prev(kNan, kNan);
    for (const auto& q : s.points) {
      const Eigen::Vector2d v(L.px(q.x()), L.py(q.y()));
      if (std::isfinite(v.x()) && v.x() + r >= x0 && v.x() - r <= x1 && v.y() + r >= y0 &&
          v.y() - r <= y1) {
        cost += 1;
      }
      if (s.source->line && std::isfinite(prev.x()) && std::isfinite(v.x()) &&
          segment_hits_box(prev, v, x0, y0, x1, y1)) {
        cost += 100;
      }
      prev = v;
    }
  }
  for (double y : p.line_y) {
    const double v = L.py(y);
    if (v >= y0 && v <= y1) cost += 100;
  }
  for (const Bar& b : f.bars) {
    const auto [top, base] = bar_span(f, L, b);
    if (L.px(b.x1) >= x0 && L.px(b.x0) <= x1 && std::max(top, base) >= y0 &&
        std::min(top, base) <= y1) {
      cost += 1;
    }
  }
  return cost;
}

// The corner inside the plot that hides no data, preferring upper right; when every corner hides
// some, the legend goes outside the plot on the right.
Layout choose_layout(cairo_t* cr, const Figure& f, const Prepared& p, const Fonts& fonts,
                     const Legend& legend) {
  if (legend.entries.empty()) {
    return make_layout(cr, f, p, fonts, legend, LegendPlace::kUpperRight);
  }
  for (LegendPlace place : {LegendPlace::kUpperRight, LegendPlace::kUpperLeft,
                            LegendPlace::kLowerLeft, LegendPlace::kLowerRight}) {
    Layout L = make_layout(cr, f, p, fonts, legend, place);
    const bool fits = legend.width + 40 < L.w && legend.height + 40 < L.h;
    if (fits && legend_overlap(f, L, p, legend) == 0) return L;
  }
  return make_layout(cr, f, p, fonts, legend, LegendPlace::kOutside);
}

// ---------------------------------------------------------------------------------------------
// Drawing

// Dots of the current line width: zero-length sub-paths stroked with round caps, which cairo
// documents as drawing circles; in SVG each is a short "M x y L x y". Centres are rounded to a
// quarter pixel (invisible, and it shortens the SVG). `per_stroke` dots go into one path: a single
// stroke for all of them paints their union (overlaps do not compound alpha), while small batches
// rasterise several times faster, since cairo tessellates each path's outlines together.
void draw_dots(cairo_t* cr, const Layout& L, const std::vector<Eigen::Vector2d>& points,
               double radius, std::size_t per_stroke) {
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_width(cr, 2 * radius);
  std::size_t pending = 0;
  for (const auto& q : points) {
    if (!std::isfinite(q.x())) continue;
    const double x = std::round(4 * L.px(q.x())) / 4, y = std::round(4 * L.py(q.y())) / 4;
    cairo_move_to(cr, x, y);
    cairo_line_to(cr, x, y);
    if (++pending == per_stroke) {
      cairo_stroke(cr);
      pending = 0;
    }
  }
  cairo_stroke(cr);
}

double marker_radius(double line_width) { return line_width + 1.5; }

// A scatter series is one layer: alpha blends it with what lies below but not with itself, so a
// dense cloud keeps one even tone. Vector output strokes all dots as one path at the series' alpha;
// on an image, small opaque batches go into a group painted with that alpha, which looks the same
// and is faster. (Groups are not used on SVG: cairo 1.16 leaks each group painted there.)
void draw_scatter(cairo_t* cr, const Layout& L, const PreparedSeries& s) {
  const Series& src = *s.source;
  const double alpha = clamp01(src.alpha);
  if (cairo_surface_get_type(cairo_get_target(cr)) != CAIRO_SURFACE_TYPE_IMAGE) {
    set_color(cr, src.color, alpha);
    draw_dots(cr, L, s.points, src.size, s.points.size());
    return;
  }
  constexpr std::size_t kDotsPerStroke = 16;
  if (alpha < 1) cairo_push_group(cr);
  set_color(cr, src.color, 1.0);
  draw_dots(cr, L, s.points, src.size, kDotsPerStroke);
  if (alpha < 1) {
    cairo_pop_group_to_source(cr);
    cairo_paint_with_alpha(cr, alpha);
  }
}

// A polyline, broken at non-finite points, then its markers, each stroked at the series' alpha.
void draw_polyline(cairo_t* cr, const Layout& L, const PreparedSeries& s) {
  const Series& src = *s.source;
  set_color(cr, src.color, src.alpha);
  cairo_set_line_width(cr, src.size);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  bool pen_down = false;
  for (const auto& q : s.points) {
    if (!std::isfinite(q.x())) {
      pen_down = false;
      continue;
    }
    const double x = L.px(q.x()), y = L.py(q.y());
    if (!pen_down) cairo_move_to(cr, x, y);  // the zero-length first segment keeps a lone point
    cairo_line_to(cr, x, y);                 // visible as a dot of the line's width
    pen_down = true;
  }
  cairo_stroke(cr);
  if (s.finite_count <= kMaxMarkedPoints) {
    draw_dots(cr, L, s.points, marker_radius(src.size), s.points.size());
  }
}

void set_reference_style(cairo_t* cr, const Rgb& color, bool dashed, double width) {
  set_color(cr, color, 1.0);
  cairo_set_line_width(cr, width);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
  const double dash[2] = {6 * width / 1.5, 4 * width / 1.5};
  cairo_set_dash(cr, dash, dashed ? 2 : 0, 0);
}

void draw_legend(cairo_t* cr, const Layout& L, const Legend& legend, const Fonts& fonts) {
  if (legend.entries.empty()) return;
  const double x = snap(L.legend_x), y = snap(L.legend_y);
  cairo_rectangle(cr, x, y, std::round(legend.width), std::round(legend.height));
  cairo_set_source_rgba(cr, 1, 1, 1, 0.92);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 0.7, 0.7, 0.7);
  cairo_set_line_width(cr, 1);
  cairo_stroke(cr);

  set_font(cr, fonts.legend);
  for (std::size_t i = 0; i < legend.entries.size(); ++i) {
    const LegendEntry& e = legend.entries[i];
    const double cy = y + legend.pad + (static_cast<double>(i) + 0.5) * legend.row;
    const double sx0 = x + legend.pad, sx1 = sx0 + legend.sample;
    switch (e.kind) {
      case EntryKind::kScatter:
        set_color(cr, e.color, std::max(e.alpha, 0.85));
        cairo_arc(cr, 0.5 * (sx0 + sx1), cy, std::max(e.size, 3.5), 0, 2 * std::numbers::pi);
        cairo_fill(cr);
        break;
      case EntryKind::kLine:
        set_color(cr, e.color, e.alpha);
        cairo_set_line_width(cr, e.size);
        cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
        cairo_move_to(cr, sx0, cy);
        cairo_line_to(cr, sx1, cy);
        cairo_stroke(cr);
        if (e.markers) {
          cairo_arc(cr, 0.5 * (sx0 + sx1), cy, marker_radius(e.size), 0, 2 * std::numbers::pi);
          cairo_fill(cr);
        }
        break;
      case EntryKind::kReference:
        set_reference_style(cr, e.color, e.dashed, e.size);
        cairo_move_to(cr, sx0, cy);
        cairo_line_to(cr, sx1, cy);
        cairo_stroke(cr);
        cairo_set_dash(cr, nullptr, 0, 0);
        break;
      case EntryKind::kBox:
        set_color(cr, e.color, 1.0);
        cairo_rectangle(cr, sx0, cy - 0.35 * legend.row, legend.sample, 0.7 * legend.row);
        cairo_fill(cr);
        break;
    }
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    draw_text(cr, e.label, sx1 + 0.6 * fonts.legend.size, cy, 0);
  }
}

// The plot area's edges on pixel centres.
struct Frame {
  double x0, y0, x1, y1;
};

// Grid at the major ticks, and fainter at the minor ticks of a log axis.
void draw_grid(cairo_t* cr, const Layout& L, const Frame& frame) {
  const auto [x0, y0, x1, y1] = frame;
  cairo_set_line_width(cr, 1);
  cairo_set_source_rgb(cr, 0.955, 0.955, 0.955);
  for (double pos : L.y_ticks.minor) {
    cairo_move_to(cr, x0, snap(L.py(pos)));
    cairo_line_to(cr, x1, snap(L.py(pos)));
  }
  cairo_stroke(cr);
  cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
  for (const auto& t : L.x_ticks.major) {
    cairo_move_to(cr, snap(L.px(t.pos)), y0);
    cairo_line_to(cr, snap(L.px(t.pos)), y1);
  }
  for (const auto& t : L.y_ticks.major) {
    cairo_move_to(cr, x0, snap(L.py(t.pos)));
    cairo_line_to(cr, x1, snap(L.py(t.pos)));
  }
  cairo_stroke(cr);
}

// Shaded intervals across the plot's height, under the grid.
void draw_bands(cairo_t* cr, const Figure& f, const Layout& L, const Frame& frame) {
  const auto [x0, y0, x1, y1] = frame;
  for (const VerticalBand& b : f.bands) {
    const double left = std::max(x0, std::round(L.px(b.x0))),
                 right = std::min(x1, std::round(L.px(b.x1)));
    if (right <= left) continue;
    set_color(cr, b.color, 1.0);
    cairo_rectangle(cr, left, y0, right - left, y1 - y0);
    cairo_fill(cr);
  }
}

// Bars with edges on whole pixels; outlined in 60 % of their colour when 4 pixels or wider.
void draw_bars(cairo_t* cr, const Figure& f, const Layout& L) {
  cairo_set_line_width(cr, 1);
  for (const Bar& b : f.bars) {
    const double left = std::round(L.px(b.x0)), right = std::round(L.px(b.x1));
    const auto [y_top, y_base] = bar_span(f, L, b);
    const double top = std::round(std::min(y_top, y_base));
    const double base = std::round(std::max(y_top, y_base));
    if (right <= left || base <= top) continue;
    set_color(cr, b.color, 1.0);
    cairo_rectangle(cr, left, top, right - left, base - top);
    cairo_fill(cr);
    if (right - left < 4) continue;
    set_color(cr, {0.6 * b.color[0], 0.6 * b.color[1], 0.6 * b.color[2]}, 1.0);
    cairo_rectangle(cr, left + 0.5, top + 0.5, right - left - 1, base - top - 1);
    cairo_stroke(cr);
  }
}

// Bars, reference lines, then the series, clipped to the plot area.
void draw_data(cairo_t* cr, const Figure& f, const Prepared& p, const Layout& L,
               const Frame& frame) {
  const auto [x0, y0, x1, y1] = frame;
  cairo_save(cr);
  cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
  cairo_clip(cr);
  draw_bars(cr, f, L);
  for (const VerticalLine& v : f.vertical_lines) {
    set_reference_style(cr, v.color, v.dashed, 1.5);
    cairo_move_to(cr, snap(L.px(v.x)), y0);
    cairo_line_to(cr, snap(L.px(v.x)), y1);
    cairo_stroke(cr);
  }
  for (std::size_t i = 0; i < f.lines.size(); ++i) {
    set_reference_style(cr, f.lines[i].color, f.lines[i].dashed, 1.5);
    cairo_move_to(cr, x0, L.py(p.line_y[i]));
    cairo_line_to(cr, x1, L.py(p.line_y[i]));
    cairo_stroke(cr);
  }
  cairo_set_dash(cr, nullptr, 0, 0);
  for (const auto& s : p.series) {
    if (s.finite_count == 0) continue;
    if (s.source->line) {
      draw_polyline(cr, L, s);
    } else {
      draw_scatter(cr, L, s);
    }
  }
  cairo_restore(cr);
}

// The frame and outward ticks.
void draw_frame(cairo_t* cr, const Layout& L, const Frame& frame) {
  const auto [x0, y0, x1, y1] = frame;
  cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
  cairo_set_line_width(cr, 1);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_SQUARE);
  cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
  cairo_stroke(cr);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
  for (const auto& t : L.x_ticks.major) {
    cairo_move_to(cr, snap(L.px(t.pos)), y1);
    cairo_rel_line_to(cr, 0, kTickLength);
  }
  for (const auto& t : L.y_ticks.major) {
    cairo_move_to(cr, x0, snap(L.py(t.pos)));
    cairo_rel_line_to(cr, -kTickLength, 0);
  }
  cairo_stroke(cr);
  for (double pos : L.y_ticks.minor) {
    cairo_move_to(cr, x0, snap(L.py(pos)));
    cairo_rel_line_to(cr, -0.6 * kTickLength, 0);
  }
  cairo_stroke(cr);
}

// The vertical lines' labels in their rows above the plot, centred on the lines but kept inside
// the image.
void draw_vertical_line_labels(cairo_t* cr, const Figure& f, const Layout& L, const Fonts& fonts) {
  set_font(cr, fonts.tick);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  const double margin = fonts.tick.size;
  for (std::size_t i = 0; i < f.vertical_lines.size(); ++i) {
    if (L.label_row[i] < 0) continue;
    const std::string& text = f.vertical_lines[i].label;
    const double half = 0.5 * text_width(cr, text);
    const double cx = std::clamp(L.px(f.vertical_lines[i].x), margin + half,
                                 std::max(margin + half, f.width - margin - half));
    draw_text(cr, text, cx, L.y0 - (L.label_row[i] + 0.5) * L.label_row_h, 0.5);
  }
}

// Tick labels, axis labels and the title.
void draw_labels(cairo_t* cr, const Figure& f, const Layout& L, const Frame& frame,
                 const Fonts& fonts) {
  const auto [x0, y0, x1, y1] = frame;
  // Tick labels.
  const double gap = 0.5 * fonts.tick.size;
  set_font(cr, fonts.tick);
  const double tick_text_h = cap_height(cr);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  for (const auto& t : L.x_ticks.major) {
    draw_text(cr, t.label, L.px(t.pos), y1 + kTickLength + gap + 0.5 * tick_text_h, 0.5);
  }
  double widest_y = 0;
  for (const auto& t : L.y_ticks.major) {
    draw_text(cr, t.label, x0 - kTickLength - gap, L.py(t.pos), 1.0);
    widest_y = std::max(widest_y, text_width(cr, t.label));
  }

  // Axis labels and title.
  set_font(cr, fonts.label);
  const double label_cap = cap_height(cr);
  if (!f.x_label.empty()) {
    draw_text(cr, f.x_label, 0.5 * (x0 + x1),
              y1 + kTickLength + gap + tick_text_h + 2 * gap + 0.5 * label_cap, 0.5);
  }
  if (!f.y_label.empty()) {
    draw_vertical_text(cr, f.y_label, x0 - kTickLength - gap - widest_y - 2 * gap - 0.5 * label_cap,
                       0.5 * (y0 + y1));
  }
  draw_vertical_line_labels(cr, f, L, fonts);
  if (!f.note.empty()) {
    set_font(cr, fonts.legend);
    cairo_set_source_rgb(cr, 0.25, 0.25, 0.25);
    draw_text(cr, f.note, x0, f.height - fonts.tick.size - 0.5 * 1.35 * cap_height(cr), 0);
  }
  if (L.has_title) {
    set_font(cr, fonts.title);
    cairo_set_source_rgb(cr, 0, 0, 0);
    // Centred over the plot, but kept inside the image when it is wider than the plot.
    const double half = 0.5 * text_width(cr, f.title), margin = fonts.tick.size;
    const double cx = std::max(std::min(0.5 * (x0 + x1), f.width - margin - half), margin + half);
    draw_text(cr, f.title, cx, L.title_y, 0.5);
  }
}

void draw(cairo_t* cr, const Figure& f, const Prepared& p) {
  begin_page(cr);
  const Fonts fonts = fonts_for(f.width, f.height);
  const Legend legend = make_legend(cr, f, fonts);
  const Layout L = choose_layout(cr, f, p, fonts, legend);
  const Frame frame{snap(L.x0), snap(L.y0), snap(L.x0 + L.w), snap(L.y0 + L.h)};
  draw_bands(cr, f, L, frame);
  draw_grid(cr, L, frame);
  draw_data(cr, f, p, L, frame);
  draw_frame(cr, L, frame);
  draw_labels(cr, f, L, frame, fonts);
  draw_legend(cr, L, legend, fonts);
}

}  // namespace
}  // namespace detail

void write_figure(const Figure& figure, const std::filesystem::path& stem) {
  const detail::Prepared prepared = detail::prepare(figure);
  detail::write_svg_and_png(stem, figure.width, figure.height,
                            [&](cairo_t* cr) { detail::draw(cr, figure, prepared); });
}

}  // namespace align3d::report
