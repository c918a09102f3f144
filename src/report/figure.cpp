// Figures drawn with cairo. One function per kind of figure (draw() for plots, draw_heatmaps() for
// heat maps) paints it onto any cairo context; it runs once on an SVG surface and once on an ARGB32
// image surface that is saved as PNG, so both files show the same picture. Layout (margins, ticks,
// legend place) is measured with the context being drawn on.
#include "align3d/report/figure.hpp"

#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"

namespace align3d::report {
namespace {

constexpr const char* kFontFamily = "DejaVu Sans";  // fontconfig falls back to the default sans
constexpr double kPadFraction = 0.05;               // data range padding on each side
constexpr int kMaxSide = 16384;                     // cairo's image surface limit is 32767
constexpr std::size_t kMaxMarkedPoints = 200;       // line series with more points get no markers
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

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  double span() const { return hi - lo; }
};

struct Prepared {
  std::vector<PreparedSeries> series;
  std::vector<double> line_y;  // HorizontalLine y in plot coordinates
  Range x, y;                  // padded data range in plot coordinates
};

double clamp01(double v) { return std::isfinite(v) ? std::clamp(v, 0.0, 1.0) : 0.0; }

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
  if (!(x.lo <= x.hi)) throw std::invalid_argument("figure: no series has a finite point to draw");
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
  if (!std::isfinite(p.x.span()) || !std::isfinite(p.y.span())) {
    throw std::invalid_argument("figure: data range too large to plot (beyond 1e307)");
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// Text

struct FontSpec {
  double size;
  bool bold;
};

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

// Height of digits and capitals above the baseline: the box that vertical centring uses.
double cap_height(cairo_t* cr) {
  cairo_text_extents_t e;
  cairo_text_extents(cr, "0", &e);
  return -e.y_bearing;
}

// Draws s with its horizontal anchor at fraction `ha` of its width (0 left, 0.5 centre, 1 right)
// and its capitals vertically centred on y.
void draw_text(cairo_t* cr, const std::string& s, double x, double y, double ha) {
  cairo_move_to(cr, x - ha * text_width(cr, s), y + 0.5 * cap_height(cr));
  cairo_show_text(cr, s.c_str());
}

// ---------------------------------------------------------------------------------------------
// Ticks

struct Tick {
  double pos;  // plot coordinate (log10 of the value on a log axis)
  std::string label;
};

struct Ticks {
  std::vector<Tick> major;
  std::vector<double> minor;
};

// The 1-2-5 step at or above `raw`.
double nice_step(double raw) {
  const double e = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / e;
  return (f <= 1.0 ? 1.0 : f <= 2.0 ? 2.0 : f <= 5.0 ? 5.0 : 10.0) * e;
}

double next_nice_step(double step) { return nice_step(step * 1.01); }

std::string with_unicode_minus(std::string s) {
  if (!s.empty() && s[0] == '-') s.replace(0, 1, "\u2212");
  return s;
}

std::string superscript(int k) {
  static const char* const kDigits[] = {"\u2070", "\u00b9", "\u00b2", "\u00b3", "\u2074",
                                        "\u2075", "\u2076", "\u2077", "\u2078", "\u2079"};
  std::string out = k < 0 ? "\u207b" : "";
  for (char c : std::to_string(std::abs(k))) out += kDigits[c - '0'];
  return out;
}

// A value on a grid of `step`, printed with as many decimals as the step needs; beyond six digits
// before or after the point, as a mantissa with just enough digits and a power of ten: 1.205×10⁷.
std::string format_linear(double v, double step) {
  if (std::abs(v) < step * 1e-6) return "0";
  const int step_exponent = static_cast<int>(std::floor(std::log10(step) + 1e-9));
  char buf[64];
  if (std::max(std::abs(v), step) < 1e6 && step_exponent >= -5) {
    std::snprintf(buf, sizeof buf, "%.*f", std::max(0, -step_exponent), v);
    return with_unicode_minus(buf);
  }
  int k = static_cast<int>(std::floor(std::log10(std::abs(v))));
  const int decimals = std::max(0, k - step_exponent);
  double mantissa = v / std::pow(10.0, k);
  const double rounding = 0.5 * std::pow(10.0, -decimals);
  if (std::abs(mantissa) >= 10 - rounding) {
    ++k;
    mantissa /= 10;
  }
  std::snprintf(buf, sizeof buf, "%.*f", decimals, mantissa);
  return with_unicode_minus(buf) + "\u00d710" + superscript(k);
}

// m * 10^k for a mantissa m in 1..9: plain decimals for 0.001 .. 10000, else 10⁻⁶ or 2×10⁻⁶.
std::string format_power(int m, int k) {
  if (k >= -3 && k <= 4) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.*f", std::max(0, -k), m * std::pow(10.0, k));
    return buf;
  }
  return (m == 1 ? std::string() : std::to_string(m) + "\u00d7") + "10" + superscript(k);
}

Ticks linear_ticks(cairo_t* cr, Range r, double length_px, double target_px, bool horizontal) {
  Ticks t;
  const double target_count = std::max(2.0, length_px / target_px);
  double step = nice_step(r.span() / target_count);
  for (int attempt = 0; attempt < 8; ++attempt) {
    t.major.clear();
    const auto first = static_cast<long long>(std::ceil(r.lo / step - 1e-9));
    const auto last = static_cast<long long>(std::floor(r.hi / step + 1e-9));
    double widest = 0;
    for (long long i = first; i <= last && t.major.size() < 100; ++i) {
      const double v = static_cast<double>(i) * step;
      t.major.push_back({v, format_linear(v, step)});
      widest = std::max(widest, text_width(cr, t.major.back().label));
    }
    // Horizontal labels must not touch each other; vertical ones are spaced by target_px already.
    const double step_px = step / r.span() * length_px;
    if (!horizontal || widest + 12 <= step_px) break;
    step = next_nice_step(step);
  }
  return t;
}

Ticks log_ticks(cairo_t* cr, Range r, double length_px) {
  Ticks t;
  const double max_major = std::max(2.0, std::floor(length_px / 40));
  const int k0 = static_cast<int>(std::ceil(r.lo - 1e-9));
  const int k1 = static_cast<int>(std::floor(r.hi + 1e-9));
  const int decades = k1 - k0 + 1;
  const double decade_px = length_px / r.span();
  if (decades >= 2) {
    const int stride = static_cast<int>(std::ceil(decades / max_major));
    for (int k = k0; k <= k1; ++k) {
      if (((k % stride) + stride) % stride == 0)
        t.major.push_back({static_cast<double>(k), format_power(1, k)});
    }
    if (stride == 1 && decade_px >= 25) {
      for (int k = k0 - 1; k <= k1; ++k) {
        for (int m = 2; m <= 9; ++m) {
          const double pos = k + std::log10(m);
          if (pos >= r.lo && pos <= r.hi) t.minor.push_back(pos);
        }
      }
    }
    return t;
  }
  // Less than two decades visible: label 1, 2 and 5 times powers of ten.
  for (int k = static_cast<int>(std::floor(r.lo)) - 1; k <= static_cast<int>(std::ceil(r.hi));
       ++k) {
    for (int m = 1; m <= 9; ++m) {
      const double pos = k + std::log10(m);
      if (pos < r.lo - 1e-9 || pos > r.hi + 1e-9) continue;
      if (m == 1 || m == 2 || m == 5) {
        t.major.push_back({pos, format_power(m, k)});
      } else {
        t.minor.push_back(pos);
      }
    }
  }
  if (t.major.size() >= 2) return t;
  // Within a factor of ~2.5: ordinary 1-2-5 steps of the value, placed logarithmically.
  t = {};
  const Range values{std::pow(10.0, r.lo), std::pow(10.0, r.hi)};
  for (const Tick& lin : linear_ticks(cr, values, length_px, 60, false).major) {
    if (lin.pos > 0) t.major.push_back({std::log10(lin.pos), lin.label});
  }
  return t;
}

// ---------------------------------------------------------------------------------------------
// Layout

struct Fonts {
  FontSpec title, label, tick, legend;
};

Fonts fonts_for(double width, double height, double min_scale = 0.85) {
  // Sizes in pixels for the default 900 x 600 figure, scaled with the figure's smaller side.
  // Small figures keep text readable rather than proportional.
  const double s = std::clamp(std::min(width / 900.0, height / 600.0), min_scale, 3.0);
  return {{17 * s, true}, {14 * s, false}, {12 * s, false}, {12.5 * s, false}};
}

enum class EntryKind { kScatter, kLine, kReference };

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
  double title_y = 0;  // centre of the title's capitals

