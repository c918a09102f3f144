#include "align3d/report/figure.hpp"

#include <cairo.h>
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "png_image.hpp"
#include "test_util.hpp"

namespace align3d::report {
namespace {

namespace fs = std::filesystem;

// cairo's toy text API caches fonts, and fontconfig its configuration, for the life of the process;
// LeakSanitizer reports both at exit. Release them after the last test. FcFini is looked up at run
// time (fontconfig is loaded as cairo's dependency) so the test needs no fontconfig build flags.
class ReleaseFontCaches : public ::testing::Environment {
 public:
  void TearDown() override {
    cairo_debug_reset_static_data();
    if (void* fc_fini = dlsym(RTLD_DEFAULT, "FcFini")) {
      reinterpret_cast<void (*)()>(reinterpret_cast<std::uintptr_t>(fc_fini))();
    }
  }
};
[[maybe_unused]] const auto* const kReleaseFontCaches =
    ::testing::AddGlobalTestEnvironment(new ReleaseFontCaches);

class FigureTest : public ::testing::Test {
 protected:
  test::TempDir temp_{"figure_test"};  // each test's own empty folder, removed afterwards
  const fs::path dir_ = temp_.path();
};

using Image = test::PngImage;

bool is_red(Image::Rgb8 c) { return c.r > 200 && c.g < 90 && c.b < 90; }
bool is_blue(Image::Rgb8 c) { return c.b > 200 && c.r < 90 && c.g < 90; }
bool is_green(Image::Rgb8 c) { return c.g > 100 && c.r < 60 && c.b < 60; }
bool is_dark(Image::Rgb8 c) { return c.r + c.g + c.b < 300; }

std::string read_all(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Series scatter(Rgb color, std::vector<Eigen::Vector2d> points, std::string label = "") {
  Series s;
  s.label = std::move(label);
  s.color = color;
  s.points = std::move(points);
  s.size = 3;
  s.alpha = 1;
  return s;
}

// Blue points spread over [0, 10]^2 and a red cluster at the (10, 10) corner.
Figure corner_figure() {
  Figure f;
  f.title = "Placement";
  f.x_label = "x [mm]";
  f.y_label = "y [mm]";
  std::vector<Eigen::Vector2d> blue, red;
  for (int i = 0; i <= 10; ++i) blue.emplace_back(i, i);
  blue.emplace_back(0, 10);
  blue.emplace_back(10, 0);
  for (int i = 0; i < 20; ++i) red.emplace_back(9.5 + 0.025 * i, 9.5 + 0.025 * (i % 5));
  f.series.push_back(scatter({0, 0, 1}, blue));
  f.series.push_back(scatter({1, 0, 0}, red));
  return f;
}

TEST_F(FigureTest, WritesSvgAndPngOfTheRequestedSize) {
  Figure f = corner_figure();
  f.width = 640;
  f.height = 480;
  write_figure(f, dir_ / "fig");

  ASSERT_TRUE(fs::exists(dir_ / "fig.svg"));
  ASSERT_TRUE(fs::exists(dir_ / "fig.png"));
  const std::string svg = read_all(dir_ / "fig.svg");
  EXPECT_TRUE(svg.starts_with("<?xml") || svg.starts_with("<svg"));
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);

  const Image png(dir_ / "fig.png");
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png.width(), 640);
  EXPECT_EQ(png.height(), 480);
  EXPECT_EQ(png.at(0, 0).r, 255);  // white background
  EXPECT_EQ(png.at(0, 0).b, 255);

  // Only the two figure files are left in the directory (no temporaries).
  int files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 2);
}

