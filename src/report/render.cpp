// The software renderer of render.hpp: the mesh into a z-buffer, the points splatted on it, the
// edges on top. The four views composed with a colour bar are views_figure.cpp.
#include "align3d/report/render.hpp"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "align3d/io/atomic_file.hpp"
#include "align3d/report/colormap.hpp"
#include "canvas.hpp"

namespace align3d::report {
namespace {

constexpr float kNoDepthF = -std::numeric_limits<float>::infinity();

// Light grey, lit from the viewer's upper left (a fixed direction in view space, so every view is
// lit alike); Lambert's cosine with an ambient floor, so faces turned from the light stay legible.
constexpr double kMeshAlbedo = 0.94;
constexpr double kAmbient = 0.5, kDiffuse = 0.5;
const Eigen::Vector3d kLight = Eigen::Vector3d(-0.35, 0.5, 0.8).normalized();
constexpr Rgb kEdgeColor{0.28, 0.28, 0.30};
// Crease edges: the normals of the two triangles differ by more than this (the facets of a
// 64-sided cylinder, 5.6° apart, are not edges; a 45° chamfer is).
const double kCreaseCos = std::cos(25.0 * std::numbers::pi / 180.0);
// Screen coordinates are rounded to 1/256 pixel, as GPUs do: the edge functions' products then fit
// a double's mantissa exactly (images are at most 2^14 pixels), so two triangles sharing an edge
// agree to the bit on which side of it a pixel centre lies, and the top-left rule leaves no pixel
// uncovered or covered twice.
constexpr double kSubpixel = 256;

std::uint32_t pack(const Rgb& c) {
  auto byte = [](double v) {
    return static_cast<std::uint32_t>(std::lround(255 * std::clamp(v, 0.0, 1.0)));
  };
  return 0xff000000u | byte(c[0]) << 16 | byte(c[1]) << 8 | byte(c[2]);
}

void check_size(int width, int height) {
  if (width < 16 || height < 16 || width > detail::kMaxSide || height > detail::kMaxSide) {
    throw std::invalid_argument("render: width and height must be in [16, 16384] pixels, got " +
                                std::to_string(width) + " x " + std::to_string(height));
  }
}

// ---- The mesh ----------------------------------------------------------------------------------

// Per pixel: the nearest surface's depth (kNoDepthF: background) and its shade.
struct MeshLayer {
  int width = 0, height = 0;
  std::vector<float> depth;
  std::vector<float> shade;
  std::size_t covered = 0;  // pixels the mesh covers

  std::size_t index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(x);
  }
};

struct ScreenVertex {
  double x, y, z;
};

ScreenVertex to_screen(const ViewCamera& camera, const Eigen::Vector3d& p) {
  const Eigen::Vector2d q = camera.pixel(p);
  return {std::round(q.x() * kSubpixel) / kSubpixel, std::round(q.y() * kSubpixel) / kSubpixel,
          camera.depth(p)};
}

// Twice the signed area of (a, b, p); > 0 when p lies on the interior side of a → b for a
// triangle a, b, c of positive orientation.
double edge_function(const ScreenVertex& a, const ScreenVertex& b, double px, double py) {
  return (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
}

// The top-left rule (y down): a pixel centre exactly on an edge belongs to the triangle whose
// interior lies below a horizontal edge or right of a slanted one, never to both.
bool top_left(const ScreenVertex& a, const ScreenVertex& b) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  return dy < 0 || (dy == 0 && dx > 0);
}

bool inside(double w, bool owns_edge) { return w > 0 || (w == 0 && owns_edge); }

// Rasterises one triangle into the depth buffer, either winding (two-sided).
void rasterize(ScreenVertex a, ScreenVertex b, ScreenVertex c, float shade, MeshLayer& L) {
  double area = edge_function(a, b, c.x, c.y);
  if (!(std::abs(area) > 0)) return;  // zero area (seen edge-on) or NaN
  if (area < 0) {
    std::swap(b, c);
    area = -area;
  }
  const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x}))));
  const int x1 = std::min(L.width - 1, static_cast<int>(std::floor(std::max({a.x, b.x, c.x}))));
  const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y}))));
  const int y1 = std::min(L.height - 1, static_cast<int>(std::floor(std::max({a.y, b.y, c.y}))));
  const bool own_a = top_left(b, c), own_b = top_left(c, a), own_c = top_left(a, b);
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5;
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5;
      const double wa = edge_function(b, c, px, py), wb = edge_function(c, a, px, py);
      const double wc = edge_function(a, b, px, py);
      if (!inside(wa, own_a) || !inside(wb, own_b) || !inside(wc, own_c)) continue;
      const auto z = static_cast<float>((wa * a.z + wb * b.z + wc * c.z) / area);
      const std::size_t i = L.index(x, y);
      if (z > L.depth[i]) {
        L.covered += L.depth[i] == kNoDepthF;
        L.depth[i] = z;
        L.shade[i] = shade;
      }
    }
  }
}