  double px(double x_value) const { return x0 + (x_value - x.lo) / x.span() * w; }
  double py(double y_value) const { return y0 + h - (y_value - y.lo) / y.span() * h; }
};

enum class LegendPlace { kUpperRight, kUpperLeft, kLowerLeft, kLowerRight, kOutside };

constexpr double kTickLength = 5;

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
  const double bottom =
      kTickLength + gap + tick_text_h + (f.x_label.empty() ? 0 : 2 * gap + label_h) + pad;
  L.y0 = top;
  L.h = std::max(10.0, f.height - top - bottom);

  double left = pad + 40, right = pad;
  L.x = p.x;
  L.y = p.y;
  for (int pass = 0; pass < 4; ++pass) {
    L.x0 = left;
    L.w = std::max(10.0, f.width - left - right);
    L.x = p.x;
    L.y = p.y;
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
    if (new_left == left && new_right == right) break;
    left = new_left;
    right = new_right;
  }

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
double legend_overlap(const Layout& L, const Prepared& p, const Legend& legend) {
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
    if (fits && legend_overlap(L, p, legend) == 0) return L;
  }
  return make_layout(cr, f, p, fonts, legend, LegendPlace::kOutside);
}

// ---------------------------------------------------------------------------------------------
// Drawing

// Crisp 1-pixel lines: put coordinates on pixel centres.
double snap(double v) { return std::floor(v) + 0.5; }

