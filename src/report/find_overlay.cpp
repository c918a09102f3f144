// The find command's image and overlay of find_overlay.hpp: the depth image and the masks coloured
// pixel by pixel into a cairo surface, the ranks and the caption drawn on it as text; the PLY
// through io::write_ply.
#include "align3d/report/find_overlay.hpp"

#include <cairo.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/io/atomic_file.hpp"
#include "align3d/io/ply_attributes.hpp"
#include "canvas.hpp"
#include "ticks.hpp"

namespace align3d::report {
namespace {

using Rgb8 = std::array<std::uint8_t, 3>;

// Trubetskoy's red, green, blue, orange, purple, cyan, magenta, yellow, lime, teal, brown, olive.
constexpr std::array<Rgb8, kInstancePaletteSize> kPalette = {{{230, 25, 75},
                                                              {60, 180, 75},
                                                              {67, 99, 216},
                                                              {245, 130, 49},
                                                              {145, 30, 180},
                                                              {66, 212, 244},
                                                              {240, 50, 230},
                                                              {255, 225, 25},
                                                              {191, 239, 69},
                                                              {70, 153, 144},
                                                              {154, 99, 36},
                                                              {128, 128, 0}}};

constexpr Rgb8 kNoReturn{24, 28, 52};                     // dark blue: no grey level reaches it
constexpr double kNear = 0.90, kFar = 0.25, kFlat = 0.6;  // grey levels of the depth
// Above 0.5, so a filled pixel is nearer its instance's colour than the depth's grey.
constexpr double kFillAlpha = 0.55;
constexpr int kMaxClosing = 16;  // pixels

constexpr Rgb8 kSceneGrey{170, 170, 170};  // the overlay's scene points
constexpr double kPale = 0.4;              // share of an instance's colour in its scene points

// The 1st and 99th percentiles of the finite depths: a few stray returns (a flying pixel, a far
// wall) do not flatten the grey of the rest.
struct DepthScale {
  double lo = 0, hi = 0;
};

DepthScale depth_scale(const std::vector<float>& depth) {
  std::vector<float> valid;
  std::copy_if(depth.begin(), depth.end(), std::back_inserter(valid),
               [](float d) { return std::isfinite(d); });
  if (valid.empty()) return {};
  auto quantile = [&](double q) {
    const auto k = static_cast<std::size_t>(std::lround(q * static_cast<double>(valid.size() - 1)));
    std::nth_element(valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(k), valid.end());
    return static_cast<double>(valid[k]);
  };
  return {quantile(0.01), quantile(0.99)};
}

double grey_level(float d, DepthScale s) {
  if (!(s.hi > s.lo)) return kFlat;
  const double t = std::clamp((d - s.lo) / (s.hi - s.lo), 0.0, 1.0);
  return kNear + t * (kFar - kNear);
}

// Each instance's pixels: those whose scene point it explains; a point two instances claim goes
// to the better rank.
std::vector<std::vector<std::size_t>> explained_pixels(const RangeImage& image,
                                                       const FindResult& result) {
  std::size_t points = 0;  // 1 + the largest point index in the image
  for (std::int32_t p : image.point) {
    if (p >= 0) points = std::max(points, static_cast<std::size_t>(p) + 1);
  }
  std::vector<std::size_t> rank_of(points, 0);               // 0: no instance
  for (std::size_t k = result.instances.size(); k-- > 0;) {  // the better rank written last
    for (std::uint32_t p : result.instances[k].points) {
      if (p < points) rank_of[p] = k + 1;
    }
  }
  std::vector<std::vector<std::size_t>> pixels(result.instances.size());
  for (std::size_t i = 0; i < image.point.size(); ++i) {
    const std::int32_t p = image.point[i];
    if (p >= 0 && rank_of[static_cast<std::size_t>(p)] > 0) {
      pixels[rank_of[static_cast<std::size_t>(p)] - 1].push_back(i);
    }
  }
  return pixels;
}

// One direction of a square structuring element: out[i] is any (dilation) or all (erosion) of the
// n values `stride` apart within r of i. The window is cut at the line's ends, so erosion does not
// eat into a mask at the image's edge.
void box_pass(const std::uint8_t* in, std::uint8_t* out, int n, std::ptrdiff_t stride, int r,
              bool all) {
  int count = 0;  // ones in [i − r, i + r] ∩ [0, n)
  for (int i = 0; i < std::min(r, n); ++i) count += in[i * stride];
  for (int i = 0; i < n; ++i) {
    if (i + r < n) count += in[(i + r) * stride];
    if (i - r - 1 >= 0) count -= in[(i - r - 1) * stride];
    const int size = std::min(n - 1, i + r) - std::max(0, i - r) + 1;
    out[i * stride] = all ? count == size : count > 0;
  }
}

// Morphological closing of a w × h mask of 0/1 by a (2r + 1)-square: fills gaps up to 2r wide.
void close_mask(std::vector<std::uint8_t>& mask, int w, int h, int r) {
  std::vector<std::uint8_t> rows(mask.size());
  for (bool erode : {false, true}) {
    for (int y = 0; y < h; ++y) {
      const auto at = static_cast<std::ptrdiff_t>(y) * w;
      box_pass(mask.data() + at, rows.data() + at, w, 1, r, erode);
    }
    for (int x = 0; x < w; ++x) box_pass(rows.data() + x, mask.data() + x, h, w, r, erode);
  }
}

// A model voxel in pixels at the median depth of `pixels`: the verification samples the model at
// its voxel, so explained pixels may lie that far apart, and a closing of this radius bridges one
// sample missing between them too (noise, a speck of no return).
int closing_radius(const RangeImage& image, const std::vector<std::size_t>& pixels, double voxel) {
  std::vector<float> z;
  for (std::size_t i : pixels) {
    if (std::isfinite(image.depth[i])) z.push_back(image.depth[i]);
  }
  if (z.empty() || !(voxel > 0)) return 1;
  const auto mid = z.begin() + static_cast<std::ptrdiff_t>(z.size() / 2);
  std::nth_element(z.begin(), mid, z.end());
  if (!(*mid > 0)) return 1;
  const double spacing = voxel * 0.5 * (std::abs(image.fx) + std::abs(image.fy)) / *mid;
  if (!std::isfinite(spacing)) return 1;
  return std::clamp(static_cast<int>(std::ceil(spacing)), 1, kMaxClosing);
}

// A window [x0, x1) × [y0, y1) of the image, and the index of a pixel in a mask over it.
struct Window {
  int x0, y0, x1, y1;
  std::size_t size() const { return static_cast<std::size_t>(x1 - x0) * (y1 - y0); }
  std::size_t at(int x, int y) const {
    return static_cast<std::size_t>(y - y0) * (x1 - x0) + static_cast<std::size_t>(x - x0);
  }
};

// The bounding box of `pixels` grown by `grow` on every side, cut at the image's edges.
Window bounding_window(const RangeImage& image, const std::vector<std::size_t>& pixels, int grow) {
  const auto w = static_cast<std::size_t>(image.width);
  Window b{image.width, image.height, 0, 0};
  for (std::size_t i : pixels) {
    const auto x = static_cast<int>(i % w), y = static_cast<int>(i / w);
    b = {std::min(b.x0, x), std::min(b.y0, y), std::max(b.x1, x + 1), std::max(b.y1, y + 1)};
  }
  return {std::max(0, b.x0 - grow), std::max(0, b.y0 - grow), std::min(image.width, b.x1 + grow),
          std::min(image.height, b.y1 + grow)};
}

// Each pixel's rank (0: none): every instance's closed mask, best rank first, claims the pixels
// still free. The closing runs in the mask's bounding box grown by 2r, beyond its reach.
std::vector<std::size_t> pixel_ranks(const RangeImage& image, const FindResult& result) {
  const auto w = static_cast<std::size_t>(image.width);
  std::vector<std::size_t> ranks(image.depth.size(), 0);
  const auto pixels = explained_pixels(image, result);
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    if (pixels[k].empty()) continue;
    const int r = closing_radius(image, pixels[k], result.voxel);
    const Window window = bounding_window(image, pixels[k], 2 * r);
    std::vector<std::uint8_t> mask(window.size(), 0);
    for (std::size_t i : pixels[k]) {
      mask[window.at(static_cast<int>(i % w), static_cast<int>(i / w))] = 1;
    }
    close_mask(mask, window.x1 - window.x0, window.y1 - window.y0, r);
    for (int y = window.y0; y < window.y1; ++y) {
      for (int x = window.x0; x < window.x1; ++x) {
        std::size_t& owner = ranks[image.pixel(x, y)];
        if (mask[window.at(x, y)] && owner == 0) owner = k + 1;
      }
    }
  }
  return ranks;
}

// Whether pixel (x, y) of `rank` has a pixel of another rank (or none) within `t`: the outline,
// t pixels wide inside the mask. The image's edge does not count.
bool on_outline(const RangeImage& image, const std::vector<std::size_t>& ranks, int x, int y,
                int t) {
  const std::size_t rank = ranks[image.pixel(x, y)];
  for (int v = std::max(0, y - t); v <= std::min(image.height - 1, y + t); ++v) {
    for (int u = std::max(0, x - t); u <= std::min(image.width - 1, x + t); ++u) {
      if (ranks[image.pixel(u, v)] != rank) return true;
    }
  }
  return false;
}

using detail::to_byte;

// The depth in grey and the masks, pixel by pixel, straight into the surface's ARGB32 words.
void paint_pixels(cairo_surface_t* surface, const RangeImage& image,
                  const std::vector<std::size_t>& ranks) {
  cairo_surface_flush(surface);
  unsigned char* data = cairo_image_surface_get_data(surface);
  const int stride = cairo_image_surface_get_stride(surface);
  const DepthScale scale = depth_scale(image.depth);
  const int outline = std::min(image.width, image.height) >= 240 ? 2 : 1;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const std::size_t i = image.pixel(x, y);
      std::array<double, 3> c;
      if (std::isfinite(image.depth[i])) {
        c.fill(grey_level(image.depth[i], scale));
      } else {
        for (int k = 0; k < 3; ++k) c[k] = kNoReturn[k] / 255.0;
      }
      if (ranks[i] > 0) {
        const Rgb8 p = instance_color(static_cast<int>(ranks[i]));
        const double a = on_outline(image, ranks, x, y, outline) ? 1.0 : kFillAlpha;
        for (int k = 0; k < 3; ++k) c[k] = (1 - a) * c[k] + a * p[k] / 255.0;
      }
      const std::uint32_t word = 0xff000000u | std::uint32_t{to_byte(c[0])} << 16 |
                                 std::uint32_t{to_byte(c[1])} << 8 | to_byte(c[2]);
      std::memcpy(data + static_cast<std::ptrdiff_t>(y) * stride + 4 * x, &word, 4);
    }
  }
  cairo_surface_mark_dirty(surface);
}