// The unit normal of a triangle in view space, turned toward the viewer.
Eigen::Vector3d view_normal(const TriangleMesh& mesh, const std::array<std::uint32_t, 3>& t,
                            const Eigen::Matrix3d& rotation) {
  const Eigen::Vector3d& a = mesh.vertices[t[0]];
  const Eigen::Vector3d n = rotation * (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a);
  const double length = n.norm();
  if (!(length > 0)) return Eigen::Vector3d::UnitZ();
  return (n.z() < 0 ? -n : n) / length;
}

MeshLayer rasterize_mesh(const TriangleMesh& mesh, const ViewCamera& camera, int width,
                         int height) {
  MeshLayer L;
  L.width = width;
  L.height = height;
  const auto pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  L.depth.assign(pixels, kNoDepthF);
  L.shade.assign(pixels, 0.0F);
  for (const auto& t : mesh.triangles) {
    const double lambert = std::max(0.0, view_normal(mesh, t, camera.rotation).dot(kLight));
    rasterize(to_screen(camera, mesh.vertices[t[0]]), to_screen(camera, mesh.vertices[t[1]]),
              to_screen(camera, mesh.vertices[t[2]]),
              static_cast<float>(kAmbient + kDiffuse * lambert), L);
  }
  return L;
}

// ---- The points --------------------------------------------------------------------------------

// points → pixels in one affine map: (x, y, depth) = A·p + b, p in the points' frame.
struct PointProjection {
  Eigen::Matrix3d A;
  Eigen::Vector3d b;
  double tolerance;  // depth units (data units)
};

PointProjection point_projection(const ViewCamera& camera, const DeviationPoints& points) {
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(0, 0) = camera.scale;
  S(1, 1) = -camera.scale;
  const Eigen::Matrix3d A_mesh = S * camera.rotation;
  const Eigen::Vector3d b_mesh(camera.offset.x(), camera.offset.y(), 0);
  const Eigen::Matrix3d A = A_mesh * points.T_mesh_points.linear();
  const Eigen::Vector3d b = A_mesh * points.T_mesh_points.translation() + b_mesh;
  return {A, b, points.depth_tolerance + 2.0 / camera.scale};
}

// Whether a point at depth z is not hidden by the mesh at pixel i.
bool visible(const MeshLayer& L, std::size_t i, double z, double tolerance) {
  return z + tolerance >= static_cast<double>(L.depth[i]);
}

// The splat side from the spacing of the measured points seen on the mesh, s = √(mesh pixels /
// points on them): 1.5 s, since a scanner's rows are seldom as far apart as the points along them
// (a wall seen at a slant); one pixel when several points share each.
constexpr double kSplatPerSpacing = 1.5;

int splat_from_spacing(const MeshLayer& L, const DeviationPoints& points,
                       const PointProjection& P) {
  std::size_t seen = 0;
  for (std::size_t n = 0; n < points.positions.size(); ++n) {
    if (std::isnan(points.deviation[n])) continue;
    const Eigen::Vector3d q = P.A * points.positions[n] + P.b;
    if (!(q.x() >= 0 && q.x() < L.width && q.y() >= 0 && q.y() < L.height)) continue;
    const std::size_t i = L.index(static_cast<int>(q.x()), static_cast<int>(q.y()));
    seen += L.depth[i] != kNoDepthF && visible(L, i, q.z(), P.tolerance);
  }
  if (seen == 0) return 1;
  const double spacing = std::sqrt(static_cast<double>(L.covered) / static_cast<double>(seen));
  return std::clamp(static_cast<int>(std::ceil(kSplatPerSpacing * spacing - 0.05)), 1, 9);
}