void set_color(cairo_t* cr, const Rgb& c, double alpha) {
  cairo_set_source_rgba(cr, clamp01(c[0]), clamp01(c[1]), clamp01(c[2]), clamp01(alpha));
}

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
    }
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    draw_text(cr, e.label, sx1 + 0.6 * fonts.legend.size, cy, 0);
  }
}

// Text options shared by every figure, and a white page.
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

// Text rotated to read upwards, centred on (x, y).
void draw_vertical_text(cairo_t* cr, const std::string& s, double x, double y) {
  cairo_save(cr);
  cairo_translate(cr, x, y);
  cairo_rotate(cr, -std::numbers::pi / 2);
  draw_text(cr, s, 0, 0, 0.5);
  cairo_restore(cr);
}

void draw(cairo_t* cr, const Figure& f, const Prepared& p) {
  begin_page(cr);
  const Fonts fonts = fonts_for(f.width, f.height);
  const Legend legend = make_legend(cr, f, fonts);
  const Layout L = choose_layout(cr, f, p, fonts, legend);
  const double x0 = snap(L.x0), y0 = snap(L.y0);
  const double x1 = snap(L.x0 + L.w), y1 = snap(L.y0 + L.h);

  // Grid at the major ticks, and fainter at the minor ticks of a log axis.
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

  // Data, clipped to the plot area.
  cairo_save(cr);
  cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
  cairo_clip(cr);
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

  // Frame and outward ticks.
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
  if (L.has_title) {
    set_font(cr, fonts.title);
    cairo_set_source_rgb(cr, 0, 0, 0);
    // Centred over the plot, but kept inside the image when it is wider than the plot.
    const double half = 0.5 * text_width(cr, f.title), margin = fonts.tick.size;
    const double cx = std::max(std::min(0.5 * (x0 + x1), f.width - margin - half), margin + half);
    draw_text(cr, f.title, cx, L.title_y, 0.5);
  }

  draw_legend(cr, L, legend, fonts);
}

// ---------------------------------------------------------------------------------------------
// Heat maps

// Viridis (matplotlib's default map: perceptually uniform, monotonic in lightness, so it reads in
// gray and for colour-blind readers) sampled at ten evenly spaced points; between them, colours
// are interpolated linearly in sRGB.
constexpr Rgb hex_color(std::uint32_t v) {
  return {((v >> 16) & 0xff) / 255.0, ((v >> 8) & 0xff) / 255.0, (v & 0xff) / 255.0};
}
constexpr std::array<Rgb, 10> kViridis = {
    hex_color(0x440154), hex_color(0x482878), hex_color(0x3e4989), hex_color(0x31688e),
    hex_color(0x26828e), hex_color(0x1f9e89), hex_color(0x35b779), hex_color(0x6ece58),
    hex_color(0xb5de2b), hex_color(0xfde725)};

constexpr Rgb kNoDataFill{0.9, 0.9, 0.9};
constexpr Rgb kNoDataHatch{0.68, 0.68, 0.68};

// t in [0, 1] (clamped; NaN as 0) to a colour; the ends are exactly the first and last anchors.
Rgb colormap(double t) {
  const double s = (t > 0 ? std::min(t, 1.0) : 0.0) * static_cast<double>(kViridis.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(s), kViridis.size() - 2);
  const double f = s - static_cast<double>(i);
  Rgb c;
  for (int k = 0; k < 3; ++k) c[k] = (1 - f) * kViridis[i][k] + f * kViridis[i + 1][k];
  return c;
}

