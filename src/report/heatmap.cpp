// Heat maps (heatmap.hpp): cells coloured by a viridis map, with their values, row and column
// labels, and one colour bar for all panels.
#include "align3d/report/heatmap.hpp"

#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "canvas.hpp"
#include "ticks.hpp"

namespace align3d::report {
namespace detail {
namespace {

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
  std::size_t columns = 1;       // panels per row
  std::vector<int> row_heights;  // each row's tallest panel
  std::size_t rows() const { return row_heights.size(); }
};

HeatPrepared prepare_heatmaps(const std::vector<HeatMap>& panels, const std::string& title,
                              std::size_t columns) {
  if (panels.empty()) throw std::invalid_argument("heat map: no panels to draw");
  HeatPrepared p;
  p.title = title;
  p.columns = columns == 0 ? panels.size() : std::min(columns, panels.size());
  std::int64_t row_width = 0, widest_row = 0, total_height = 0;
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
    p.show_y.push_back(i % p.columns == 0 || m.y_ticks != panels[i - 1].y_ticks ||
                       m.y_label != panels[i - 1].y_label);
    if (p.value_label.empty()) p.value_label = m.value_label;
    p.any_missing = p.any_missing || !m.values.allFinite();
    p.panels.push_back(&m);
    if (i % p.columns == 0) row_width = 0, p.row_heights.push_back(0);
    row_width += m.width;
    widest_row = std::max(widest_row, row_width);
    p.row_heights.back() = std::max(p.row_heights.back(), m.height);
  }
  for (const int h : p.row_heights) total_height += h;
  if (widest_row > kMaxSide || total_height > kMaxSide) {
    throw std::invalid_argument("heat maps: the panels add up to " + std::to_string(widest_row) +
                                " x " + std::to_string(total_height) +
                                " pixels, more than 16384 a side");
  }
  p.width = static_cast<int>(widest_row);
  p.height = static_cast<int>(total_height);
  p.lo = panels[0].min_value;
  p.hi = panels[0].max_value;
  return p;
}

struct HeatLayout {
  struct Grid {
    double x0, y0, w, h;  // cell area in pixels (y0 is the top)
    double widest_y_tick;
    double title_y;  // centre of the panel title's capitals
  };
  std::vector<Grid> grids;
  double title_y = 0;            // centre of the figure title's capitals
  double bar_x0 = 0, bar_w = 0;  // colour bar; it spans the first row's grids
  Ticks bar_ticks;               // positions in values
  double widest_bar_tick = 0;
  double annotation_size = 0;  // font size of the cell values; 0: none
};

FontSpec panel_title_font(const Fonts& fonts) { return {fonts.label.size, true}; }

constexpr const char* kNoDataText = "no data";

// Spacing and text heights shared by the parts of the layout.
struct Spacing {
  double pad;      // outer margin
  double gap;      // between a label and what it labels
  double tick_h;   // capitals of the tick font
  double label_h;  // a line of the label font, with room for descenders
};

// Vertical: the figure's title on top; sets its position and returns the height it takes.
double layout_title(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts, const Spacing& sp,
                    HeatLayout& L) {
  double top = sp.pad;
  if (!p.title.empty()) {
    set_font(cr, fonts.title);
    L.title_y = top + 0.5 * cap_height(cr);
    top += 1.35 * cap_height(cr) + 1.2 * sp.gap;
  }
  return top;
}

// Vertical, in each row: the panel titles above the grids, the same height for every panel so the
// grids line up. Returns the height they take; `title_y` their centre below the row's top.
double layout_panel_titles(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts,
                           const Spacing& sp, double& title_y) {
  const bool panel_titles = std::any_of(p.panels.begin(), p.panels.end(),
                                        [](const HeatMap* m) { return !m->title.empty(); });
  if (!panel_titles) return 0.5 * sp.tick_h;  // the colour bar's top label is centred on its end
  set_font(cr, panel_title_font(fonts));
  title_y = 0.5 * cap_height(cr);
  return 1.35 * cap_height(cr) + sp.gap;
}

// The colour bar's column on the right: bar, ticks and labels, value label; the "no data" key
// goes under it, in the row of the column labels. Sets the bar's ticks and width; returns the
// column's width.
double layout_colour_bar(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts, const Spacing& sp,
                         double grid_h, HeatLayout& L) {
  set_font(cr, fonts.tick);
  const double scale = p.formats[0] == ValueFormat::kPercent ? 100 : 1;
  L.bar_ticks = linear_ticks(cr, {p.lo * scale, p.hi * scale}, grid_h, 55, false);
  for (Tick& t : L.bar_ticks.major) {
    t.pos /= scale;
    if (p.formats[0] == ValueFormat::kPercent) t.label += "%";
    L.widest_bar_tick = std::max(L.widest_bar_tick, text_width(cr, t.label));
  }
  L.bar_w = std::round(1.4 * fonts.tick.size);
  double bar_column = L.bar_w + kTickLength + sp.gap + L.widest_bar_tick +
                      (p.value_label.empty() ? 0 : 2 * sp.gap + sp.label_h);
  if (p.any_missing) {
    bar_column = std::max(bar_column, 1.6 * sp.tick_h + sp.gap + text_width(cr, kNoDataText));
  }
  return bar_column;
}

// Horizontal, in the row of panels [first, last): per panel, its row labels and y label, then its
// grid; the grids share what is left after the margins and the colour bar's column (kept free in
// every row, so that rows of the same panels line up) in proportion to the panels' widths. Adds
// the grids, from `top`, `grid_h` tall, and sets the colour bar's left edge after the first row.
void layout_grids(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts, const Spacing& sp,
                  std::size_t first, std::size_t last, double top, double grid_h, double title_y,
                  double bar_column, HeatLayout& L) {
  set_font(cr, fonts.tick);
  std::vector<double> left(p.panels.size(), 0.0), widest(p.panels.size(), 0.0);
  double fixed = 2 * sp.pad + 2 * sp.pad + bar_column, width_sum = 0;  // margins, gap before bar
  for (std::size_t i = first; i < last; ++i) {
    const HeatMap& m = *p.panels[i];
    for (const auto& t : m.y_ticks) widest[i] = std::max(widest[i], text_width(cr, t));
    if (p.show_y[i]) {
      left[i] = widest[i] + sp.gap + (m.y_label.empty() ? 0 : sp.label_h + 2 * sp.gap);
    }
    fixed += left[i] + (i > first ? 2 * sp.pad : 0);
    width_sum += m.width;
  }
  const double available = p.width - fixed;
  double x = sp.pad;
  for (std::size_t i = first; i < last; ++i) {
    x += left[i];
    const double w = std::max(10.0, available * p.panels[i]->width / width_sum);
    L.grids.push_back({x, top, w, grid_h, widest[i], title_y});
    x += w + 2 * sp.pad;
  }
  if (first == 0) L.bar_x0 = std::round(x);
}

// Font size of the cell values: the tick font, shrunk to fit the smallest cell with air around the
// text; 0 (values left out) below 7 pixels or when no panel prints its values.
double annotation_size(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts,
                       const std::vector<HeatLayout::Grid>& grids) {
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
    const double cell_w = grids[i].w / static_cast<double>(m.values.cols());
    const double cell_h = grids[i].h / static_cast<double>(m.values.rows());
    if (widest_value > 0) size = std::min(size, 0.75 * cell_w / widest_value);
    size = std::min(size, 0.45 * cell_h / cap_per_size);
  }
  return any && size >= 7 ? size : 0;
}

