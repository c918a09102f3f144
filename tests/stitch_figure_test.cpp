// The stitch's figure (report/stitch_figure.hpp) on hand-made merged clouds of known scans: the
// PNG is read back with cairo and each scan's colour is looked for where its points project.
#include "align3d/report/stitch_figure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/report/find_overlay.hpp"
#include "png_image.hpp"
#include "test_util.hpp"

namespace align3d::report {
namespace {

namespace fs = std::filesystem;
using Image = test::PngImage;

bool has_colour(Image::Rgb8 c, std::size_t scan) {
  const auto p = instance_color(static_cast<int>(scan) + 1);
  return c.r == p[0] && c.g == p[1] && c.b == p[2];
}

// `scans` scans, none merged yet; scan k connected unless listed in `unconnected`.
StitchResult empty_result(std::size_t scans, std::vector<std::size_t> unconnected = {}) {
  StitchResult r;
  r.scans.resize(scans);
  for (std::size_t k = 0; k < scans; ++k) r.scans[k].connected = true;
  for (std::size_t k : unconnected) r.scans[k].connected = false;
  return r;
}

void add_point(StitchResult& r, const Eigen::Vector3d& p, int scan) {
  r.merged.positions.push_back(p);
  r.merged.normals.emplace_back(0, 0, 1);
  r.merged_scan.push_back(scan);
}

// A flat 100 × 40 sheet at z = 0, 1 apart: scan 0 on the left half (x < 0), scan 1 on the right.
StitchResult two_halves() {
  StitchResult r = empty_result(2);
  for (int i = -50; i <= 50; ++i)
    for (int j = -20; j <= 20; ++j)
      if (i != 0) add_point(r, Eigen::Vector3d(i, j, 0), i < 0 ? 0 : 1);
  return r;
}

class StitchFigureTest : public ::testing::Test {
 protected:
  test::TempDir temp_{"stitch_figure_test"};
  const fs::path dir_ = temp_.path();
};

TEST_F(StitchFigureTest, WritesAPngOfTheRequestedSize) {
  StitchFigureSettings s;
  s.width = 900, s.height = 500;
  s.title = "Two halves";
  s.units = "mm";
  const StitchFigureInfo info = write_stitch_figure(two_halves(), dir_ / "f.png", s);
  const Image image(dir_ / "f.png");
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(image.width(), 900);
  EXPECT_EQ(image.height(), 500);
  EXPECT_EQ(info.drawn_points, 100u * 41u);
  EXPECT_EQ(info.panels[0].view, View::kTop);
  EXPECT_EQ(info.panels[1].view, View::kFront);
  // Both views side by side inside the figure, at one scale.
  EXPECT_LT(info.panels[0].x + info.panels[0].width, info.panels[1].x);
  EXPECT_LE(info.panels[1].x + info.panels[1].width, 900);
  EXPECT_EQ(info.panels[0].camera.scale, info.panels[1].camera.scale);
  // The PNG bytes are the same picture, and the same result draws the same bytes.
  EXPECT_EQ(stitch_figure_png(two_halves(), s), test::read_text(dir_ / "f.png"));
}

TEST_F(StitchFigureTest, EachScanIsDrawnInItsColourWhereItLies) {
  const StitchResult r = two_halves();
  const StitchFigureInfo info = write_stitch_figure(r, dir_ / "f.png");
  const Image image(dir_ / "f.png");
  ASSERT_TRUE(image.ok());
  for (const StitchFigurePanel& p : info.panels) {
    // Every merged point's pixel shows its scan's colour (the sheet is one layer: no point hides
    // another of the other scan, except at the seam).
    int right = 0, checked = 0;
    for (std::size_t i = 0; i < r.merged.size(); i += 7) {
      if (std::abs(r.merged.positions[i].x()) < 3) continue;  // the seam's splats overlap
      const Eigen::Vector2d q = p.camera.pixel(r.merged.positions[i]);
      ++checked;
      right += has_colour(image.at(static_cast<int>(q.x()), static_cast<int>(q.y())),
                          static_cast<std::size_t>(r.merged_scan[i]))
                   ? 1
                   : 0;
    }
    EXPECT_EQ(right, checked) << view_name(p.view);
    // Scan 0 fills the left half of the view's data, scan 1 the right; neither strays.
    const int mid = static_cast<int>(std::lround(p.camera.pixel(Eigen::Vector3d::Zero()).x()));
    const int y0 = p.y, y1 = p.y + p.height;
    const auto colour = [](std::size_t scan) {
      return [scan](Image::Rgb8 c) { return has_colour(c, scan); };
    };
    EXPECT_GT(image.count(p.x, y0, mid - 3, y1, colour(0)), 0) << view_name(p.view);
    EXPECT_EQ(image.count(p.x, y0, mid - 3, y1, colour(1)), 0) << view_name(p.view);
    EXPECT_GT(image.count(mid + 3, y0, p.x + p.width, y1, colour(1)), 0) << view_name(p.view);
    EXPECT_EQ(image.count(mid + 3, y0, p.x + p.width, y1, colour(0)), 0) << view_name(p.view);
  }
  // The top view is the sheet seen flat (wide), the front view it seen edge-on (a line).
  const auto area = [&](const StitchFigurePanel& p) {
    return image.count(p.x, p.y, p.x + p.width, p.y + p.height,
                       [](Image::Rgb8 c) { return has_colour(c, 0) || has_colour(c, 1); });
  };
  EXPECT_GT(area(info.panels[0]), 10 * area(info.panels[1]));
}

TEST_F(StitchFigureTest, NearerPointsCoverFartherOnesWhateverTheirOrder) {
  // Scan 1 lies 1 above scan 0 over the same square, and comes first in the merged cloud: seen
  // from above (+z) it covers scan 0 entirely.
  StitchResult r = empty_result(2);
  for (int scan : {1, 0})
    for (int i = -20; i <= 20; ++i)
      for (int j = -20; j <= 20; ++j) add_point(r, Eigen::Vector3d(i, j, scan == 1 ? 1 : 0), scan);
  const StitchFigureInfo info = write_stitch_figure(r, dir_ / "f.png");
  const Image image(dir_ / "f.png");
  const StitchFigurePanel& top = info.panels[0];
  const auto in_top = [&](std::size_t scan) {
    return image.count(top.x, top.y, top.x + top.width, top.y + top.height,
                       [scan](Image::Rgb8 c) { return has_colour(c, scan); });
  };
  EXPECT_GT(in_top(1), 100);
  EXPECT_EQ(in_top(0), 0);
}

TEST_F(StitchFigureTest, TheLegendShowsEveryScanUnderTheViews) {
  // Scan 2 is not connected (no merged point): the legend still shows its colour.
  StitchResult r = two_halves();
  r.scans.resize(3);
  StitchFigureSettings s;
  s.names = {"a.ply", "", "c.ply"};
  const StitchFigureInfo info = write_stitch_figure(r, dir_ / "f.png", s);
  const Image image(dir_ / "f.png");
  const int below = info.panels[0].y + info.panels[0].height + 1;
  for (std::size_t scan = 0; scan < 3; ++scan)
    EXPECT_GT(image.count(0, below, image.width(), image.height(),
                          [scan](Image::Rgb8 c) { return has_colour(c, scan); }),
              10)
        << scan;
}

TEST_F(StitchFigureTest, AMillionPointsAreThinnedEvenly) {
  StitchResult r = empty_result(3);
  for (int i = 0; i < 1000; ++i)
    for (int j = 0; j < 1000; ++j)
      add_point(r, Eigen::Vector3d(0.1 * i, 0.1 * j, std::sin(0.01 * i)), (i / 334) % 3);
  StitchFigureSettings s;
  s.max_points = 300000;
  const StitchFigureInfo info = write_stitch_figure(r, dir_ / "f.png", s);
  EXPECT_EQ(info.drawn_points, 250000u);  // every 4th of 10⁶
  const Image image(dir_ / "f.png");
  for (std::size_t scan = 0; scan < 3; ++scan)
    EXPECT_GT(image.count([scan](Image::Rgb8 c) { return has_colour(c, scan); }), 1000) << scan;
}

TEST_F(StitchFigureTest, OnePointOrNoneStillDraws) {
  StitchResult none = empty_result(2);
  EXPECT_EQ(write_stitch_figure(none, dir_ / "none.png").drawn_points, 0u);
  EXPECT_TRUE(Image(dir_ / "none.png").ok());
  StitchResult one = empty_result(2);
  add_point(one, Eigen::Vector3d(1, 2, 3), 1);
  const StitchFigureInfo info = write_stitch_figure(one, dir_ / "one.png");
  const Image image(dir_ / "one.png");
  const Eigen::Vector2d q = info.panels[0].camera.pixel(Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(has_colour(image.at(static_cast<int>(q.x()), static_cast<int>(q.y())), 1));
}

TEST_F(StitchFigureTest, RejectsBadInputAndNamesAFileItCannotWrite) {
  StitchResult r = two_halves();
  StitchFigureSettings s;
  s.names = {"only one"};
  EXPECT_THROW(write_stitch_figure(r, dir_ / "f.png", s), std::invalid_argument);
  s = {};
  s.width = 100;
  EXPECT_THROW(write_stitch_figure(r, dir_ / "f.png", s), std::invalid_argument);
  s = {};
  s.max_points = 0;
  EXPECT_THROW(write_stitch_figure(r, dir_ / "f.png", s), std::invalid_argument);
  StitchResult bad = r;
  bad.merged_scan.pop_back();
  EXPECT_THROW(write_stitch_figure(bad, dir_ / "f.png"), std::invalid_argument);
  bad = r;
  bad.merged_scan[0] = 2;
  EXPECT_THROW(write_stitch_figure(bad, dir_ / "f.png"), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_ / "f.png"));
  try {
    write_stitch_figure(r, dir_ / "missing" / "f.png");
    FAIL() << "no OutputError";
  } catch (const OutputError& e) {
    EXPECT_EQ(e.path(), dir_ / "missing" / "f.png");
  }
}

}  // namespace
}  // namespace align3d::report