// WCAG relative luminance of an sRGB colour.
double luminance(const Rgb& c) {
  auto linear = [](double v) {
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
  };
  return 0.2126 * linear(c[0]) + 0.7152 * linear(c[1]) + 0.0722 * linear(c[2]);
}

// Black text on cells brighter than this, white on darker ones: the luminance L where both have
// the same WCAG contrast ratio, (L + 0.05) / 0.05 = 1.05 / (L + 0.05).
constexpr double kBlackTextAbove = 0.179;

enum class ValueFormat { kPercent, kFixed2 };

ValueFormat parse_value_format(const std::string& name, const std::string& where) {
  if (name == "percent") return ValueFormat::kPercent;
  if (name == "fixed2") return ValueFormat::kFixed2;
  throw std::invalid_argument(where + ": value_format must be \"percent\" or \"fixed2\", got \"" +
                              name + "\"");
}

std::string format_value(double v, ValueFormat format) {
  char buf[64];
  if (format == ValueFormat::kPercent) {
    std::snprintf(buf, sizeof buf, "%.0f%%", std::round(v * 100) + 0.0);  // + 0.0: no "-0%"
  } else {
    std::snprintf(buf, sizeof buf, "%.2f", std::round(v * 100) / 100 + 0.0);
  }
  return with_unicode_minus(buf);
}

struct HeatPrepared {
  std::vector<const HeatMap*> panels;
  std::vector<ValueFormat> formats;  // per panel
  std::vector<bool> show_y;          // per panel: row labels and y label printed
  std::string title;
  std::string value_label;
  double lo = 0, hi = 1;
  bool any_missing = false;  // some cell is non-finite: the colour bar gets a "no data" key
  int width = 0, height = 0;
};

HeatPrepared prepare_heatmaps(const std::vector<HeatMap>& panels, const std::string& title) {
  if (panels.empty()) throw std::invalid_argument("heat map: no panels to draw");
  HeatPrepared p;
  p.title = title;
  std::int64_t total_width = 0;
  for (std::size_t i = 0; i < panels.size(); ++i) {
    const HeatMap& m = panels[i];
    const std::string where =
        panels.size() == 1 ? std::string("heat map")
                           : "heat map panel " + std::to_string(i + 1) + " '" + m.title + "'";
    if (m.width < 64 || m.height < 64 || m.width > kMaxSide || m.height > kMaxSide) {
      throw std::invalid_argument(where + ": width and height must be in [64, 16384] pixels, got " +
                                  std::to_string(m.width) + " x " + std::to_string(m.height));
    }
    if (m.values.size() == 0) throw std::invalid_argument(where + ": no values");
    if (m.x_ticks.size() != static_cast<std::size_t>(m.values.cols()) ||
        m.y_ticks.size() != static_cast<std::size_t>(m.values.rows())) {
      throw std::invalid_argument(
          where + ": " + std::to_string(m.values.rows()) + " x " + std::to_string(m.values.cols()) +
          " values (rows x columns) need as many y and x tick "
          "labels, got " +
          std::to_string(m.y_ticks.size()) + " and " + std::to_string(m.x_ticks.size()));
    }
    if (!std::isfinite(m.min_value) || !std::isfinite(m.max_value) ||
        !(m.min_value < m.max_value) || !std::isfinite(m.max_value - m.min_value)) {
      throw std::invalid_argument(where + ": colour range [" + std::to_string(m.min_value) + ", " +
                                  std::to_string(m.max_value) +
                                  "] must be finite with min_value < max_value");
    }
    if (i > 0 && (m.min_value != panels[0].min_value || m.max_value != panels[0].max_value)) {
      throw std::invalid_argument(where +
                                  ": the panels share one colour bar, so they need the "
                                  "same min_value and max_value as the first panel");
    }
    p.formats.push_back(parse_value_format(m.value_format, where));
    p.show_y.push_back(i == 0 || m.y_ticks != panels[i - 1].y_ticks ||
                       m.y_label != panels[i - 1].y_label);
    if (p.value_label.empty()) p.value_label = m.value_label;
    p.any_missing = p.any_missing || !m.values.allFinite();
    p.panels.push_back(&m);
    total_width += m.width;
    p.height = std::max(p.height, m.height);
  }
  if (total_width > kMaxSide) {
    throw std::invalid_argument("heat maps: the panels' widths add up to " +
                                std::to_string(total_width) + " pixels, more than 16384");
  }
  p.width = static_cast<int>(total_width);
  p.lo = panels[0].min_value;
  p.hi = panels[0].max_value;
  return p;
}