struct Label {
  std::size_t rank = 0;
  double x = 0, y = 0;  // image coordinates of the text's centre
};

// Each rank's label: at the centroid of its pixels, or at the centre of its pixel nearest to the
// centroid when that falls outside them (a ring, a bent part).
std::vector<Label> label_positions(const RangeImage& image, const std::vector<std::size_t>& ranks,
                                   std::size_t count) {
  std::vector<Eigen::Vector3d> sums(count + 1, Eigen::Vector3d::Zero());  // Σx, Σy, pixels
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x)
      sums[ranks[image.pixel(x, y)]] += Eigen::Vector3d(x, y, 1);
  }
  std::vector<Label> labels;
  std::vector<double> sq_best(count + 1, -1);  // −1: at the centroid; else the nearest so far
  for (std::size_t k = 1; k <= count; ++k) {
    if (sums[k].z() == 0) continue;
    // The mean pixel index; pixel x's centre is at x + 0.5, so the centroid lies in pixel round(c).
    const Eigen::Vector2d c = sums[k].head<2>() / sums[k].z();
    labels.push_back({k, c.x() + 0.5, c.y() + 0.5});
    const auto cx = static_cast<int>(std::lround(c.x())), cy = static_cast<int>(std::lround(c.y()));
    if (ranks[image.pixel(cx, cy)] != k) sq_best[k] = std::numeric_limits<double>::infinity();
  }
  for (Label& label : labels) {
    if (sq_best[label.rank] < 0) continue;
    const Eigen::Vector2d c(label.x, label.y);
    for (int y = 0; y < image.height; ++y) {
      for (int x = 0; x < image.width; ++x) {
        const double sq_d = (Eigen::Vector2d(x + 0.5, y + 0.5) - c).squaredNorm();
        if (ranks[image.pixel(x, y)] == label.rank && sq_d < sq_best[label.rank]) {
          sq_best[label.rank] = sq_d;
          label.x = x + 0.5;
          label.y = y + 0.5;
        }
      }
    }
  }
  return labels;
}

