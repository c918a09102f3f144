// The software renderer of the inspection's views (report/render.hpp): a unit cube with points on
// its faces, each face's points at a known deviation, checked pixel by pixel against the projection
// computed here from the documented fit (scale and offset), the depth test and the colour map.
#include "align3d/report/render.hpp"

#include <cairo.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/report/colormap.hpp"
#include "align3d/report/views_figure.hpp"
#include "mesh_test_util.hpp"
#include "test_util.hpp"

namespace align3d::report {
namespace {

constexpr int kSide = 200;  // square images: the cube's extent fills 90 % of them in every view
constexpr std::uint32_t kWhite = 0xffffffffu;
const Tolerance kBand{-0.1, 0.1};
using test::kNan;

std::uint32_t packed(const Rgb& c) {
  auto byte = [](double v) { return static_cast<std::uint32_t>(std::lround(255 * v)); };
  return 0xff000000u | byte(c[0]) << 16 | byte(c[1]) << 8 | byte(c[2]);
}
std::uint32_t colour_of(double deviation) { return packed(deviation_color(deviation, kBand)); }

// The unit cube [0, 1]³ and points on two opposite faces: `near_face` (the one facing the viewer)
// at deviation +0.05, the other at −0.05, on a grid of `n` × `n` cell centres.
struct Scene {
  TriangleMesh cube = test::box_mesh({0, 0, 0}, {1, 1, 1});
  std::vector<Eigen::Vector3d> points;
  std::vector<double> deviation;

  void add(const Eigen::Vector3d& p, double d) {
    points.push_back(p);
    deviation.push_back(d);
  }
  // The face where coordinate `axis` equals `value`.
  void add_face(int axis, double value, double d, int n = 40) {
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        Eigen::Vector3d p;
        p((axis + 1) % 3) = (i + 0.5) / n;
        p((axis + 2) % 3) = (j + 0.5) / n;
        p(axis) = value;
        add(p, d);
      }
    }
  }
  DeviationPoints view_points(double depth_tolerance = 0.05) const {
    DeviationPoints p;
    p.positions = points;
    p.deviation = deviation;
    p.band = kBand;
    p.depth_tolerance = depth_tolerance;
    return p;
  }
};

ViewImage render(const Scene& s, View view, int splat = 3) {
  ViewSettings settings;
  settings.width = kSide;
  settings.height = kSide;
  settings.splat = splat;
  return render_view(s.cube, s.view_points(), view, settings);
}

// The documented fit for the unit cube in an orthographic view: extent 1 × 1, so the scale is
// 0.9 × 200 = 180 pixels per unit and the cube's projection spans pixels 10 … 190 both ways.
// (right, up) are the data coordinates the view shows to the right and upwards.
Eigen::Vector2d expected_pixel(double right, double up) {
  const double scale = kSide * (1 - 2 * 0.05);
  return {0.5 * kSide + scale * (right - 0.5), 0.5 * kSide - scale * (up - 0.5)};
}

struct OrthoCase {
  View view;
  int right_axis, up_axis;  // data axes shown to the right and up
  int depth_axis;           // the axis the view looks along
  double near_value;        // the face of the cube facing the viewer
};

const OrthoCase kOrthoCases[] = {
    {View::kTop, 0, 1, 2, 1.0},    // looking down −z: x right, y up; the top face z = 1
    {View::kFront, 0, 2, 1, 0.0},  // looking along +y: x right, z up; the front face y = 0
    {View::kSide, 1, 2, 0, 1.0},   // looking along −x: y right, z up; the right face x = 1
};