struct HeatLayout {
  struct Grid {
    double x0, y0, w, h;  // cell area in pixels (y0 is the top)
    double widest_y_tick;
  };
  std::vector<Grid> grids;
  double title_y = 0, panel_title_y = 0;  // centres of the titles' capitals
  double bar_x0 = 0, bar_w = 0;           // colour bar; it spans the grids' height
  Ticks bar_ticks;                        // positions in values
  double widest_bar_tick = 0;
  double annotation_size = 0;  // font size of the cell values; 0: none
};

FontSpec panel_title_font(const Fonts& fonts) { return {fonts.label.size, true}; }

constexpr const char* kNoDataText = "no data";

HeatLayout layout_heatmaps(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts) {
  HeatLayout L;
  const double pad = fonts.tick.size, gap = 0.5 * fonts.tick.size;
  set_font(cr, fonts.tick);
  const double tick_h = cap_height(cr);
  set_font(cr, fonts.label);
  const double label_h = cap_height(cr) * 1.35;  // room for descenders

  // Vertical: title, panel titles, grids, column labels, x labels. The same for every panel, so
  // the grids line up.
  double top = pad;
  if (!p.title.empty()) {
    set_font(cr, fonts.title);
    L.title_y = top + 0.5 * cap_height(cr);
    top += 1.35 * cap_height(cr) + 1.2 * gap;
  }
  const bool panel_titles = std::any_of(p.panels.begin(), p.panels.end(),
                                        [](const HeatMap* m) { return !m->title.empty(); });
  if (panel_titles) {
    set_font(cr, panel_title_font(fonts));
    L.panel_title_y = top + 0.5 * cap_height(cr);
    top += 1.35 * cap_height(cr) + gap;
  } else {
    top += 0.5 * tick_h;  // the colour bar's top label is centred on the bar's top end
  }
  const bool x_labels = std::any_of(p.panels.begin(), p.panels.end(),
                                    [](const HeatMap* m) { return !m->x_label.empty(); });
  const double bottom = gap + 1.35 * tick_h + (x_labels ? 2 * gap + label_h : 0) + pad;
  const double grid_h = std::max(10.0, p.height - top - bottom);

  // The colour bar's column on the right: bar, ticks and labels, value label; the "no data" key
  // goes under it, in the row of the column labels.
  set_font(cr, fonts.tick);
  const double scale = p.formats[0] == ValueFormat::kPercent ? 100 : 1;
  L.bar_ticks = linear_ticks(cr, {p.lo * scale, p.hi * scale}, grid_h, 55, false);
  for (Tick& t : L.bar_ticks.major) {
    t.pos /= scale;
    if (p.formats[0] == ValueFormat::kPercent) t.label += "%";
    L.widest_bar_tick = std::max(L.widest_bar_tick, text_width(cr, t.label));
  }
  L.bar_w = std::round(1.4 * fonts.tick.size);
  double bar_column = L.bar_w + kTickLength + gap + L.widest_bar_tick +
                      (p.value_label.empty() ? 0 : 2 * gap + label_h);
  if (p.any_missing) {
    bar_column = std::max(bar_column, 1.6 * tick_h + gap + text_width(cr, kNoDataText));
  }

  // Horizontal: per panel, its row labels and y label, then its grid; the grids share what is
  // left in proportion to the panels' widths.
  std::vector<double> left(p.panels.size(), 0.0), widest(p.panels.size(), 0.0);
  double fixed = 2 * pad + 2 * pad + bar_column, width_sum = 0;  // margins, gap before the bar
  for (std::size_t i = 0; i < p.panels.size(); ++i) {
    const HeatMap& m = *p.panels[i];
    for (const auto& t : m.y_ticks) widest[i] = std::max(widest[i], text_width(cr, t));
    if (p.show_y[i]) left[i] = widest[i] + gap + (m.y_label.empty() ? 0 : label_h + 2 * gap);
    fixed += left[i] + (i > 0 ? 2 * pad : 0);
    width_sum += m.width;
  }
  const double available = p.width - fixed;
  double x = pad;
  for (std::size_t i = 0; i < p.panels.size(); ++i) {
    x += left[i];
    const double w = std::max(10.0, available * p.panels[i]->width / width_sum);
    L.grids.push_back({x, top, w, grid_h, widest[i]});
    x += w + 2 * pad;
  }
  L.bar_x0 = std::round(x);

  // Cell values: the tick font, shrunk to fit the smallest cell with air around the text; left out
  // below 7 pixels.
  constexpr double kReference = 10;
  set_font(cr, {kReference, false});
  const double cap_per_size = cap_height(cr) / kReference;
  double size = fonts.tick.size;
  bool any = false;
  for (std::size_t i = 0; i < p.panels.size(); ++i) {
    const HeatMap& m = *p.panels[i];
    if (!m.annotate) continue;
    double widest_value = 0;
    for (Eigen::Index r = 0; r < m.values.rows(); ++r) {
      for (Eigen::Index c = 0; c < m.values.cols(); ++c) {
        if (!std::isfinite(m.values(r, c))) continue;
        widest_value = std::max(
            widest_value, text_width(cr, format_value(m.values(r, c), p.formats[i])) / kReference);
        any = true;
      }
    }
    const double cell_w = L.grids[i].w / static_cast<double>(m.values.cols());
    const double cell_h = L.grids[i].h / static_cast<double>(m.values.rows());
    if (widest_value > 0) size = std::min(size, 0.75 * cell_w / widest_value);
    size = std::min(size, 0.45 * cell_h / cap_per_size);
  }
  L.annotation_size = any && size >= 7 ? size : 0;
  return L;
}