// The rank in bold white on a dark halo (the text's outline stroked wide underneath), kept
// inside the image.
void draw_label(cairo_t* cr, const RangeImage& image, const Label& label, double size) {
  const std::string text = std::to_string(label.rank);
  detail::set_font(cr, {size, true});
  const double half_w = 0.5 * detail::text_width(cr, text), half_h = 0.5 * detail::cap_height(cr);
  const double halo = 0.22 * size;
  const double x =
      std::clamp(label.x, half_w + halo, std::max(half_w + halo, image.width - half_w - halo));
  const double y =
      std::clamp(label.y, half_h + halo, std::max(half_h + halo, image.height - half_h - halo));
  cairo_move_to(cr, x - half_w, y + half_h);
  cairo_text_path(cr, text.c_str());
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_width(cr, 2 * halo);
  cairo_set_source_rgba(cr, 0.05, 0.05, 0.08, 0.85);
  cairo_stroke_preserve(cr);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_fill(cr);
}

// "2 instances · scores 0.91, 0.84" with as many scores as fit `width` in the current font, the
// rest as "…".
std::string caption(cairo_t* cr, const FindResult& result, double width) {
  const std::size_t n = result.instances.size();
  if (n == 0) return "no instance found";
  std::string text =
      std::to_string(n) + (n == 1 ? " instance \u00b7 score " : " instances \u00b7 scores ");
  for (std::size_t k = 0; k < n; ++k) {
    char score[32];
    std::snprintf(score, sizeof score, "%.2f", result.instances[k].score);
    const std::string next = text + (k > 0 ? ", " : "") + detail::with_unicode_minus(score);
    const std::string more = k + 1 < n ? ", \u2026" : "";
    if (detail::text_width(cr, next + more) > width) return text + (k > 0 ? ", \u2026" : "\u2026");
    text = next;
  }
  return text;
}