TEST_F(FigureTest, DataCornerMapsToImageQuadrant) {
  write_figure(corner_figure(), dir_ / "fig");
  const Image png(dir_ / "fig.png");
  ASSERT_TRUE(png.ok());
  const int w = png.width(), h = png.height();
  // Large x is right, large y is up: the red cluster is in the upper-right quadrant only.
  EXPECT_GT(png.count(w / 2, 0, w, h / 2, is_red), 20);
  EXPECT_EQ(png.count(0, h / 2, w / 2, h, is_red), 0);
  EXPECT_EQ(png.count(0, 0, w / 2, h / 2, is_red), 0);
  EXPECT_EQ(png.count(w / 2, h / 2, w, h, is_red), 0);
  EXPECT_GT(png.count(0, h / 2, w / 2, h, is_blue), 20);
}

TEST_F(FigureTest, LogAxisPutsLargeValuesAtTheTop) {
  Figure f;
  f.log_y = true;
  Series line;
  line.line = true;
  line.color = {1, 0, 0};
  line.alpha = 1;
  line.size = 2;
  for (int i = 0; i < 30; ++i) line.points.emplace_back(i, 1e3 * std::pow(10.0, -0.2 * i));
  f.series.push_back(line);
  f.series.push_back(scatter({0, 0, 1}, {{0, 1e-4}, {29, 1e-4}}));
  write_figure(f, dir_ / "log");
  const Image png(dir_ / "log.png");
  ASSERT_TRUE(png.ok());
  const int w = png.width(), h = png.height();
  // The curve falls from 1000 (upper left) to 1e-3 (lower right) above the blue points at 1e-4.
  EXPECT_GT(png.count(0, 0, w / 3, h / 3, is_red), 20);
  EXPECT_EQ(png.count(0, 2 * h / 3, w / 3, h, is_red), 0);
  EXPECT_GT(png.count(0, 2 * h / 3, w, h, is_blue), 10);
  EXPECT_EQ(png.count(0, 0, w, h / 2, is_blue), 0);
}