// Light gray with diagonal hatching: a cell (or key) without data.
void draw_no_data(cairo_t* cr, double x0, double y0, double x1, double y1) {
  cairo_save(cr);
  cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
  set_color(cr, kNoDataFill, 1);
  cairo_fill_preserve(cr);
  cairo_clip(cr);
  set_color(cr, kNoDataHatch, 1);
  cairo_set_line_width(cr, 1);
  constexpr double kSpacing = 5;
  for (double d = -(y1 - y0); d < x1 - x0; d += kSpacing) {
    cairo_move_to(cr, x0 + d, y1);
    cairo_line_to(cr, x0 + d + (y1 - y0), y0);
  }
  cairo_stroke(cr);
  cairo_restore(cr);
}

// Every `stride`-th label, so labels of width `widest` at `spacing` pixels keep `air` between them.
int label_stride(double widest, double spacing, double air) {
  return std::max(1, static_cast<int>(std::ceil((widest + air) / std::max(spacing, 1.0))));
}

void draw_heat_panel(cairo_t* cr, const HeatMap& m, ValueFormat format, bool show_y,
                     const HeatLayout::Grid& g, const HeatLayout& L, const Fonts& fonts, double lo,
                     double hi) {
  const Eigen::Index rows = m.values.rows(), cols = m.values.cols();
  const double cell_w = g.w / static_cast<double>(cols), cell_h = g.h / static_cast<double>(rows);
  // Cell edges on whole pixels, so colours are crisp; row 0 at the bottom.
  auto x_edge = [&](Eigen::Index c) { return std::round(g.x0 + static_cast<double>(c) * cell_w); };
  auto y_edge = [&](Eigen::Index r) {
    return std::round(g.y0 + g.h - static_cast<double>(r) * cell_h);
  };
  // White borders: 2 pixels between cells of 20 pixels or more, else 1, none below 4.
  const double smaller = std::min(cell_w, cell_h);
  const double border = smaller >= 20 ? 2 : smaller >= 4 ? 1 : 0;
  const double before = std::floor(border / 2), after = border - before;

  for (Eigen::Index r = 0; r < rows; ++r) {
    for (Eigen::Index c = 0; c < cols; ++c) {
      const double x0 = x_edge(c) + before, x1 = x_edge(c + 1) - after;
      const double y0 = y_edge(r + 1) + before, y1 = y_edge(r) - after;
      if (x1 <= x0 || y1 <= y0) continue;
      const double v = m.values(r, c);
      if (!std::isfinite(v)) {
        draw_no_data(cr, x0, y0, x1, y1);
        continue;
      }
      set_color(cr, colormap((v - lo) / (hi - lo)), 1);
      cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
      cairo_fill(cr);
    }
  }

  if (m.annotate && L.annotation_size > 0) {
    set_font(cr, {L.annotation_size, false});
    for (Eigen::Index r = 0; r < rows; ++r) {
      for (Eigen::Index c = 0; c < cols; ++c) {
        const double v = m.values(r, c);
        if (!std::isfinite(v)) continue;
        const bool dark = luminance(colormap((v - lo) / (hi - lo))) <= kBlackTextAbove;
        cairo_set_source_rgb(cr, dark ? 1.0 : 0.0, dark ? 1.0 : 0.0, dark ? 1.0 : 0.0);
        draw_text(cr, format_value(v, format), 0.5 * (x_edge(c) + x_edge(c + 1)),
                  0.5 * (y_edge(r) + y_edge(r + 1)), 0.5);
      }
    }
  }

  // Labels centred on the cells, thinned out when they would touch.
  const double gap = 0.5 * fonts.tick.size;
  set_font(cr, fonts.tick);
  const double tick_h = cap_height(cr);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  double widest_x = 0;
  for (const auto& t : m.x_ticks) widest_x = std::max(widest_x, text_width(cr, t));
  const int x_stride = label_stride(widest_x, cell_w, gap);
  const double label_row = g.y0 + g.h + gap + 0.5 * tick_h;
  for (Eigen::Index c = 0; c < cols; c += x_stride) {
    draw_text(cr, m.x_ticks[static_cast<std::size_t>(c)],
              g.x0 + (static_cast<double>(c) + 0.5) * cell_w, label_row, 0.5);
  }
  if (show_y) {
    const int y_stride = label_stride(tick_h, cell_h, 0.5 * tick_h);
    for (Eigen::Index r = 0; r < rows; r += y_stride) {
      draw_text(cr, m.y_ticks[static_cast<std::size_t>(r)], g.x0 - gap,
                g.y0 + g.h - (static_cast<double>(r) + 0.5) * cell_h, 1.0);
    }
  }

  set_font(cr, fonts.label);
  const double label_cap = cap_height(cr);
  if (!m.x_label.empty()) {
    draw_text(cr, m.x_label, g.x0 + 0.5 * g.w, label_row + 0.5 * tick_h + 2 * gap + 0.5 * label_cap,
              0.5);
  }
  if (show_y && !m.y_label.empty()) {
    draw_vertical_text(cr, m.y_label, g.x0 - gap - g.widest_y_tick - 2 * gap - 0.5 * label_cap,
                       g.y0 + 0.5 * g.h);
  }
  if (!m.title.empty()) {
    set_font(cr, panel_title_font(fonts));
    cairo_set_source_rgb(cr, 0, 0, 0);
    draw_text(cr, m.title, g.x0 + 0.5 * g.w, L.panel_title_y, 0.5);
  }
}