// Top to bottom: title, then per row of panels: panel titles, grids, column labels, x labels (the
// rows share the height below the title in proportion to their tallest panels); left to right: per
// panel its row labels, y label and grid, then the colour bar's column (beside the first row).
HeatLayout layout_heatmaps(cairo_t* cr, const HeatPrepared& p, const Fonts& fonts) {
  HeatLayout L;
  Spacing sp{fonts.tick.size, 0.5 * fonts.tick.size, 0, 0};
  set_font(cr, fonts.tick);
  sp.tick_h = cap_height(cr);
  set_font(cr, fonts.label);
  sp.label_h = cap_height(cr) * 1.35;

  double top = layout_title(cr, p, fonts, sp, L);
  double title_y = 0;
  const double titles = layout_panel_titles(cr, p, fonts, sp, title_y);
  const bool x_labels = std::any_of(p.panels.begin(), p.panels.end(),
                                    [](const HeatMap* m) { return !m->x_label.empty(); });
  const double bottom =
      sp.gap + 1.35 * sp.tick_h + (x_labels ? 2 * sp.gap + sp.label_h : 0) + sp.pad;
  const double per_pixel = (p.height - top) / static_cast<double>(p.height);
  double bar_column = 0;
  for (std::size_t r = 0; r < p.rows(); ++r) {
    const double row_h = per_pixel * p.row_heights[r];
    const double grid_h = std::max(10.0, row_h - titles - bottom);
    if (r == 0) bar_column = layout_colour_bar(cr, p, fonts, sp, grid_h, L);
    const std::size_t first = r * p.columns;
    layout_grids(cr, p, fonts, sp, first, std::min(first + p.columns, p.panels.size()),
                 top + titles, grid_h, top + title_y, bar_column, L);
    top += row_h;
  }
  L.annotation_size = annotation_size(cr, p, fonts, L.grids);
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

// A panel's cells: edges on whole pixels, so colours are crisp; row 0 at the bottom.
struct Cells {
  HeatLayout::Grid g;
  Eigen::Index rows, cols;
  double w, h;  // cell size before rounding

  Cells(const HeatLayout::Grid& grid, const Eigen::MatrixXd& values)
      : g(grid),
        rows(values.rows()),
        cols(values.cols()),
        w(grid.w / static_cast<double>(values.cols())),
        h(grid.h / static_cast<double>(values.rows())) {}
  double x_edge(Eigen::Index c) const { return std::round(g.x0 + static_cast<double>(c) * w); }
  double y_edge(Eigen::Index r) const {
    return std::round(g.y0 + g.h - static_cast<double>(r) * h);
  }
};

// Each cell in its colour, a non-finite one hatched; white borders of 2 pixels between cells of 20
// pixels or more, else 1, none below 4.
void draw_cells(cairo_t* cr, const HeatMap& m, const Cells& cells, double lo, double hi) {
  const double smaller = std::min(cells.w, cells.h);
  const double border = smaller >= 20 ? 2 : smaller >= 4 ? 1 : 0;
  const double before = std::floor(border / 2), after = border - before;
  for (Eigen::Index r = 0; r < cells.rows; ++r) {
    for (Eigen::Index c = 0; c < cells.cols; ++c) {
      const double x0 = cells.x_edge(c) + before, x1 = cells.x_edge(c + 1) - after;
      const double y0 = cells.y_edge(r + 1) + before, y1 = cells.y_edge(r) - after;
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
}

// Each finite cell's value centred in it, black or white for contrast.
void draw_cell_values(cairo_t* cr, const HeatMap& m, ValueFormat format, const Cells& cells,
                      double font_size, double lo, double hi) {
  set_font(cr, {font_size, false});
  for (Eigen::Index r = 0; r < cells.rows; ++r) {
    for (Eigen::Index c = 0; c < cells.cols; ++c) {
      const double v = m.values(r, c);
      if (!std::isfinite(v)) continue;
      const bool dark = luminance(colormap((v - lo) / (hi - lo))) <= kBlackTextAbove;
      cairo_set_source_rgb(cr, dark ? 1.0 : 0.0, dark ? 1.0 : 0.0, dark ? 1.0 : 0.0);
      draw_text(cr, format_value(v, format), 0.5 * (cells.x_edge(c) + cells.x_edge(c + 1)),
                0.5 * (cells.y_edge(r) + cells.y_edge(r + 1)), 0.5);
    }
  }
}

// Column and row labels centred on the cells, thinned out when they would touch; the axis labels
// and the panel's title.
void draw_panel_labels(cairo_t* cr, const HeatMap& m, bool show_y, const Cells& cells,
                       const Fonts& fonts) {
  const HeatLayout::Grid& g = cells.g;
  const double gap = 0.5 * fonts.tick.size;
  set_font(cr, fonts.tick);
  const double tick_h = cap_height(cr);
  cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
  double widest_x = 0;
  for (const auto& t : m.x_ticks) widest_x = std::max(widest_x, text_width(cr, t));
  const int x_stride = label_stride(widest_x, cells.w, gap);
  const double label_row = g.y0 + g.h + gap + 0.5 * tick_h;
  for (Eigen::Index c = 0; c < cells.cols; c += x_stride) {
    draw_text(cr, m.x_ticks[static_cast<std::size_t>(c)],
              g.x0 + (static_cast<double>(c) + 0.5) * cells.w, label_row, 0.5);
  }
  if (show_y) {
    const int y_stride = label_stride(tick_h, cells.h, 0.5 * tick_h);
    for (Eigen::Index r = 0; r < cells.rows; r += y_stride) {
      draw_text(cr, m.y_ticks[static_cast<std::size_t>(r)], g.x0 - gap,
                g.y0 + g.h - (static_cast<double>(r) + 0.5) * cells.h, 1.0);
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
    draw_text(cr, m.title, g.x0 + 0.5 * g.w, g.title_y, 0.5);
  }
}

void draw_heat_panel(cairo_t* cr, const HeatMap& m, ValueFormat format, bool show_y,
                     const HeatLayout::Grid& g, const HeatLayout& L, const Fonts& fonts, double lo,
                     double hi) {
  const Cells cells(g, m.values);
  draw_cells(cr, m, cells, lo, hi);
  if (m.annotate && L.annotation_size > 0) {
    draw_cell_values(cr, m, format, cells, L.annotation_size, lo, hi);
  }
  draw_panel_labels(cr, m, show_y, cells, fonts);
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
  const Fonts fonts = fonts_for(static_cast<double>(p.width) / static_cast<double>(p.columns),
                                static_cast<double>(p.height) / static_cast<double>(p.rows()), 1.0);
  const HeatLayout L = layout_heatmaps(cr, p, fonts);
  for (std::size_t i = 0; i < p.panels.size(); ++i) {
    draw_heat_panel(cr, *p.panels[i], p.formats[i], p.show_y[i], L.grids[i], L, fonts, p.lo, p.hi);
  }
  draw_colour_bar(cr, p, L, fonts);
  if (!p.title.empty()) {
    set_font(cr, fonts.title);
    cairo_set_source_rgb(cr, 0, 0, 0);
    // Centred over the first row's grids, but kept inside the image.
    const HeatLayout::Grid& last = L.grids[p.columns - 1];
    const double cx = 0.5 * (L.grids.front().x0 + last.x0 + last.w);
    const double half = 0.5 * text_width(cr, p.title), margin = fonts.tick.size;
    draw_text(cr, p.title, std::max(std::min(cx, p.width - margin - half), margin + half),
              L.title_y, 0.5);
  }
}

}  // namespace
}  // namespace detail

void write_heatmap(const HeatMap& map, const std::filesystem::path& stem) {
  // One panel under the map's title, which is then the figure's title.
  HeatMap panel = map;
  panel.title.clear();
  write_heatmaps({panel}, map.title, stem);
}

void write_heatmaps(const std::vector<HeatMap>& panels, const std::string& title,
                    const std::filesystem::path& stem, std::size_t columns) {
  const detail::HeatPrepared prepared = detail::prepare_heatmaps(panels, title, columns);
  detail::write_svg_and_png(stem, prepared.width, prepared.height,
                            [&](cairo_t* cr) { detail::draw_heatmaps(cr, prepared); });
}

}  // namespace align3d::report