TEST_F(FigureTest, EqualAspectKeepsCirclesRound) {
  Figure f;
  f.equal_aspect = true;
  f.width = 900;
  f.height = 500;
  std::vector<Eigen::Vector2d> circle;
  for (int i = 0; i < 720; ++i) {
    const double a = i * 2 * std::numbers::pi / 720;
    circle.emplace_back(std::cos(a), std::sin(a));
  }
  f.series.push_back(scatter({1, 0, 0}, circle));
  f.series.back().size = 1.5;
  f.series.push_back(scatter({0, 0, 1}, {{8, 0}}));  // makes the x range much wider than y
  write_figure(f, dir_ / "circle");
  const Image png(dir_ / "circle.png");
  ASSERT_TRUE(png.ok());
  int x0 = png.width(), x1 = -1, y0 = png.height(), y1 = -1;
  for (int y = 0; y < png.height(); ++y) {
    for (int x = 0; x < png.width(); ++x) {
      if (!is_red(png.at(x, y))) continue;
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  }
  ASSERT_GE(x1, 0);
  const double bw = x1 - x0 + 1, bh = y1 - y0 + 1;
  EXPECT_GT(bh, 50);
  EXPECT_NEAR(bw / bh, 1.0, 0.03);
}

TEST_F(FigureTest, TitleTextIsRendered) {
  // Above the plot frame only the title is drawn, so dark pixels there mean a font was found.
  auto dark_rows_above_frame = [&](const std::string& title) {
    Figure f = corner_figure();
    f.title = title;
    write_figure(f, dir_ / "t");
    const Image png(dir_ / "t.png");
    int frame_row = 0;
    while (frame_row < png.height() &&
           png.count(0, frame_row, png.width(), frame_row + 1, is_dark) < png.width() / 3) {
      ++frame_row;
    }
    return png.count(0, 0, png.width(), frame_row, is_dark);
  };
  EXPECT_EQ(dark_rows_above_frame(""), 0);
  EXPECT_GT(dark_rows_above_frame("ICP result: bunny, XZ view"), 100);
}

TEST_F(FigureTest, LegendShowsLabelledSeries) {
  Figure f = corner_figure();
  f.series.push_back(scatter({0, 0.6, 0}, {{5, 2}}));
  write_figure(f, dir_ / "unlabelled");
  f.series.back().label = "green point";
  f.lines.push_back({5.0, "reference", {0.5, 0.5, 0.5}, true});
  write_figure(f, dir_ / "labelled");
  const Image without(dir_ / "unlabelled.png");
  const Image with(dir_ / "labelled.png");
  EXPECT_GT(with.count(is_green), without.count(is_green) + 10);
}

TEST_F(FigureTest, LegendGoesToTheCornerWithoutData) {
  // A red band along the top and a blue point at the lower left leave only the lower-right corner
  // free, so the legend, and with it the red legend marker, must go there and hide no red dot.
  Figure f;
  std::vector<Eigen::Vector2d> band;
  for (int i = 0; i <= 100; ++i) {
    for (int j = 0; j <= 10; ++j) band.emplace_back(0.1 * i, 9 + 0.1 * j);
  }
  f.series.push_back(scatter({1, 0, 0}, band));
  f.series.push_back(scatter({0, 0, 1}, {{0, 0}}));
  write_figure(f, dir_ / "plain");
  f.series[0].label = "band";
  write_figure(f, dir_ / "legend");
  const Image plain(dir_ / "plain.png");
  const Image legend(dir_ / "legend.png");
  const int w = plain.width(), h = plain.height();
  EXPECT_EQ(plain.count(w / 2, h / 2, w, h, is_red), 0);
  EXPECT_GT(legend.count(w / 2, h / 2, w, h, is_red), 10);
  EXPECT_EQ(legend.count(0, 0, w, h / 2, is_red), plain.count(0, 0, w, h / 2, is_red));
}

TEST_F(FigureTest, DegenerateAndNonFiniteInputDraws) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Figure f;
  f.series.push_back(scatter({1, 0, 0}, {{2, 1}, {2, 3}, {nan, 1}, {2, inf}}));  // all x equal
  Series line;
  line.line = true;
  line.points = {{2, 2}, {2, nan}, {2, 2.5}};
  f.series.push_back(line);
  ASSERT_NO_THROW(write_figure(f, dir_ / "flat"));
  const Image png(dir_ / "flat.png");
  ASSERT_TRUE(png.ok());
  // All red dots share one x: they form one narrow column, away from the image edges.
  int x0 = png.width(), x1 = -1;
  for (int y = 0; y < png.height(); ++y) {
    for (int x = 0; x < png.width(); ++x) {
      if (is_red(png.at(x, y))) x0 = std::min(x0, x), x1 = std::max(x1, x);
    }
  }
  ASSERT_GE(x1, 0);
  EXPECT_LE(x1 - x0, 8);
  EXPECT_GT(x0, png.width() / 4);
  EXPECT_LT(x1, 3 * png.width() / 4);

  Figure single;  // one point: both ranges degenerate
  single.series.push_back(scatter({1, 0, 0}, {{0, 0}}));
  EXPECT_NO_THROW(write_figure(single, dir_ / "single"));
}

TEST_F(FigureTest, LargeCloudDraws) {
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0, 10);
  std::vector<Eigen::Vector2d> a, b;
  for (int i = 0; i < 25000; ++i) a.emplace_back(n(rng), 0.3 * n(rng));
  for (int i = 0; i < 25000; ++i) b.emplace_back(n(rng) + 5, 0.3 * n(rng) + 1);
  Figure f;
  f.equal_aspect = true;
  f.series.push_back(scatter({1, 0, 0}, a, "source"));
  f.series.push_back(scatter({0, 0, 1}, b, "target"));
  ASSERT_NO_THROW(write_figure(f, dir_ / "large"));
  const Image png(dir_ / "large.png");
  EXPECT_GT(png.count(is_red), 1000);
}