// The colour bar: the map as a vertical gradient from lo (bottom) to hi, outward ticks and labels
// on its right, the value label beyond them, and the "no data" key under it.
void draw_colour_bar(cairo_t* cr, const HeatPrepared& p, const HeatLayout& L, const Fonts& fonts) {
  const HeatLayout::Grid& g = L.grids.front();
  const double x0 = L.bar_x0, x1 = L.bar_x0 + L.bar_w;
  const double y0 = std::round(g.y0), y1 = std::round(g.y0 + g.h);
  cairo_pattern_t* gradient = cairo_pattern_create_linear(0, y1, 0, y0);
  for (std::size_t i = 0; i < kViridis.size(); ++i) {
    const Rgb& c = kViridis[i];
    cairo_pattern_add_color_stop_rgb(gradient, static_cast<double>(i) / (kViridis.size() - 1), c[0],
                                     c[1], c[2]);
  }
  cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
  cairo_set_source(cr, gradient);
  cairo_fill(cr);
  cairo_pattern_destroy(gradient);

  const double gap = 0.5 * fonts.tick.size;
  auto py = [&](double v) { return y1 - (v - p.lo) / (p.hi - p.lo) * (y1 - y0); };
  cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
  cairo_set_line_width(cr, 1);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
  for (const auto& t : L.bar_ticks.major) {
    const double y = std::clamp(snap(py(t.pos)), y0 + 0.5, y1 - 0.5);
    cairo_move_to(cr, x1, y);
    cairo_rel_line_to(cr, kTickLength, 0);
  }
  cairo_stroke(cr);
  set_font(cr, fonts.tick);
  const double tick_h = cap_height(cr);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  for (const auto& t : L.bar_ticks.major) {
    draw_text(cr, t.label, x1 + kTickLength + gap, py(t.pos), 0);
  }
  if (p.any_missing) {
    const double s = std::round(1.3 * tick_h), cy = y1 + gap + 0.5 * 1.35 * tick_h;
    draw_no_data(cr, x0, std::round(cy - 0.5 * s), x0 + s, std::round(cy - 0.5 * s) + s);
    cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    draw_text(cr, kNoDataText, x0 + s + 0.6 * gap, cy, 0);
  }
  if (!p.value_label.empty()) {
    set_font(cr, fonts.label);
    draw_vertical_text(cr, p.value_label,
                       x1 + kTickLength + gap + L.widest_bar_tick + 2 * gap + 0.5 * cap_height(cr),
                       0.5 * (y0 + y1));
  }
}