// Per pixel: the sum and count of the measured deviations splatted on it, and the outliers.
struct PointLayer {
  std::vector<double> sum;
  std::vector<std::uint32_t> count, outliers;
};

// The pixels of a splat of side `k` centred at (x, y): the k × k block whose centres are nearest,
// less its corners beyond the inscribed circle when k > 2.
template <typename Visit>
void for_each_splat_pixel(double x, double y, int k, int width, int height, Visit&& visit) {
  const int x0 = static_cast<int>(std::floor(x + 0.5 * (1 - k)));
  const int y0 = static_cast<int>(std::floor(y + 0.5 * (1 - k)));
  const double sq_radius = 0.25 * k * k;
  for (int py = std::max(y0, 0); py < std::min(y0 + k, height); ++py) {
    for (int px = std::max(x0, 0); px < std::min(x0 + k, width); ++px) {
      const double dx = px + 0.5 - x, dy = py + 0.5 - y;
      if (k > 2 && dx * dx + dy * dy > sq_radius) continue;
      visit(px, py);
    }
  }
}

std::size_t splat_points(const MeshLayer& L, const DeviationPoints& points,
                         const PointProjection& P, int k, PointLayer& out) {
  const auto pixels = L.depth.size();
  out.sum.assign(pixels, 0.0);
  out.count.assign(pixels, 0);
  out.outliers.assign(pixels, 0);
  std::size_t drawn = 0;
  for (std::size_t n = 0; n < points.positions.size(); ++n) {
    const Eigen::Vector3d q = P.A * points.positions[n] + P.b;
    // Outside the image, NaN included (and before any cast to int could overflow).
    if (!(q.x() > -k && q.x() < L.width + k && q.y() > -k && q.y() < L.height + k)) continue;
    const double d = points.deviation[n];
    bool any = false;
    // Outliers (fixtures, the table) are context, not measurements: single pixels, a light
    // texture that leaves the part's outline in front.
    const int side = std::isnan(d) ? 1 : k;
    for_each_splat_pixel(q.x(), q.y(), side, L.width, L.height, [&](int x, int y) {
      const std::size_t i = L.index(x, y);
      if (!visible(L, i, q.z(), P.tolerance)) return;
      any = true;
      if (std::isnan(d)) {
        ++out.outliers[i];
      } else {
        out.sum[i] += d;
        ++out.count[i];
      }
    });
    drawn += any;
  }
  return drawn;
}

// Closes the gaps a scanner's rows leave between splats: an uncovered pixel of the mesh with
// measured pixels on both sides of it along a row, a column or a diagonal, within kGap pixels,
// takes their mean deviation. Both sides are required, so the edge of the scanned area does not
// grow; reads come from the unfilled layer, so nothing spreads further.
constexpr int kGap = 2;