TEST_F(FigureTest, NonPositiveYOnLogAxisThrows) {
  Figure f;
  f.log_y = true;
  f.series.push_back(scatter({1, 0, 0}, {{0, 1}, {1, 0}}));
  EXPECT_THROW(write_figure(f, dir_ / "bad"), std::invalid_argument);
  f.series.back().points = {{0, 1}, {1, -2}};
  EXPECT_THROW(write_figure(f, dir_ / "bad"), std::invalid_argument);
  f.series.back().points = {{0, 1}, {1, 2}};
  f.lines.push_back({0.0, "zero", {0, 0, 0}, true});
  EXPECT_THROW(write_figure(f, dir_ / "bad"), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_ / "bad.svg"));
  EXPECT_FALSE(fs::exists(dir_ / "bad.png"));
}

TEST_F(FigureTest, InvalidUtf8TextThrows) {
  Figure f = corner_figure();
  f.y_label = "z [\xff]";
  EXPECT_THROW(write_figure(f, dir_ / "bad"), std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(FigureTest, EmptyFigureThrows) {
  Figure f;
  f.title = "nothing";
  EXPECT_THROW(write_figure(f, dir_ / "empty"), std::invalid_argument);
  f.series.push_back(scatter({1, 0, 0}, {}));
  f.lines.push_back({1.0, "a line alone is not data", {0, 0, 0}, true});
  EXPECT_THROW(write_figure(f, dir_ / "empty"), std::invalid_argument);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  f.series.back().points = {{nan, 1}};
  EXPECT_THROW(write_figure(f, dir_ / "empty"), std::invalid_argument);
}

TEST_F(FigureTest, MissingDirectoryThrowsOutputErrorNamingThePath) {
  const fs::path stem = dir_ / "no" / "such" / "dir" / "fig";
  try {
    write_figure(corner_figure(), stem);
    FAIL() << "expected OutputError";
  } catch (const OutputError& e) {
    EXPECT_NE(std::string(e.what()).find((dir_ / "no" / "such" / "dir").string()),
              std::string::npos)
        << e.what();
    EXPECT_EQ(e.code(), ExitCode::kOutput);
  }
  EXPECT_FALSE(fs::exists(dir_ / "no"));
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(FigureTest, FailureOnSecondFileLeavesNothingBehind) {
  // A directory where the PNG should go makes the final rename fail after both were drawn.
  fs::create_directory(dir_ / "fig.png");
  EXPECT_THROW(write_figure(corner_figure(), dir_ / "fig"), OutputError);
  EXPECT_FALSE(fs::exists(dir_ / "fig.svg"));
  int entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 1);  // only the directory we made
}

TEST_F(FigureTest, OverwritesAnExistingFigure) {
  write_figure(corner_figure(), dir_ / "fig");
  Figure f = corner_figure();
  f.width = 500;
  f.height = 400;
  write_figure(f, dir_ / "fig");
  const Image png(dir_ / "fig.png");
  EXPECT_EQ(png.width(), 500);
}

// ---------------------------------------------------------------------------------------------
// Heat maps

// The colour map's ends (viridis): dark purple for min_value, yellow for max_value.
constexpr Image::Rgb8 kLowEnd{0x44, 0x01, 0x54};
constexpr Image::Rgb8 kHighEnd{0xfd, 0xe7, 0x25};

bool near(Image::Rgb8 a, Image::Rgb8 b, int tolerance = 1) {
  return std::abs(a.r - b.r) <= tolerance && std::abs(a.g - b.g) <= tolerance &&
         std::abs(a.b - b.b) <= tolerance;
}

// A 4-connected region of pixels of one colour.
struct Blob {
  int x0, y0, x1, y1;  // inclusive bounding box
  int area;
  int cx() const { return (x0 + x1) / 2; }
  int cy() const { return (y0 + y1) / 2; }
};

// Regions of at least min_area pixels within 1 of `color`, left to right. The colour bar's
// gradient matches a colour in a strip a pixel or two high, far below a cell's area.
std::vector<Blob> blobs(const Image& png, Image::Rgb8 color, int min_area = 300) {
  const int w = png.width(), h = png.height();
  std::vector<char> seen(static_cast<std::size_t>(w) * h, 0);
  std::vector<Blob> out;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (seen[y * w + x] || !near(png.at(x, y), color)) continue;
      Blob b{x, y, x, y, 0};
      std::vector<std::pair<int, int>> stack{{x, y}};
      seen[y * w + x] = 1;
      while (!stack.empty()) {
        const auto [px, py] = stack.back();
        stack.pop_back();
        ++b.area;
        b.x0 = std::min(b.x0, px), b.x1 = std::max(b.x1, px);
        b.y0 = std::min(b.y0, py), b.y1 = std::max(b.y1, py);
        const int nx[4] = {px - 1, px + 1, px, px}, ny[4] = {py, py, py - 1, py + 1};
        for (int k = 0; k < 4; ++k) {
          if (nx[k] < 0 || ny[k] < 0 || nx[k] >= w || ny[k] >= h) continue;
          if (seen[ny[k] * w + nx[k]] || !near(png.at(nx[k], ny[k]), color)) continue;
          seen[ny[k] * w + nx[k]] = 1;
          stack.emplace_back(nx[k], ny[k]);
        }
      }
      if (b.area >= min_area) out.push_back(b);
    }
  }
  std::sort(out.begin(), out.end(), [](const Blob& a, const Blob& b) { return a.cx() < b.cx(); });
  return out;
}