void draw_heatmaps(cairo_t* cr, const HeatPrepared& p) {
  begin_page(cr);
  // Text sized for one panel, as if it were a figure of its own, but no smaller than a 900 x 600
  // plot's: a heat map is read at a glance, and its cells carry text too.
  const Fonts fonts = fonts_for(static_cast<double>(p.width) / p.panels.size(), p.height, 1.0);
  const HeatLayout L = layout_heatmaps(cr, p, fonts);
  for (std::size_t i = 0; i < p.panels.size(); ++i) {
    draw_heat_panel(cr, *p.panels[i], p.formats[i], p.show_y[i], L.grids[i], L, fonts, p.lo, p.hi);
  }
  draw_colour_bar(cr, p, L, fonts);
  if (!p.title.empty()) {
    set_font(cr, fonts.title);
    cairo_set_source_rgb(cr, 0, 0, 0);
    // Centred over the grids, but kept inside the image.
    const double cx = 0.5 * (L.grids.front().x0 + L.grids.back().x0 + L.grids.back().w);
    const double half = 0.5 * text_width(cr, p.title), margin = fonts.tick.size;
    draw_text(cr, p.title, std::max(std::min(cx, p.width - margin - half), margin + half),
              L.title_y, 0.5);
  }
}

// ---------------------------------------------------------------------------------------------
// Surfaces

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

void check(cairo_status_t status, const std::filesystem::path& destination) {
  if (status != CAIRO_STATUS_SUCCESS) {
    throw OutputError(destination.string() + ": cannot write: " + cairo_status_to_string(status));
  }
}

using Painter = std::function<void(cairo_t*)>;

void render(cairo_surface_t* surface, const Painter& paint,
            const std::filesystem::path& destination) {
  check(cairo_surface_status(surface), destination);
  const ContextPtr cr(cairo_create(surface));
  check(cairo_status(cr.get()), destination);
  paint(cr.get());
  if (cairo_status(cr.get()) == CAIRO_STATUS_INVALID_STRING) {
    throw std::invalid_argument("figure: a title, label, tick or legend text is not valid UTF-8");
  }
  check(cairo_status(cr.get()), destination);
}

void write_svg(const Painter& paint, int width, int height, const std::filesystem::path& tmp,
               const std::filesystem::path& destination) {
  const SurfacePtr surface(cairo_svg_surface_create(tmp.c_str(), width, height));
  render(surface.get(), paint, destination);
  cairo_surface_finish(surface.get());  // writes and closes the file; errors land in the status
  check(cairo_surface_status(surface.get()), destination);
}

void write_png(const Painter& paint, int width, int height, const std::filesystem::path& tmp,
               const std::filesystem::path& destination) {
  const SurfacePtr surface(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width, height));
  render(surface.get(), paint, destination);
  cairo_surface_flush(surface.get());
  check(cairo_surface_write_to_png(surface.get(), tmp.c_str()), destination);
}

std::filesystem::path with_suffix(const std::filesystem::path& stem, const char* suffix) {
  auto path = stem;
  path += suffix;
  return path;
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

}  // namespace

void write_figure(const Figure& figure, const std::filesystem::path& stem) {
  const Prepared prepared = prepare(figure);
  write_svg_and_png(stem, figure.width, figure.height,
                    [&](cairo_t* cr) { draw(cr, figure, prepared); });
}

void write_heatmap(const HeatMap& map, const std::filesystem::path& stem) {
  // One panel under the map's title, which is then the figure's title.
  HeatMap panel = map;
  panel.title.clear();
  write_heatmaps({panel}, map.title, stem);
}

void write_heatmaps(const std::vector<HeatMap>& panels, const std::string& title,
                    const std::filesystem::path& stem) {
  const HeatPrepared prepared = prepare_heatmaps(panels, title);
  write_svg_and_png(stem, prepared.width, prepared.height,
                    [&](cairo_t* cr) { draw_heatmaps(cr, prepared); });
}

}  // namespace align3d::report