void fill_gaps(const MeshLayer& L, PointLayer& P) {
  const PointLayer before = P;
  static constexpr int kDirections[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  for (int y = 0; y < L.height; ++y) {
    for (int x = 0; x < L.width; ++x) {
      const std::size_t i = L.index(x, y);
      if (before.count[i] > 0 || L.depth[i] == kNoDepthF) continue;
      double sum = 0;
      std::uint32_t count = 0;
      for (const auto& d : kDirections) {
        std::size_t found[2];
        int sides = 0;
        for (int sign : {1, -1}) {
          for (int step = 1; step <= kGap; ++step) {
            const int px = x + sign * step * d[0], py = y + sign * step * d[1];
            if (px < 0 || px >= L.width || py < 0 || py >= L.height) break;
            const std::size_t j = L.index(px, py);
            if (before.count[j] > 0) {
              found[sides++] = j;
              break;
            }
          }
        }
        if (sides < 2) continue;
        for (std::size_t j : found) {
          sum += before.sum[j] / before.count[j];
          ++count;
        }
      }
      if (count > 0) {
        P.sum[i] = sum;
        P.count[i] = count;
      }
    }
  }
}

// Per pixel: the mean deviation's colour where measured points lie, else the outlier grey on every
// other pixel of a checkerboard where only outliers lie (a fixture or a table seen at full density
// would otherwise be a solid block heavier than the part), else the shaded mesh, else the page.
Raster compose(const MeshLayer& L, const PointLayer& P, const Tolerance& band) {
  Raster image{L.width, L.height, std::vector<std::uint32_t>(L.depth.size())};
  const std::uint32_t outlier = pack(kOutlierColor);
  for (int y = 0; y < L.height; ++y) {
    for (int x = 0; x < L.width; ++x) {
      const std::size_t i = L.index(x, y);
      std::uint32_t& pixel = image.pixels[i];
      if (P.count[i] > 0) {
        pixel = pack(deviation_color(P.sum[i] / P.count[i], band));
      } else if (P.outliers[i] > 0 && (x + y) % 2 == 0) {
        pixel = outlier;
      } else if (L.depth[i] != kNoDepthF) {
        const double g = kMeshAlbedo * L.shade[i];
        pixel = pack({g, g, g});
      } else {
        pixel = kViewBackground;
      }
    }
  }
  return image;
}

// ---- The edges ---------------------------------------------------------------------------------

// A one-pixel line from a to b, drawn where it is not behind the mesh (opaque, so pixels stepped
// on twice look the same).
void draw_line(const ScreenVertex& a, const ScreenVertex& b, double tolerance, const MeshLayer& L,
               Raster& image) {
  const std::uint32_t color = pack(kEdgeColor);
  const double steps = std::ceil(std::max(std::abs(b.x - a.x), std::abs(b.y - a.y)));
  const int n = static_cast<int>(std::min(steps, 4.0 * detail::kMaxSide));
  for (int s = 0; s <= n; ++s) {
    const double t = n == 0 ? 0 : static_cast<double>(s) / n;
    const double x = a.x + t * (b.x - a.x), y = a.y + t * (b.y - a.y);
    if (!(x >= 0 && x < L.width && y >= 0 && y < L.height)) continue;
    const std::size_t i = L.index(static_cast<int>(x), static_cast<int>(y));
    if (visible(L, i, a.z + t * (b.z - a.z), tolerance)) image.pixels[i] = color;
  }
}

// Creases (normals more than 25° apart), silhouettes (one triangle faces the viewer, the other
// away) and open or non-manifold edges: the part's outline, steps, holes and chamfers.
void draw_edges(const TriangleMesh& mesh, const ViewCamera& camera, const MeshLayer& L,
                Raster& image) {
  const auto neighbours = edge_neighbours(mesh);
  const double tolerance = 3.0 / camera.scale;  // depth sampled at pixel centres, lines between
  auto raw_normal = [&](std::uint32_t t) {
    const auto& v = mesh.triangles[t];
    const Eigen::Vector3d& a = mesh.vertices[v[0]];
    return Eigen::Vector3d((mesh.vertices[v[1]] - a).cross(mesh.vertices[v[2]] - a).normalized());
  };
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = neighbours[t][static_cast<std::size_t>(k)];
      if (u != kNoTriangle && u < t) continue;  // each shared edge once
      bool draw = u == kNoTriangle;
      if (!draw) {
        const Eigen::Vector3d nt = raw_normal(t), nu = raw_normal(u);
        const double zt = camera.rotation.row(2).dot(nt), zu = camera.rotation.row(2).dot(nu);
        draw = nt.dot(nu) < kCreaseCos || (zt > 0) != (zu > 0);
      }
      if (!draw) continue;
      const auto& v = mesh.triangles[t];
      draw_line(to_screen(camera, mesh.vertices[v[static_cast<std::size_t>(k)]]),
                to_screen(camera, mesh.vertices[v[static_cast<std::size_t>((k + 1) % 3)]]),
                tolerance, L, image);
    }
  }
}

}  // namespace

const char* view_name(View view) {
  switch (view) {
    case View::kTop:
      return "top";
    case View::kFront:
      return "front";
    case View::kSide:
      return "side";
    case View::kIsometric:
      return "isometric";
  }
  return "?";
}

const char* view_title(View view) {
  switch (view) {
    case View::kTop:
      return "Top";
    case View::kFront:
      return "Front";
    case View::kSide:
      return "Right side";
    case View::kIsometric:
      return "Isometric";
  }
  return "?";
}

const char* view_axes(View view) {
  switch (view) {
    case View::kTop:
      return "looking down \u2212z: x right, y up";
    case View::kFront:
      return "looking along +y: x right, z up";
    case View::kSide:
      return "looking along \u2212x: y right, z up";
    case View::kIsometric:
      return "from +x, \u2212y, +z: z up";
  }
  return "?";
}