// The caption, light on a dark translucent band across the image's bottom.
void draw_caption(cairo_t* cr, const RangeImage& image, const FindResult& result) {
  const double size = std::clamp(0.03 * std::min(image.width, image.height), 8.0, 24.0);
  detail::set_font(cr, {size, false});
  const double pad = 0.35 * size;
  const double band = std::ceil(detail::cap_height(cr) + 2 * pad);
  cairo_rectangle(cr, 0, image.height - band, image.width, band);
  cairo_set_source_rgba(cr, 0, 0, 0, 0.6);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0.95, 0.95, 0.95);
  detail::draw_text(cr, caption(cr, result, image.width - 2 * pad), pad, image.height - 0.5 * band,
                    0);
}

void check_image(const RangeImage& image) {
  if (image.width <= 0 || image.height <= 0) {
    throw std::invalid_argument("write_find_image: the result holds no depth image (" +
                                std::to_string(image.width) + " x " + std::to_string(image.height) +
                                ")");
  }
  if (image.width > detail::kMaxSide || image.height > detail::kMaxSide) {
    throw std::invalid_argument("write_find_image: a depth image wider or higher than " +
                                std::to_string(detail::kMaxSide) + " pixels");
  }
  const std::size_t pixels = static_cast<std::size_t>(image.width) * image.height;
  if (image.depth.size() != pixels || image.point.size() != pixels) {
    throw std::invalid_argument("write_find_image: the depth image's arrays hold " +
                                std::to_string(image.depth.size()) + " and " +
                                std::to_string(image.point.size()) + " values for " +
                                std::to_string(pixels) + " pixels");
  }
}

}  // namespace

