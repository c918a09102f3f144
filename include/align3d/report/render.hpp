// Views of an inspected part: the CAD mesh, flat-shaded light grey, with the measured points
// splatted on top in their deviation colours (colormap.hpp). A small software renderer, since cairo
// has no depth buffer: triangles are rasterised into a z-buffer with edge functions (pixel centres,
// top-left fill rule), then each point is drawn as a small square or disc wherever it is not behind
// the mesh's visible surface, then the part's sharp and outline edges on top in dark grey.
//
// A pixel covered by several points shows the colour of their mean deviation: the same colour
// whatever the points' order, and no side of the deviation favoured. Outliers are context, drawn
// only where no measured point is, one pixel each and on every other pixel of a checkerboard, so
// that a fixture or a table does not outweigh the part. Nearest-point-wins would be biased: on a
// visible surface the outward normal faces the viewer, so the nearest of several points is the most
// positive one.
//
// Views are orthographic, each fitted to the mesh's extent with a margin:
//   top        looking down −z (from +z): x right, y up
//   front      looking along +y (from −y): x right, z up
//   side       the right side, looking along −x (from +x): y right, z up
//   isometric  looking along (−1, +1, −1) (from +x, −y, +z): z up
// Deterministic (one thread; same input, same pixels). One thread is enough: an 800 × 600 view of
// the generated part with 2 million points took 40-80 ms (90-150 ms on a loaded machine), mesh
// and edges included. No point is ever skipped: the density is part of what a reader sees.
// The four views composed into one figure with a colour bar: views_figure.hpp.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "align3d/inspect.hpp"
#include "align3d/mesh.hpp"

namespace align3d::report {

enum class View : std::uint8_t { kTop, kFront, kSide, kIsometric };
inline constexpr std::array<View, 4> kViews = {View::kTop, View::kFront, View::kSide,
                                               View::kIsometric};
const char* view_name(View view);   // "top", "front", "side", "isometric" (file names)
const char* view_title(View view);  // "Top", "Front", "Right side", "Isometric"
const char* view_axes(View view);   // "looking down −z: x right, y up", ... (as listed above)

// The scan points to draw: positions[i] moved by T_mesh_points into the mesh's frame, coloured by
// deviation_color(deviation[i], band) (NaN: an outlier, grey). The spans must be of equal length
// and outlive the call.
struct DeviationPoints {
  std::span<const Eigen::Vector3d> positions;
  std::span<const double> deviation;
  Eigen::Isometry3d T_mesh_points = Eigen::Isometry3d::Identity();
  Tolerance band;
  // A point is hidden when it lies farther than this behind the mesh's visible surface at its
  // pixel (data units). Measured points lie up to the outlier distance inside the material, so
  // pass DeviationMap::max_distance; the renderer adds 2 pixels' worth for the depth buffer's
  // sampling. 0: 2 pixels only.
  double depth_tolerance = 0;
};

struct ViewSettings {
  int width = 800, height = 600;  // pixels, each in [16, 16384]
  double margin = 0.05;           // share of the width and height left empty on each side
  // Side of a measured point's splat in pixels (a square up to 2, a disc above; an outlier is
  // always one pixel). 0: 1.5 × the spacing of the measured points seen in the view, √(the mesh's
  // visible pixels / the measured points on them), rounded up and clamped to [1, 9]; the 1.5
  // covers scan rows farther apart than the points along them, and partial coverage of the
  // visible surface errs the same way, towards larger splats: no holes.
  int splat = 0;
};

// Orthographic projection of one view onto the image: pixel x = scale·(right·p) + offset.x, pixel
// y = offset.y − scale·(up·p) (y grows downwards; pixel (i, j) covers [i, i+1) × [j, j+1)), depth
// toward·p, larger is nearer. `fit_view` centres the mesh's projected extent in the image and
// scales it to fill width × height less the margins (the tighter of the two directions decides).
struct ViewCamera {
  Eigen::Matrix3d rotation;  // rows: right, up, toward the viewer (a rotation: det = +1)
  double scale = 1;          // pixels per data unit
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();

  Eigen::Vector2d pixel(const Eigen::Vector3d& p) const;
  double depth(const Eigen::Vector3d& p) const { return rotation.row(2).dot(p); }
};
Eigen::Matrix3d view_rotation(View view);
// Throws std::invalid_argument for an empty mesh or a bad size.
ViewCamera fit_view(const TriangleMesh& mesh, View view, int width, int height, double margin);

// An opaque image in cairo's ARGB32 layout (native-endian 0xAARRGGBB words, rows top to bottom,
// no padding), ready for cairo_image_surface_create_for_data.
inline constexpr std::uint32_t kViewBackground = 0xffffffffu;  // white: no mesh and no point
struct Raster {
  int width = 0, height = 0;
  std::vector<std::uint32_t> pixels;
  std::uint32_t at(int x, int y) const {
    return pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                  static_cast<std::size_t>(x)];
  }
};

struct ViewImage {
  Raster image;
  ViewCamera camera;
  int splat = 0;                 // the splat side used, pixels
  std::size_t drawn_points = 0;  // points not hidden and inside the image
};

// Renders one view of `mesh` with `points` on it. Throws DataError("mesh", …) for a mesh
// check_mesh rejects, std::invalid_argument for spans of different lengths, a bad size or margin
// (outside [0, 0.45]) or a splat outside [0, 64].
ViewImage render_view(const TriangleMesh& mesh, const DeviationPoints& points, View view,
                      const ViewSettings& settings = {});

// Writes the image as a PNG, atomically (io/atomic_file.hpp). Throws OutputError naming `png`.
void write_png(const Raster& image, const std::filesystem::path& png);

}  // namespace align3d::report