HeatMap grid_map(int rows, int cols, double fill) {
  HeatMap m;
  m.title = "success rate";
  m.x_label = "rotation [deg]";
  m.y_label = "translation [m]";
  m.value_label = "success";
  for (int c = 0; c < cols; ++c) m.x_ticks.push_back(std::to_string(15 * c));
  for (int r = 0; r < rows; ++r) m.y_ticks.push_back(std::to_string(r) + ".5");
  m.values = Eigen::MatrixXd::Constant(rows, cols, fill);
  return m;
}

TEST_F(FigureTest, HeatMapWritesSvgAndPngOfTheRequestedSize) {
  const HeatMap m = grid_map(5, 8, 0.7);
  write_heatmap(m, dir_ / "heat");
  ASSERT_TRUE(fs::exists(dir_ / "heat.svg"));
  const std::string svg = read_all(dir_ / "heat.svg");
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  const Image png(dir_ / "heat.png");
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png.width(), 700);
  EXPECT_EQ(png.height(), 520);
  int files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 2);
}

TEST_F(FigureTest, HeatMapEndColoursLandInTheirCellsWithRowZeroAtTheBottom) {
  // 2 x 3: min_value in row 0, column 0 (lower left), max_value in row 1, column 2 (upper right),
  // the middle value elsewhere.
  HeatMap m = grid_map(2, 3, 0.5);
  m.annotate = false;
  m.values(0, 0) = 0;
  m.values(1, 2) = 1;
  write_heatmap(m, dir_ / "heat");
  const Image png(dir_ / "heat.png");
  ASSERT_TRUE(png.ok());

  const auto low = blobs(png, kLowEnd), high = blobs(png, kHighEnd);
  ASSERT_EQ(low.size(), 1u);
  ASSERT_EQ(high.size(), 1u);
  EXPECT_TRUE(near(png.at(low[0].cx(), low[0].cy()), kLowEnd));  // cell centres, exactly
  EXPECT_TRUE(near(png.at(high[0].cx(), high[0].cy()), kHighEnd));
  // Cells are solid rectangles of one size.
  for (const Blob& b : {low[0], high[0]}) {
    EXPECT_EQ(b.area, (b.x1 - b.x0 + 1) * (b.y1 - b.y0 + 1));
    EXPECT_GT(b.x1 - b.x0, 100);
    EXPECT_GT(b.y1 - b.y0, 100);
  }
  EXPECT_NEAR(low[0].x1 - low[0].x0, high[0].x1 - high[0].x0, 2);
  EXPECT_NEAR(low[0].y1 - low[0].y0, high[0].y1 - high[0].y0, 2);
  // Lower-left and upper-right: two cell pitches apart in x, one in y.
  const double pitch_x = 0.5 * (high[0].cx() - low[0].cx());
  const double pitch_y = low[0].cy() - high[0].cy();
  EXPECT_NEAR(pitch_x, low[0].x1 - low[0].x0 + 2, 3);  // a cell plus its white border
  EXPECT_NEAR(pitch_y, low[0].y1 - low[0].y0 + 2, 3);

  // The four other cells hold one middle colour, whatever it is: sample the cell right of the
  // lower-left one, and find it at the other three places of the lattice too.
  const Image::Rgb8 mid = png.at(static_cast<int>(low[0].cx() + pitch_x), low[0].cy());
  const auto middles = blobs(png, mid);
  ASSERT_EQ(middles.size(), 4u);
  for (const Blob& b : middles) {
    const double col = (b.cx() - low[0].cx()) / pitch_x, row = (low[0].cy() - b.cy()) / pitch_y;
    EXPECT_NEAR(col, std::round(col), 0.05);
    EXPECT_NEAR(row, std::round(row), 0.05);
  }
  // White borders between cells.
  const Image::Rgb8 between = png.at(low[0].x1 + 1, low[0].cy());
  EXPECT_EQ(between.r + between.g + between.b, 3 * 255);
}