std::array<std::uint8_t, 3> instance_color(int rank) {
  if (rank < 1)
    throw std::invalid_argument("instance_color: rank " + std::to_string(rank) + " < 1");
  return kPalette[static_cast<std::size_t>(rank - 1) % kPalette.size()];
}

void write_find_image(const std::filesystem::path& path, const FindResult& result) {
  const RangeImage& image = result.image;
  check_image(image);
  const std::vector<std::size_t> ranks = pixel_ranks(image, result);
  const detail::SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_ARGB32, image.width, image.height));
  detail::check_cairo(cairo_surface_status(surface.get()), path);
  const detail::ContextPtr cr(cairo_create(surface.get()));
  detail::begin_page(cr.get());  // the text options; its white page is painted over
  paint_pixels(surface.get(), image, ranks);
  const double label_size = std::clamp(0.05 * std::min(image.width, image.height), 9.0, 40.0);
  for (const Label& label : label_positions(image, ranks, result.instances.size())) {
    draw_label(cr.get(), image, label, label_size);
  }
  draw_caption(cr.get(), image, result);
  detail::check_cairo(cairo_status(cr.get()), path);
  cairo_surface_flush(surface.get());
  io::write_via_temporary(path, [&](const std::filesystem::path& tmp) {
    detail::check_cairo(cairo_surface_write_to_png(surface.get(), tmp.c_str()), path);
  });
}

void write_find_overlay(const std::filesystem::path& path, const PointCloud& scene,
                        const PpfModel& model, const FindResult& result) {
  const std::size_t n = scene.size(), m = model.points.size();
  std::vector<Eigen::Vector3d> positions = scene.positions;
  positions.reserve(n + result.instances.size() * m);
  io::PlyAttributes a;
  a.colors.assign(n, kSceneGrey);
  a.ints.push_back({"instance", std::vector<std::int32_t>(n, 0)});
  std::vector<std::int32_t>& instance = a.ints[0].second;
  for (std::size_t k = result.instances.size(); k-- > 0;) {  // the better rank painted last
    const Rgb8 c = instance_color(static_cast<int>(k + 1));
    for (std::uint32_t p : result.instances[k].points) {
      if (p >= n) {
        throw std::invalid_argument("write_find_overlay: instance " + std::to_string(k + 1) +
                                    " names point " + std::to_string(p) + "; the scene has " +
                                    std::to_string(n));
      }
      for (int i = 0; i < 3; ++i)
        a.colors[p][i] = to_byte(((1 - kPale) * kSceneGrey[i] + kPale * c[i]) / 255);
    }
  }
  for (std::size_t k = 0; k < result.instances.size(); ++k) {
    const Eigen::Isometry3d& T = result.instances[k].T_scene_model;
    for (const Eigen::Vector3d& q : model.points.positions) positions.push_back(T * q);
    a.colors.insert(a.colors.end(), m, instance_color(static_cast<int>(k + 1)));
    instance.insert(instance.end(), m, static_cast<std::int32_t>(k + 1));
  }
  io::write_ply(path, positions, a);
}

}  // namespace align3d::report
