// The stitch's figure of stitch_figure.hpp: each view's points splatted far to near into a raster
// (cairo has no depth order of its own), then frames, ticks, labels and the legend drawn with cairo
// around them, and the surface written as PNG.
#include "align3d/report/stitch_figure.hpp"

#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "align3d/io/atomic_file.hpp"
#include "align3d/report/find_overlay.hpp"  // instance_color
#include "canvas.hpp"
#include "ticks.hpp"

namespace align3d::report {
namespace {

constexpr std::array<View, 2> kFigureViews = {View::kTop, View::kFront};
constexpr int kMinSide = 320;
constexpr int kMinPanel = 48;   // pixels of a view's plot area, each way
constexpr double kFill = 0.92;  // share of the tighter plot area the data fills
constexpr int kMaxSplat = 5;    // pixels

// The data axes a view shows across and up (view_rotation's first two rows).
const char* axis_name(View view, int k) {
  static const char* const kTop[] = {"x", "y"};
  static const char* const kFront[] = {"x", "z"};
  return (view == View::kTop ? kTop : kFront)[k];
}

std::uint32_t scan_word(std::size_t scan) {
  const std::array<std::uint8_t, 3> c = instance_color(static_cast<int>(scan) + 1);
  return 0xff000000u | std::uint32_t{c[0]} << 16 | std::uint32_t{c[1]} << 8 | c[2];
}

Rgb scan_rgb(std::size_t scan) {
  const std::array<std::uint8_t, 3> c = instance_color(static_cast<int>(scan) + 1);
  return {c[0] / 255.0, c[1] / 255.0, c[2] / 255.0};
}

void check_input(const StitchResult& r, const StitchFigureSettings& s) {
  if (s.width < kMinSide || s.height < kMinSide || s.width > detail::kMaxSide ||
      s.height > detail::kMaxSide)
    throw std::invalid_argument("stitch figure: size " + std::to_string(s.width) + " x " +
                                std::to_string(s.height) + " outside [" + std::to_string(kMinSide) +
                                ", " + std::to_string(detail::kMaxSide) + "]");
  if (s.max_points == 0) throw std::invalid_argument("stitch figure: max_points is 0");
  if (!s.names.empty() && s.names.size() != r.scans.size())
    throw std::invalid_argument("stitch figure: " + std::to_string(s.names.size()) + " names for " +
                                std::to_string(r.scans.size()) + " scans");
  if (r.merged_scan.size() != r.merged.size())
    throw std::invalid_argument("stitch figure: " + std::to_string(r.merged_scan.size()) +
                                " scan indices for " + std::to_string(r.merged.size()) +
                                " merged points");
  for (std::int32_t k : r.merged_scan)
    if (k < 0 || static_cast<std::size_t>(k) >= r.scans.size())
      throw std::invalid_argument("stitch figure: merged point of scan " + std::to_string(k) +
                                  ", outside [0, " + std::to_string(r.scans.size()) + ")");
}

std::vector<std::string> legend_texts(const StitchResult& r, const StitchFigureSettings& s) {
  std::vector<std::string> texts;
  for (std::size_t k = 0; k < r.scans.size(); ++k) {
    std::string t =
        s.names.empty() || s.names[k].empty() ? "scan " + std::to_string(k) : s.names[k];
    if (!r.scans[k].connected) t += " (not connected)";
    texts.push_back(std::move(t));
  }
  return texts;
}

struct Area {
  double x = 0, y = 0, w = 0, h = 0;
};

struct FigureLayout {
  detail::Fonts fonts;
  double pad = 0, gap = 0, title_y = 0, panel_title_h = 0;
  std::array<Area, 2> plots;
  std::vector<Area> swatches;  // one per scan: the colour square; its text follows it
  double legend_text_x = 0;    // offset of a text from its swatch's left
};

// Top to bottom: the title, per view its title line over its plot area, the tick labels and the
// axis name under it, the legend in rows across the figure. Left to right per view: the axis name
// (vertical), the tick labels, the plot area. `label_w` is the widest y tick label.
FigureLayout layout_figure(cairo_t* cr, const StitchFigureSettings& s,
                           const std::vector<std::string>& legend, double label_w) {
  FigureLayout L;
  L.fonts = detail::fonts_for(s.width, s.height);
  L.pad = L.fonts.tick.size, L.gap = 0.5 * L.fonts.tick.size;
  const detail::TitleBand band = detail::title_band(cr, L.fonts, !s.title.empty(), L.pad, L.gap);
  const double top = band.top;
  L.title_y = band.title_y;
  L.panel_title_h = band.panel_title_h;
  detail::set_font(cr, L.fonts.legend);
  const double row = std::round(1.6 * L.fonts.legend.size), swatch = 0.8 * L.fonts.legend.size;
  L.legend_text_x = swatch + L.gap;
  double x = L.pad, y = 0;
  for (const std::string& t : legend) {
    const double w = L.legend_text_x + detail::text_width(cr, t) + 2 * L.pad;
    if (x > L.pad && x + w > s.width - L.pad) x = L.pad, y += row;
    L.swatches.push_back({x, y, swatch, swatch});
    x += w;
  }
  const double legend_h = legend.empty() ? 0 : y + row;
  const double legend_top = s.height - L.pad - legend_h;
  detail::set_font(cr, L.fonts.label);
  const double name_h = detail::cap_height(cr);
  const double left = name_h + 2 * L.gap + label_w + L.gap + detail::kTickLength;
  const double below = detail::kTickLength + 3 * L.gap + 2.2 * name_h + L.gap;
  const double w = std::floor(0.5 * (s.width - 2 * L.pad - 2 * left - 2 * L.pad));
  const double h = std::floor(legend_top - L.gap - below - top - L.panel_title_h);
  if (w < kMinPanel || h < kMinPanel)
    throw std::invalid_argument("stitch figure: " + std::to_string(s.width) + " x " +
                                std::to_string(s.height) + " pixels leave no room for the views");
  for (int k = 0; k < 2; ++k)
    L.plots[static_cast<std::size_t>(k)] = {std::round(L.pad + left + k * (w + 2 * L.pad + left)),
                                            std::round(top + L.panel_title_h), w, h};
  for (Area& a : L.swatches) a.y += std::round(legend_top + 0.5 * (row - swatch));
  return L;
}

std::vector<std::size_t> thinned(std::size_t n, std::size_t max_points) {
  const std::size_t stride = (n + max_points - 1) / std::max<std::size_t>(max_points, 1);
  std::vector<std::size_t> drawn;
  for (std::size_t i = 0; i < n; i += std::max<std::size_t>(stride, 1)) drawn.push_back(i);
  return drawn;
}

// One scale for both views (the tighter fit), each view's data centred in its plot area; the
// cameras map into the plot areas' own pixels.
std::array<ViewCamera, 2> fit_cameras(const PointCloud& merged,
                                      const std::vector<std::size_t>& drawn,
                                      const FigureLayout& L) {
  std::array<ViewCamera, 2> cameras;
  std::array<Eigen::Vector2d, 2> centre;
  double scale = std::numeric_limits<double>::infinity();
  for (std::size_t v = 0; v < 2; ++v) {
    cameras[v].rotation = view_rotation(kFigureViews[v]);
    detail::Range across, up;
    for (std::size_t i : drawn) {
      across.add(cameras[v].rotation.row(0).dot(merged.positions[i]));
      up.add(cameras[v].rotation.row(1).dot(merged.positions[i]));
    }
    centre[v].setZero();
    if (!drawn.empty()) centre[v] = {0.5 * (across.lo + across.hi), 0.5 * (up.lo + up.hi)};
    if (across.span() > 0) scale = std::min(scale, kFill * L.plots[v].w / across.span());
    if (up.span() > 0) scale = std::min(scale, kFill * L.plots[v].h / up.span());
  }
  if (!std::isfinite(scale)) scale = 1;  // no extent: one point, or none
  for (std::size_t v = 0; v < 2; ++v) {
    cameras[v].scale = scale;
    cameras[v].offset = {0.5 * L.plots[v].w - scale * centre[v].x(),
                         0.5 * L.plots[v].h + scale * centre[v].y()};
  }
  return cameras;
}

// The side of a point's square: 1.3 × the spacing of the points were they spread evenly over half
// the smaller view's filled area (a scanned surface covers about that much of its views), so that
// a surface reads as closed; 1 to kMaxSplat pixels.
int splat_side(const FigureLayout& L, std::size_t n) {
  if (n == 0) return 1;
  const double area =
      std::min(L.plots[0].w * L.plots[0].h, L.plots[1].w * L.plots[1].h) * kFill * kFill * 0.5;
  const double side = 1.3 * std::sqrt(area / static_cast<double>(n));
  return std::clamp(static_cast<int>(std::ceil(side)), 1, kMaxSplat);
}

// The drawn points of one view, far to near (ties by index), each a square of its scan's colour.
Raster draw_points(const StitchResult& r, const std::vector<std::size_t>& drawn,
                   const ViewCamera& camera, const Area& area, int splat) {
  Raster image;
  image.width = static_cast<int>(area.w), image.height = static_cast<int>(area.h);
  image.pixels.assign(static_cast<std::size_t>(image.width) * image.height, kViewBackground);
  std::vector<std::pair<double, std::size_t>> order;
  order.reserve(drawn.size());
  for (std::size_t i : drawn) order.emplace_back(camera.depth(r.merged.positions[i]), i);
  std::sort(order.begin(), order.end());  // larger depth is nearer: drawn last
  const int half = (splat - 1) / 2;
  for (const auto& [depth, i] : order) {
    const Eigen::Vector2d p = camera.pixel(r.merged.positions[i]);
    const int x0 = static_cast<int>(std::floor(p.x())) - half;
    const int y0 = static_cast<int>(std::floor(p.y())) - half;
    const std::uint32_t word = scan_word(static_cast<std::size_t>(r.merged_scan[i]));
    for (int y = std::max(0, y0); y < std::min(image.height, y0 + splat); ++y)
      for (int x = std::max(0, x0); x < std::min(image.width, x0 + splat); ++x)
        image.pixels[static_cast<std::size_t>(y) * image.width + x] = word;
  }
  return image;
}

// The visible data range of a plot area along its horizontal (k = 0) or vertical (k = 1) axis.
detail::Range visible_range(const ViewCamera& c, const Area& a, int k) {
  if (k == 0) return {(0 - c.offset.x()) / c.scale, (a.w - c.offset.x()) / c.scale};
  return {(c.offset.y() - a.h) / c.scale, c.offset.y() / c.scale};
}

double widest_y_label(cairo_t* cr, const std::array<ViewCamera, 2>& cameras,
                      const FigureLayout& L) {
  detail::set_font(cr, L.fonts.tick);
  double widest = 0;
  for (std::size_t v = 0; v < 2; ++v)
    for (const detail::Tick& t :
         detail::linear_ticks(cr, visible_range(cameras[v], L.plots[v], 1), L.plots[v].h, 55, false)
             .major)
      widest = std::max(widest, detail::text_width(cr, t.label));
  return widest;
}

std::string axis_label(View view, int k, const std::string& units) {
  return std::string(axis_name(view, k)) + (units.empty() ? "" : " (" + units + ")");
}

// The view's title line over its plot area: the name in bold, then how it looks.
void draw_view_title(cairo_t* cr, const FigureLayout& L, const Area& a, View view) {
  const double y = a.y - 0.5 * L.panel_title_h;
  detail::set_font(cr, {L.fonts.label.size, true});
  cairo_set_source_rgb(cr, 0, 0, 0);
  const std::string title = view_title(view);
  detail::draw_text(cr, title, a.x, y, 0);
  const double indent = detail::text_width(cr, title + "  ");
  detail::set_font(cr, L.fonts.tick);
  cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
  detail::draw_text(cr, view_axes(view), a.x + indent, y, 0);
}

// The frame, the ticks and their labels outside it, the axis names and the view's title line.
void draw_axes(cairo_t* cr, const FigureLayout& L, std::size_t v, const ViewCamera& camera,
               const std::string& units) {
  const Area& a = L.plots[v];
  const View view = kFigureViews[v];
  cairo_set_line_width(cr, 1);
  cairo_set_source_rgb(cr, 0.55, 0.55, 0.55);
  cairo_rectangle(cr, a.x - 0.5, a.y - 0.5, a.w + 1, a.h + 1);
  cairo_stroke(cr);
  detail::set_font(cr, L.fonts.tick);
  const double cap = detail::cap_height(cr);
  cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
  for (const detail::Tick& t :
       detail::linear_ticks(cr, visible_range(camera, a, 0), a.w, 90, true).major) {
    const double x = detail::snap(a.x + camera.offset.x() + camera.scale * t.pos);
    cairo_move_to(cr, x, a.y + a.h + 0.5);
    cairo_rel_line_to(cr, 0, detail::kTickLength);
    cairo_stroke(cr);
    detail::draw_text(cr, t.label, x, a.y + a.h + detail::kTickLength + L.gap + 0.5 * cap, 0.5);
  }
  double widest = 0;  // of the vertical axis' labels: its name goes left of them
  for (const detail::Tick& t :
       detail::linear_ticks(cr, visible_range(camera, a, 1), a.h, 55, false).major) {
    const double y = detail::snap(a.y + camera.offset.y() - camera.scale * t.pos);
    cairo_move_to(cr, a.x - 0.5, y);
    cairo_rel_line_to(cr, -detail::kTickLength, 0);
    cairo_stroke(cr);
    detail::draw_text(cr, t.label, a.x - detail::kTickLength - L.gap, y, 1);
    widest = std::max(widest, detail::text_width(cr, t.label));
  }
  detail::set_font(cr, L.fonts.label);
  const double name_h = detail::cap_height(cr);
  detail::draw_text(cr, axis_label(view, 0, units), a.x + 0.5 * a.w,
                    a.y + a.h + detail::kTickLength + 2 * L.gap + cap + 1.2 * name_h, 0.5);
  detail::draw_vertical_text(cr, axis_label(view, 1, units),
                             a.x - detail::kTickLength - 2 * L.gap - widest - 0.5 * name_h,
                             a.y + 0.5 * a.h);
  draw_view_title(cr, L, a, view);
}

void draw_legend(cairo_t* cr, const FigureLayout& L, const std::vector<std::string>& texts,
                 const StitchResult& r) {
  detail::set_font(cr, L.fonts.legend);
  for (std::size_t k = 0; k < texts.size(); ++k) {
    const Area& s = L.swatches[k];
    detail::set_color(cr, scan_rgb(k), 1);
    cairo_rectangle(cr, s.x, s.y, s.w, s.h);
    cairo_fill(cr);
    if (r.scans[k].connected) {
      cairo_set_source_rgb(cr, 0.1, 0.1, 0.1);
    } else {
      cairo_set_source_rgb(cr, 0.5, 0.5, 0.5);
    }
    detail::draw_text(cr, texts[k], s.x + L.legend_text_x, s.y + 0.5 * s.h, 0);
  }
}

struct Drawing {
  FigureLayout layout;
  std::array<ViewCamera, 2> cameras;
  std::array<Raster, 2> views;
  int splat = 1;
};

// The layout is measured twice: the plot areas' size decides the ticks, the widest tick label the
// left margin.
Drawing prepare(const StitchResult& r, const StitchFigureSettings& s,
                const std::vector<std::string>& legend, const std::vector<std::size_t>& drawn) {
  const detail::SurfacePtr scratch(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, 16, 16));
  const detail::ContextPtr measure(cairo_create(scratch.get()));
  detail::begin_page(measure.get());
  detail::set_font(measure.get(), detail::fonts_for(s.width, s.height).tick);
  Drawing d;
  double label_w = detail::text_width(measure.get(), "\u22120.00");
  for (int pass = 0; pass < 2; ++pass) {
    d.layout = layout_figure(measure.get(), s, legend, label_w);
    d.cameras = fit_cameras(r.merged, drawn, d.layout);
    label_w = std::max(label_w, widest_y_label(measure.get(), d.cameras, d.layout));
  }
  d.splat = splat_side(d.layout, drawn.size());
  for (std::size_t v = 0; v < 2; ++v)
    d.views[v] = draw_points(r, drawn, d.cameras[v], d.layout.plots[v], d.splat);
  return d;
}

cairo_status_t append_bytes(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

std::string render(const StitchResult& r, const StitchFigureSettings& s,
                   const std::filesystem::path& destination, StitchFigureInfo* info) {
  check_input(r, s);
  const std::vector<std::string> legend = legend_texts(r, s);
  const std::vector<std::size_t> drawn = thinned(r.merged.size(), s.max_points);
  const Drawing d = prepare(r, s, legend, drawn);
  const detail::SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_ARGB32, s.width, s.height));
  detail::check_cairo(cairo_surface_status(surface.get()), destination);
  const detail::ContextPtr owner(cairo_create(surface.get()));
  cairo_t* cr = owner.get();
  detail::begin_page(cr);
  for (std::size_t v = 0; v < 2; ++v) {
    const detail::SurfacePtr points = detail::raster_surface(d.views[v]);
    cairo_set_source_surface(cr, points.get(), d.layout.plots[v].x, d.layout.plots[v].y);
    cairo_paint(cr);
    draw_axes(cr, d.layout, v, d.cameras[v], s.units);
  }
  draw_legend(cr, d.layout, legend, r);
  if (!s.title.empty()) {
    detail::set_font(cr, d.layout.fonts.title);
    cairo_set_source_rgb(cr, 0, 0, 0);
    detail::draw_text(cr, s.title, d.layout.plots[0].x, d.layout.title_y, 0);
  }
  if (cairo_status(cr) == CAIRO_STATUS_INVALID_STRING)
    throw std::invalid_argument("stitch figure: a name, the units or the title is not UTF-8");
  detail::check_cairo(cairo_status(cr), destination);
  cairo_surface_flush(surface.get());
  std::string bytes;
  detail::check_cairo(cairo_surface_write_to_png_stream(surface.get(), append_bytes, &bytes),
                      destination);
  if (info != nullptr) {
    info->drawn_points = drawn.size();
    info->splat = d.splat;
    for (std::size_t v = 0; v < 2; ++v) {
      const Area& a = d.layout.plots[v];
      StitchFigurePanel& p = info->panels[v];
      p = {kFigureViews[v],       static_cast<int>(a.x), static_cast<int>(a.y),
           static_cast<int>(a.w), static_cast<int>(a.h), d.cameras[v]};
      p.camera.offset += Eigen::Vector2d(a.x, a.y);
    }
  }
  return bytes;
}

}  // namespace

StitchFigureInfo write_stitch_figure(const StitchResult& result, const std::filesystem::path& png,
                                     const StitchFigureSettings& settings) {
  StitchFigureInfo info;
  const std::string bytes = render(result, settings, png, &info);
  io::write_atomically(png, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
  return info;
}

std::string stitch_figure_png(const StitchResult& result, const StitchFigureSettings& settings,
                              StitchFigureInfo* info) {
  return render(result, settings, "stitch figure", info);
}

}  // namespace align3d::report