TEST_F(FigureTest, HeatMapValuesAreWrittenInContrastingColours) {
  HeatMap m = grid_map(2, 3, 0.5);
  m.values(0, 0) = 0;
  m.values(1, 2) = 1;
  m.annotate = false;
  write_heatmap(m, dir_ / "plain");
  m.annotate = true;
  write_heatmap(m, dir_ / "annotated");
  const Image plain(dir_ / "plain.png"), annotated(dir_ / "annotated.png");
  const auto low = blobs(plain, kLowEnd), high = blobs(plain, kHighEnd);
  ASSERT_EQ(low.size(), 1u);
  ASSERT_EQ(high.size(), 1u);
  auto whitish = [](Image::Rgb8 c) { return c.r > 200 && c.g > 200 && c.b > 200; };
  auto blackish = [](Image::Rgb8 c) { return c.r + c.g + c.b < 150; };
  const Blob& l = low[0];
  const Blob& h = high[0];
  EXPECT_EQ(plain.count(l.x0, l.y0, l.x1, l.y1, whitish), 0);
  EXPECT_EQ(plain.count(h.x0, h.y0, h.x1, h.y1, blackish), 0);
  EXPECT_GT(annotated.count(l.x0, l.y0, l.x1, l.y1, whitish), 20);   // "0%" in white on purple
  EXPECT_GT(annotated.count(h.x0, h.y0, h.x1, h.y1, blackish), 20);  // "100%" in black on yellow
  EXPECT_EQ(annotated.count(h.x0, h.y0, h.x1, h.y1, whitish), 0);
}