TEST(RenderViews, RotationsAreProperAndNamedAsDocumented) {
  for (View v : kViews) {
    const Eigen::Matrix3d R = view_rotation(v);
    EXPECT_NEAR((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
    EXPECT_NEAR(R.determinant(), 1, 1e-12);
  }
  for (const OrthoCase& c : kOrthoCases) {
    const Eigen::Matrix3d R = view_rotation(c.view);
    EXPECT_EQ(R.row(0), Eigen::RowVector3d::Unit(c.right_axis)) << view_name(c.view);
    EXPECT_EQ(R.row(1), Eigen::RowVector3d::Unit(c.up_axis)) << view_name(c.view);
    // The viewer sits on the near face's side.
    EXPECT_EQ(R(2, c.depth_axis), c.near_value > 0.5 ? 1.0 : -1.0) << view_name(c.view);
  }
  const Eigen::Matrix3d iso = view_rotation(View::kIsometric);
  EXPECT_NEAR((iso.row(2).transpose() - Eigen::Vector3d(1, -1, 1).normalized()).norm(), 0, 1e-12);
  EXPECT_GT(iso(1, 2), 0);  // z points up
}

TEST(RenderViews, NearFaceShowsAndFarFaceIsHidden) {
  for (const OrthoCase& c : kOrthoCases) {
    Scene s;
    s.add_face(c.depth_axis, c.near_value, 0.05);
    s.add_face(c.depth_axis, 1 - c.near_value, -0.05);
    const ViewImage out = render(s, c.view);
    const Eigen::Vector2d centre = expected_pixel(0.5, 0.5);
    EXPECT_EQ(out.image.at(static_cast<int>(centre.x()), static_cast<int>(centre.y())),
              colour_of(0.05))
        << view_name(c.view);
    // The far face is behind the near one everywhere: its colour appears nowhere.
    const auto far = std::count(out.image.pixels.begin(), out.image.pixels.end(), colour_of(-0.05));
    EXPECT_EQ(far, 0) << view_name(c.view);
    EXPECT_EQ(out.drawn_points, 40u * 40u) << view_name(c.view);
  }
}

TEST(RenderViews, IsometricShowsTheTopAndHidesTheBottom) {
  Scene s;
  s.add_face(2, 1.0, 0.05);
  // The bottom's points away from its edges: there the side faces in front of them are nearer
  // than the depth tolerance, within which points show by design (they may lie inside the
  // material by up to the outlier distance).
  for (int i = 0; i <= 10; ++i) {
    for (int j = 0; j <= 10; ++j) s.add({0.2 + 0.06 * i, 0.2 + 0.06 * j, 0.0}, -0.05);
  }
  const ViewImage out = render(s, View::kIsometric);
  const Eigen::Vector2d top_centre = out.camera.pixel({0.5, 0.5, 1.0});
  EXPECT_EQ(out.image.at(static_cast<int>(top_centre.x()), static_cast<int>(top_centre.y())),
            colour_of(0.05));
  EXPECT_EQ(std::count(out.image.pixels.begin(), out.image.pixels.end(), colour_of(-0.05)), 0);
}

TEST(RenderViews, BackgroundWhereNothingIs) {
  Scene s;
  s.add_face(2, 1.0, 0.05);
  for (const OrthoCase& c : kOrthoCases) {
    const ViewImage out = render(s, c.view);
    for (const auto& [x, y] : {std::pair{2, 2},
                               {kSide - 3, 2},
                               {2, kSide - 3},
                               {kSide - 3, 100},
                               {100, kSide - 3},
                               {7, 100},
                               {100, 7}}) {
      EXPECT_EQ(out.image.at(x, y), kWhite) << view_name(c.view) << " at " << x << ", " << y;
    }
  }
}

TEST(RenderViews, SplatLandsWhereTheProjectionPutsIt) {
  for (const OrthoCase& c : kOrthoCases) {
    Scene s;
    Eigen::Vector3d p;
    p(c.right_axis) = 0.25;
    p(c.up_axis) = 0.75;
    p(c.depth_axis) = c.near_value;  // on the visible face
    s.add(p, 0.07);
    Eigen::Vector3d q = p;  // beside the cube, over the background
    q(c.right_axis) = -0.03;
    q(c.up_axis) = 0.5;
    s.add(q, -0.02);
    const ViewImage out = render(s, c.view, 1);
    const Eigen::Vector2d e = expected_pixel(0.25, 0.75);
    EXPECT_NEAR((out.camera.pixel(p) - e).norm(), 0, 1e-9) << view_name(c.view);
    const int x = static_cast<int>(std::floor(e.x())), y = static_cast<int>(std::floor(e.y()));
    EXPECT_EQ(out.image.at(x, y), colour_of(0.07)) << view_name(c.view);
    EXPECT_NE(out.image.at(x + 2, y), colour_of(0.07)) << view_name(c.view);
    EXPECT_NE(out.image.at(x, y + 2), colour_of(0.07)) << view_name(c.view);
    const Eigen::Vector2d f = expected_pixel(-0.03, 0.5);  // (4.6, 100)
    EXPECT_EQ(out.image.at(static_cast<int>(f.x()), static_cast<int>(f.y())), colour_of(-0.02))
        << view_name(c.view);
  }
}

TEST(RenderViews, PointBehindThePartIsHidden) {
  Scene s;
  s.add({0.5, 0.5, -0.5}, 0.08);   // under the cube, seen from the top: hidden
  s.add({0.3, 0.3, 0.98}, -0.06);  // just inside the top face, within the depth tolerance: shown
  const ViewImage out = render(s, View::kTop, 1);
  const Eigen::Vector2d hidden = expected_pixel(0.5, 0.5), shown = expected_pixel(0.3, 0.3);
  EXPECT_EQ(std::count(out.image.pixels.begin(), out.image.pixels.end(), colour_of(0.08)), 0);
  EXPECT_NE(out.image.at(static_cast<int>(hidden.x()), static_cast<int>(hidden.y())), kWhite);
  EXPECT_EQ(out.image.at(static_cast<int>(shown.x()), static_cast<int>(shown.y())),
            colour_of(-0.06));
  EXPECT_EQ(out.drawn_points, 1u);
}

TEST(RenderViews, TrianglesSharingAnEdgeLeaveNoGap) {
  // The top face's two triangles meet on the diagonal from (0, 0) to (1, 1), which runs through
  // the centres of the pixels with x + y = 199: the top-left rule must give each to one of them.
  Scene s;
  const ViewImage out = render(s, View::kTop);
  for (int x = 12; x <= 187; ++x) {
    EXPECT_NE(out.image.at(x, 199 - x), kWhite) << x;
  }
}

TEST(RenderViews, SplatSizeFollowsThePointSpacing) {
  Scene s;
  s.add_face(2, 1.0, 0.05, 50);  // 2 500 points on the 180 × 180 pixels the mesh covers
  const ViewImage out = render(s, View::kTop, 0);
  EXPECT_EQ(out.splat, static_cast<int>(std::ceil(1.5 * std::sqrt(180.0 * 180.0 / 2500) - 0.05)));
  // No hole: every pixel inside the face (off its edge lines) shows the points' colour.
  for (int y = 12; y < 188; ++y) {
    for (int x = 12; x < 188; ++x) ASSERT_EQ(out.image.at(x, y), colour_of(0.05)) << x << ", " << y;
  }
}

TEST(RenderViews, GapBetweenSplatsIsFilledFromBothSidesOnly) {
  Scene s;
  const Eigen::Vector2d at = expected_pixel(0.5, 0.5);  // (100, 100): pixel centres at .5
  auto data = [&](double px, double py) {  // the top face point drawn at pixel (px, py)
    return Eigen::Vector3d(0.5 + (px + 0.5 - at.x()) / 180, 0.5 - (py + 0.5 - at.y()) / 180, 1);
  };
  s.add(data(100, 100), 0.02);
  s.add(data(102, 100), 0.06);
  const ViewImage out = render(s, View::kTop, 1);
  EXPECT_EQ(out.image.at(100, 100), colour_of(0.02));
  EXPECT_EQ(out.image.at(102, 100), colour_of(0.06));
  EXPECT_EQ(out.image.at(101, 100), colour_of(0.04));  // between the two: their mean
  EXPECT_NE(out.image.at(103, 100), colour_of(0.06));  // one side only: stays the mesh
  EXPECT_NE(out.image.at(103, 100), kWhite);
}

TEST(RenderViews, OutliersAreGreyOnACheckerboard) {
  Scene s;
  const Eigen::Vector2d e = expected_pixel(-0.03, 0.5);  // pixel (4, 100), over the background
  s.add({-0.03, 0.5, 0.5}, kNan);
  s.add({-0.03 + 1.0 / 180, 0.5, 0.5}, kNan);  // its neighbour (5, 100)
  const ViewImage out = render(s, View::kTop, 3);
  const int x = static_cast<int>(e.x()), y = static_cast<int>(e.y());
  ASSERT_EQ((x + y) % 2, 0);
  EXPECT_EQ(out.image.at(x, y), packed(kOutlierColor));  // one pixel each, whatever the splat
  EXPECT_EQ(out.image.at(x + 1, y), kWhite);             // odd square of the checkerboard
  EXPECT_EQ(out.image.at(x, y + 1), kWhite);             // odd, and not splatted
  EXPECT_EQ(out.image.at(x + 2, y), kWhite);             // beyond the one pixel
}

TEST(RenderViews, MovesThePointsIntoTheMeshFrame) {
  Scene s;
  const Eigen::Vector3d in_cad(0.25, 0.75, 1.0);
  Eigen::Isometry3d T_cad_scan = Eigen::Isometry3d::Identity();
  T_cad_scan.rotate(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  T_cad_scan.pretranslate(Eigen::Vector3d(5, -2, 7));
  s.add(T_cad_scan.inverse() * in_cad, 0.07);  // the scan frame
  DeviationPoints points = s.view_points();
  points.T_mesh_points = T_cad_scan;
  const ViewImage out = render_view(s.cube, points, View::kTop, {kSide, kSide, 0.05, 1});
  const Eigen::Vector2d e = expected_pixel(0.25, 0.75);
  EXPECT_EQ(out.image.at(static_cast<int>(e.x()), static_cast<int>(e.y())), colour_of(0.07));
}

TEST(RenderViews, SameInputSameBytes) {
  Scene s;
  s.add_face(2, 1.0, 0.05);
  s.add_face(0, 1.0, -0.03);
  test::TempDir dir("render_test");
  const ViewImage a = render(s, View::kIsometric, 0), b = render(s, View::kIsometric, 0);
  EXPECT_EQ(a.image.pixels, b.image.pixels);
  write_png(a.image, dir / "a.png");
  write_png(b.image, dir / "b.png");
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_FALSE(bytes(dir / "a.png").empty());
  EXPECT_EQ(bytes(dir / "a.png"), bytes(dir / "b.png"));
}

TEST(RenderViews, RejectsBadInput) {
  Scene s;
  s.add_face(2, 1.0, 0.05, 2);
  DeviationPoints p = s.view_points();
  const std::vector<double> short_deviation(3, 0.0);
  p.deviation = short_deviation;
  EXPECT_THROW(render_view(s.cube, p, View::kTop), std::invalid_argument);
  EXPECT_THROW(render_view(s.cube, s.view_points(), View::kTop, {8, 600}), std::invalid_argument);
  EXPECT_THROW(render_view(s.cube, s.view_points(), View::kTop, {800, 600, 0.5}),
               std::invalid_argument);
  EXPECT_THROW(render_view(TriangleMesh{}, s.view_points(), View::kTop), DataError);
  TriangleMesh broken = s.cube;
  broken.triangles[0][1] = 99;  // out of range
  EXPECT_THROW(render_view(broken, s.view_points(), View::kTop), DataError);
}

TEST(RenderViews, ComposedFigureHasTheKeysAndTheBand) {
  Scene s;
  s.add_face(2, 1.0, 0.05);
  test::TempDir dir("render_test");
  ViewsFigureSettings settings;
  settings.view = {240, 180};
  write_views_figure(s.cube, s.view_points(), dir / "views.png", settings);
  cairo_surface_t* png = cairo_image_surface_create_from_png((dir / "views.png").c_str());
  ASSERT_EQ(cairo_surface_status(png), CAIRO_STATUS_SUCCESS);
  const int w = cairo_image_surface_get_width(png), h = cairo_image_surface_get_height(png);
  EXPECT_GT(w, 2 * 240);
  EXPECT_GT(h, 2 * 180);
  const auto* data = reinterpret_cast<const std::uint32_t*>(cairo_image_surface_get_data(png));
  const int stride = cairo_image_surface_get_stride(png) / 4;
  // Within one level per channel: cairo rounds a colour's components to 8 bits its own way.
  auto count = [&](std::uint32_t c) {
    long n = 0;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const std::uint32_t v = data[y * stride + x];
        bool near = true;
        for (int shift : {0, 8, 16}) {
          near = near && std::abs(static_cast<int>((v >> shift) & 0xff) -
                                  static_cast<int>((c >> shift) & 0xff)) <= 1;
        }
        n += near;
      }
    }
    return n;
  };
  for (const Rgb& key : {kAboveColor, kBelowColor, kOutlierColor})
    EXPECT_GT(count(packed(key)), 50);
  EXPECT_GT(count(colour_of(0.05)), 4 * 1000);  // the top face in the top and isometric views
  EXPECT_GT(count(colour_of(0.1)), 0);          // the bar's upper end
  cairo_surface_destroy(png);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

TEST(RenderViews, NumbersAreFormattedForTheBand) {
  EXPECT_EQ(band_value(0.1, "mm"), "+0.1 mm");
  EXPECT_EQ(band_value(-0.05, ""), "\u22120.05");
  EXPECT_EQ(band_value(0, "mm"), "0 mm");
  EXPECT_EQ(format_deviation(0.012345, kBand, "mm"), "+0.0123 mm");  // 0.2 wide: 4 decimals
  EXPECT_EQ(format_deviation(-0.00001, kBand, "mm"), "0.0000 mm");   // no "−0"
  EXPECT_EQ(format_deviation(0.5, {-1, 1}, "", false), "0.500");
  EXPECT_EQ(format_count(1234567), "1\u2009234\u2009567");
  EXPECT_EQ(format_count(12), "12");
}

}  // namespace
}  // namespace align3d::report