Eigen::Matrix3d view_rotation(View view) {
  Eigen::Matrix3d R;
  switch (view) {
    case View::kTop:  // from +z
      R << 1, 0, 0, 0, 1, 0, 0, 0, 1;
      break;
    case View::kFront:  // from −y
      R << 1, 0, 0, 0, 0, 1, 0, -1, 0;
      break;
    case View::kSide:  // from +x
      R << 0, 1, 0, 0, 0, 1, 1, 0, 0;
      break;
    case View::kIsometric: {  // from (+1, −1, +1): z's projection points up
      const Eigen::Vector3d toward = Eigen::Vector3d(1, -1, 1).normalized();
      const Eigen::Vector3d up = (Eigen::Vector3d::UnitZ() - toward.z() * toward).normalized();
      R.row(0) = up.cross(toward);
      R.row(1) = up;
      R.row(2) = toward;
      break;
    }
  }
  return R;
}

Eigen::Vector2d ViewCamera::pixel(const Eigen::Vector3d& p) const {
  return {offset.x() + scale * rotation.row(0).dot(p), offset.y() - scale * rotation.row(1).dot(p)};
}

ViewCamera fit_view(const TriangleMesh& mesh, View view, int width, int height, double margin) {
  check_size(width, height);
  if (!(margin >= 0 && margin <= 0.45)) {
    throw std::invalid_argument("render: margin must be in [0, 0.45], got " +
                                std::to_string(margin));
  }
  if (mesh.empty()) throw std::invalid_argument("render: the mesh has no triangle");
  ViewCamera camera;
  camera.rotation = view_rotation(view);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const auto& t : mesh.triangles) {
    for (std::uint32_t v : t) {
      const Eigen::Vector2d q = (camera.rotation.topRows<2>() * mesh.vertices[v]).eval();
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  }
  const Eigen::Vector2d extent = hi - lo, centre = 0.5 * (lo + hi);
  const double sx = width * (1 - 2 * margin) / extent.x();
  const double sy = height * (1 - 2 * margin) / extent.y();
  // A direction the mesh has no extent in (a flat part seen edge-on) does not limit the scale.
  camera.scale = std::min(extent.x() > 0 ? sx : std::numeric_limits<double>::infinity(),
                          extent.y() > 0 ? sy : std::numeric_limits<double>::infinity());
  if (!std::isfinite(camera.scale)) camera.scale = 1;
  camera.offset = {0.5 * width - camera.scale * centre.x(),
                   0.5 * height + camera.scale * centre.y()};
  return camera;
}

ViewImage render_view(const TriangleMesh& mesh, const DeviationPoints& points, View view,
                      const ViewSettings& settings) {
  if (points.positions.size() != points.deviation.size()) {
    throw std::invalid_argument("render: " + std::to_string(points.positions.size()) +
                                " points but " + std::to_string(points.deviation.size()) +
                                " deviations");
  }
  if (settings.splat < 0 || settings.splat > 64) {
    throw std::invalid_argument("render: splat must be in [0, 64] pixels");
  }
  check_mesh(mesh, "mesh");
  ViewImage out;
  out.camera = fit_view(mesh, view, settings.width, settings.height, settings.margin);
  const MeshLayer mesh_layer = rasterize_mesh(mesh, out.camera, settings.width, settings.height);
  const PointProjection projection = point_projection(out.camera, points);
  out.splat =
      settings.splat > 0 ? settings.splat : splat_from_spacing(mesh_layer, points, projection);
  PointLayer point_layer;
  out.drawn_points = splat_points(mesh_layer, points, projection, out.splat, point_layer);
  fill_gaps(mesh_layer, point_layer);
  out.image = compose(mesh_layer, point_layer, points.band);
  draw_edges(mesh, out.camera, mesh_layer, out.image);
  return out;
}

void write_png(const Raster& image, const std::filesystem::path& png) {
  io::write_via_temporary(png, [&](const std::filesystem::path& tmp) {
    const detail::SurfacePtr surface = detail::raster_surface(image);
    detail::check_cairo(cairo_surface_status(surface.get()), png);
    detail::check_cairo(cairo_surface_write_to_png(surface.get(), tmp.c_str()), png);
  });
}

}  // namespace align3d::report