TEST_F(FigureTest, HeatMapNoDataCellsAreDrawnGray) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  HeatMap m = grid_map(2, 3, 0);
  m.values(1, 1) = nan;
  m.values(0, 2) = std::numeric_limits<double>::infinity();
  ASSERT_NO_THROW(write_heatmap(m, dir_ / "gaps"));
  const Image png(dir_ / "gaps.png");
  ASSERT_TRUE(png.ok());
  auto cells = blobs(png, kLowEnd);  // the four cells with data: (0, 0), (0, 1), (1, 0), (1, 2)
  ASSERT_EQ(cells.size(), 4u);
  int bottom = 0;
  for (const Blob& b : cells) bottom = std::max(bottom, b.cy());
  std::vector<Blob> lower, upper;  // each left to right
  for (const Blob& b : cells) (b.cy() > bottom - 5 ? lower : upper).push_back(b);
  ASSERT_EQ(lower.size(), 2u);
  ASSERT_EQ(upper.size(), 2u);
  // The gaps, (1, 1) and (0, 2), are light gray with darker gray hatching.
  auto gray = [](Image::Rgb8 c) { return c.r == c.g && c.g == c.b && c.r > 150 && c.r < 240; };
  auto expect_gray = [&](const Blob& column, const Blob& row) {
    const int area = (column.x1 - column.x0) * (row.y1 - row.y0);
    EXPECT_GT(png.count(column.x0, row.y0, column.x1, row.y1, gray), area * 9 / 10);
    EXPECT_LT(
        png.count(column.x0, row.y0, column.x1, row.y1, [](Image::Rgb8 c) { return c.r < 200; }),
        area / 2);
    EXPECT_GT(
        png.count(column.x0, row.y0, column.x1, row.y1, [](Image::Rgb8 c) { return c.r < 200; }),
        area / 20);
  };
  expect_gray(lower[1], upper[0]);
  expect_gray(upper[1], lower[0]);

  m.values.setConstant(nan);  // nothing but gaps still draws
  EXPECT_NO_THROW(write_heatmap(m, dir_ / "empty"));
}

