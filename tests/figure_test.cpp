#include "align3d/report/figure.hpp"

#include <cairo.h>
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "align3d/error.hpp"

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
  void SetUp() override {
    std::mt19937_64 rng(std::random_device{}());
    dir_ = fs::temp_directory_path() / ("align3d_figure_test_" + std::to_string(rng()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

// A decoded PNG with pixel access; the figures are opaque, so premultiplication does not matter.
class Image {
 public:
  explicit Image(const fs::path& path)
      : surface_(cairo_image_surface_create_from_png(path.c_str())) {}
  ~Image() { cairo_surface_destroy(surface_); }
  Image(const Image&) = delete;
  Image& operator=(const Image&) = delete;

  bool ok() const { return cairo_surface_status(surface_) == CAIRO_STATUS_SUCCESS; }
  int width() const { return cairo_image_surface_get_width(surface_); }
  int height() const { return cairo_image_surface_get_height(surface_); }

  struct Rgb8 {
    int r, g, b;
  };
  Rgb8 at(int x, int y) const {
    const unsigned char* row =
        cairo_image_surface_get_data(surface_) + y * cairo_image_surface_get_stride(surface_);
    std::uint32_t v;
    std::memcpy(&v, row + 4 * x, 4);
    return {int((v >> 16) & 0xff), int((v >> 8) & 0xff), int(v & 0xff)};
  }

  // Pixels in [x0, x1) x [y0, y1) satisfying pred.
  int count(int x0, int y0, int x1, int y1, const std::function<bool(Rgb8)>& pred) const {
    int n = 0;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) n += pred(at(x, y)) ? 1 : 0;
    }
    return n;
  }
  int count(const std::function<bool(Rgb8)>& pred) const {
    return count(0, 0, width(), height(), pred);
  }

 private:
  cairo_surface_t* surface_;
};

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

}  // namespace
}  // namespace align3d::report