TEST_F(FigureTest, HeatMapRejectsBadInput) {
  auto throws = [&](const HeatMap& m) {
    EXPECT_THROW(write_heatmap(m, dir_ / "bad"), std::invalid_argument);
  };
  HeatMap m = grid_map(2, 3, 0.5);
  m.x_ticks.pop_back();
  throws(m);
  m = grid_map(2, 3, 0.5);
  m.y_ticks.push_back("extra");
  throws(m);
  m = grid_map(2, 3, 0.5);
  m.values.resize(0, 0);
  m.x_ticks.clear();
  m.y_ticks.clear();
  throws(m);
  m = grid_map(2, 3, 0.5);
  m.min_value = 1;
  throws(m);  // min == max
  m.min_value = 2;
  throws(m);  // min > max
  m.min_value = std::numeric_limits<double>::quiet_NaN();
  throws(m);
  m.min_value = 0;
  m.max_value = std::numeric_limits<double>::infinity();
  throws(m);
  m = grid_map(2, 3, 0.5);
  m.value_format = "percentage";
  throws(m);
  m = grid_map(2, 3, 0.5);
  m.width = 10;
  throws(m);

  EXPECT_THROW(write_heatmaps({}, "none", dir_ / "bad"), std::invalid_argument);
  std::vector<HeatMap> panels(2, grid_map(2, 3, 0.5));
  panels[1].max_value = 2;  // one colour bar cannot show two ranges
  EXPECT_THROW(write_heatmaps(panels, "", dir_ / "bad"), std::invalid_argument);
  panels = std::vector<HeatMap>(3, grid_map(2, 3, 0.5));
  for (auto& p : panels) p.width = 6000;
  EXPECT_THROW(write_heatmaps(panels, "", dir_ / "bad"), std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(FigureTest, HeatMapsDrawPanelsSideBySide) {
  // Three 2 x 2 panels, each with min_value in its lower-left cell; only the third has max_value,
  // in its upper-right cell.
  std::vector<HeatMap> panels;
  const char* names[3] = {"point-to-point ICP", "point-to-plane ICP", "global + ICP"};
  const int widths[3] = {300, 300, 400}, heights[3] = {300, 360, 300};
  for (int i = 0; i < 3; ++i) {
    HeatMap m = grid_map(2, 2, 0.5);
    m.title = names[i];
    m.annotate = i != 1;
    m.values(0, 0) = 0;
    m.width = widths[i];
    m.height = heights[i];
    panels.push_back(m);
  }
  panels[2].values(1, 1) = 1;
  write_heatmaps(panels, "Convergence basin", dir_ / "basin");
  const Image png(dir_ / "basin.png");
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png.width(), 1000);  // the panels' widths add up
  EXPECT_EQ(png.height(), 360);  // the tallest panel

  // With annotations the low cells have white text in them: count the purple around it.
  const auto low = blobs(png, kLowEnd, 200);
  const auto high = blobs(png, kHighEnd, 200);
  ASSERT_EQ(low.size(), 3u);
  ASSERT_EQ(high.size(), 1u);
  // One low cell per panel, left to right, on one row; the third panel's grid is the widest.
  EXPECT_LT(low[0].x1, png.width() / 3);
  EXPECT_GT(low[2].x0, png.width() / 2);
  EXPECT_NEAR(low[0].cy(), low[1].cy(), 2);
  EXPECT_NEAR(low[1].cy(), low[2].cy(), 2);
  EXPECT_GT(low[2].x1 - low[2].x0, low[0].x1 - low[0].x0 + 10);
  // The high cell is the third panel's upper right: right of and above its low cell, in the grid
  // left of the colour bar, and its pixel centre has the end colour.
  EXPECT_GT(high[0].x0, low[2].x1);
  EXPECT_LT(high[0].y1, low[2].y0);
  EXPECT_LT(high[0].x1, png.width() - 50);
  EXPECT_TRUE(near(png.at(high[0].cx(), high[0].y0 + 3), kHighEnd));
}

TEST_F(FigureTest, HeatMapsInRowsOfColumnsLineUp) {
  // Six 2 x 2 panels of 300 x 300 in rows of three, each with min_value in its lower-left cell;
  // the last (lower right) also has max_value in its upper-right cell.
  std::vector<HeatMap> panels;
  for (int i = 0; i < 6; ++i) {
    HeatMap m = grid_map(2, 2, 0.5);
    m.title = "panel " + std::to_string(i);
    m.values(0, 0) = 0;
    m.width = m.height = 300;
    panels.push_back(m);
  }
  panels[5].values(1, 1) = 1;
  write_heatmaps(panels, "Convergence basin", dir_ / "rows", 3);
  const Image png(dir_ / "rows.png");
  ASSERT_TRUE(png.ok());
  EXPECT_EQ(png.width(), 900);   // a row's panels' widths
  EXPECT_EQ(png.height(), 600);  // the rows' heights
  auto low = blobs(png, kLowEnd, 200);
  const auto high = blobs(png, kHighEnd, 200);
  ASSERT_EQ(low.size(), 6u);
  ASSERT_EQ(high.size(), 1u);
  // Three low cells in the upper half and three in the lower, each row's on one line, and the
  // columns of the two rows over each other.
  std::stable_sort(low.begin(), low.end(),
                   [](const Blob& a, const Blob& b) { return a.cy() < b.cy(); });
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(low[k].y1, png.height() / 2) << k;
    EXPECT_GT(low[3 + k].y0, png.height() / 2) << k;
    EXPECT_NEAR(low[k].cy(), low[0].cy(), 2) << k;
    EXPECT_NEAR(low[3 + k].cy(), low[3].cy(), 2) << k;
  }
  std::sort(low.begin(), low.begin() + 3,
            [](const Blob& a, const Blob& b) { return a.cx() < b.cx(); });
  std::sort(low.begin() + 3, low.end(),
            [](const Blob& a, const Blob& b) { return a.cx() < b.cx(); });
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(low[k].x0, low[3 + k].x0, 2) << k;
    EXPECT_NEAR(low[k].x1, low[3 + k].x1, 2) << k;
  }
  // The high cell: the last panel's upper right, right of and above its low cell.
  EXPECT_GT(high[0].x0, low[5].x1);
  EXPECT_LT(high[0].y1, low[5].y0);
  EXPECT_GT(high[0].y0, png.height() / 2);

  // More columns than panels: one row, as with 0.
  write_heatmaps(std::vector<HeatMap>(panels.begin(), panels.begin() + 2), "", dir_ / "one", 5);
  const Image one(dir_ / "one.png");
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one.width(), 600);
  EXPECT_EQ(one.height(), 300);
}

}  // namespace
}  // namespace align3d::report
