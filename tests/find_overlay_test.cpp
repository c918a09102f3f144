// The find command's image and overlay (report/find_overlay.hpp) on a hand-made depth image: a
// plane with two found parts and one missed part of known pixels, and a few pixels without a
// return. The PNG is read back with cairo, the PLY with the cloud reader and byte by byte.
#include "align3d/report/find_overlay.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "png_image.hpp"
#include "test_util.hpp"

namespace align3d::report {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 64, kHeight = 48;

struct Rect {
  int x0, y0, x1, y1;  // [x0, x1) × [y0, y1)
  bool contains(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};
// Two found parts at depths 950 and 970 on a plane at 1000, and a part at 950 that was not found,
// so that the grey of depth 950 can be read where no mask is.
constexpr Rect kFirst{6, 6, 30, 26}, kSecond{38, 10, 60, 30}, kMissed{30, 2, 36, 8};
constexpr Rect kNoReturn{58, 0, 64, 4};

// The scene as a depth camera would give it: one point per pixel with a return, in pixel order,
// and the result naming the two parts' points.
struct Fixture {
  PointCloud scene;
  FindResult result;
};

Fixture make_fixture() {
  Fixture f;
  RangeImage& image = f.result.image;
  image.width = kWidth, image.height = kHeight;
  image.fx = image.fy = 500, image.cx = 32, image.cy = 24;
  image.organized = true;
  image.depth.assign(kWidth * kHeight, std::numeric_limits<float>::quiet_NaN());
  image.point.assign(kWidth * kHeight, -1);
  f.result.instances.resize(2);
  f.result.instances[0].score = 0.91;
  f.result.instances[1].score = 0.74;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (kNoReturn.contains(x, y)) continue;
      const float z = kFirst.contains(x, y) || kMissed.contains(x, y) ? 950
                      : kSecond.contains(x, y)                        ? 970
                                                                      : 1000;
      const auto index = static_cast<std::uint32_t>(f.scene.size());
      image.depth[image.pixel(x, y)] = z;
      image.point[image.pixel(x, y)] = static_cast<std::int32_t>(index);
      f.scene.positions.emplace_back((x - image.cx) * z / image.fx, (y - image.cy) * z / image.fy,
                                     z);
      if (kFirst.contains(x, y)) f.result.instances[0].points.push_back(index);
      if (kSecond.contains(x, y)) f.result.instances[1].points.push_back(index);
    }
  }
  return f;
}

// A pixel of a PNG read back (png_image.hpp), as a vector to measure colour distances.
class ColourImage {
 public:
  explicit ColourImage(const fs::path& path) : png_(path) {}
  bool ok() const { return png_.ok(); }
  int width() const { return png_.width(); }
  int height() const { return png_.height(); }
  Eigen::Vector3d at(int x, int y) const {
    const test::PngImage::Rgb8 c = png_.at(x, y);
    return {double(c.r), double(c.g), double(c.b)};
  }

 private:
  test::PngImage png_;
};

Eigen::Vector3d palette(int rank) {
  const auto c = instance_color(rank);
  return {double(c[0]), double(c[1]), double(c[2])};
}

bool is_grey(const Eigen::Vector3d& c) { return c.x() == c.y() && c.y() == c.z(); }

class FindOverlay : public ::testing::Test {
 protected:
  test::TempDir temp_{"find_overlay_test"};
  const fs::path dir_ = temp_.path();
};

TEST_F(FindOverlay, PaletteCyclesThroughDistinctColours) {
  std::set<std::array<std::uint8_t, 3>> colours;
  for (int rank = 1; rank <= kInstancePaletteSize; ++rank) {
    const auto c = instance_color(rank);
    EXPECT_FALSE(c[0] == c[1] && c[1] == c[2]) << "rank " << rank << " is grey";
    colours.insert(c);
    EXPECT_EQ(instance_color(rank + kInstancePaletteSize), c);
  }
  EXPECT_EQ(colours.size(), std::size_t{kInstancePaletteSize});
  EXPECT_THROW(instance_color(0), std::invalid_argument);
}

TEST_F(FindOverlay, ImageTintsEachMaskInItsRanksColour) {
  const Fixture f = make_fixture();
  const fs::path png = dir_ / "find.png";
  write_find_image(png, f.result);
  const ColourImage image(png);
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(image.width(), kWidth);
  EXPECT_EQ(image.height(), kHeight);
  // The missed part shows the grey of depth 950; the first part, at that depth, is nearer its
  // colour than that grey. Pixels (9, 9) and (41, 13) lie inside the masks, off the outlines and
  // away from the labels at the masks' centres.
  const Eigen::Vector3d grey_950 = image.at(33, 5);
  ASSERT_TRUE(is_grey(grey_950));
  const Eigen::Vector3d first = image.at(9, 9);
  EXPECT_LT((first - palette(1)).norm(), (first - grey_950).norm());
  const Eigen::Vector3d second = image.at(41, 13);
  EXPECT_FALSE(is_grey(second));
  EXPECT_LT((second - palette(2)).norm(), (second - palette(1)).norm());
  // The plane around them stays grey, darker than the nearer part; no return is not grey.
  const Eigen::Vector3d plane = image.at(34, 16);
  EXPECT_TRUE(is_grey(plane));
  EXPECT_LT(plane.x(), grey_950.x());
  EXPECT_FALSE(is_grey(image.at(61, 1)));
}

TEST_F(FindOverlay, ImageOfAnEmptyResultIsTheDepthAlone) {
  Fixture f = make_fixture();
  f.result.instances.clear();
  const fs::path png = dir_ / "none.png";
  write_find_image(png, f.result);
  const ColourImage image(png);
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(image.width(), kWidth);
  EXPECT_EQ(image.height(), kHeight);
  EXPECT_TRUE(is_grey(image.at(9, 9)));
  EXPECT_TRUE(is_grey(image.at(41, 13)));
}

TEST_F(FindOverlay, ImageRejectsAResultWithoutDepthImage) {
  EXPECT_THROW(write_find_image(dir_ / "none.png", FindResult{}), std::invalid_argument);
  Fixture f = make_fixture();
  f.result.image.point.pop_back();
  EXPECT_THROW(write_find_image(dir_ / "short.png", f.result), std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(FindOverlay, ImageInAMissingFolderIsAnOutputErrorAndLeavesNothing) {
  const Fixture f = make_fixture();
  EXPECT_THROW(write_find_image(dir_ / "missing" / "find.png", f.result), OutputError);
  EXPECT_TRUE(fs::is_empty(dir_));
}

// Five model points, and two poses: a turn about z and a shift, a shift alone.
PpfModel small_model() {
  PpfModel model;
  model.points.positions = {{0, 0, 0}, {10, 0, 0}, {0, 20, 0}, {0, 0, 30}, {5, -5, 5}};
  return model;
}

TEST_F(FindOverlay, OverlayHoldsTheSceneThenEachModelAtItsPose) {
  Fixture f = make_fixture();
  const PpfModel model = small_model();
  f.result.instances[0].T_scene_model =
      Eigen::Translation3d(-40, -30, 950) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  f.result.instances[1].T_scene_model = Eigen::Translation3d(30, -10, 970);
  const fs::path ply = dir_ / "overlay.ply";
  write_find_overlay(ply, f.scene, model, f.result);

  const PointCloud read = io::read_point_cloud(ply);
  const std::size_t n = f.scene.size(), m = model.points.size();
  ASSERT_EQ(read.size(), n + 2 * m);
  for (std::size_t i = 0; i < m; ++i) {
    const Eigen::Vector3d expected =
        f.result.instances[0].T_scene_model * model.points.positions[i];
    EXPECT_LT((read.positions[n + i] - expected).norm(), 1e-3) << "model point " << i;
  }
  EXPECT_LT((read.positions[7] - f.scene.positions[7]).norm(), 1e-3);

  // Binary records after the header: float x y z, int instance, uchar red green blue.
  const std::string bytes = test::read_text(ply);
  const std::string end = "end_header\n";
  ASSERT_NE(bytes.find("property int instance\nproperty uchar red"), std::string::npos);
  const std::size_t body = bytes.find(end) + end.size();
  ASSERT_EQ(bytes.size(), body + 19 * (n + 2 * m));
  auto instance = [&](std::size_t i) {
    std::int32_t v;
    std::memcpy(&v, bytes.data() + body + 19 * i + 12, 4);
    return v;
  };
  auto colour = [&](std::size_t i) {
    const auto* c = reinterpret_cast<const std::uint8_t*>(bytes.data() + body + 19 * i + 16);
    return std::array<std::uint8_t, 3>{c[0], c[1], c[2]};
  };
  EXPECT_EQ(instance(0), 0);
  EXPECT_EQ(instance(n), 1);
  EXPECT_EQ(instance(n + m), 2);
  EXPECT_EQ(colour(n), instance_color(1));
  EXPECT_EQ(colour(n + m + m - 1), instance_color(2));
  const auto unexplained = colour(0), explained = colour(f.result.instances[0].points[0]);
  EXPECT_TRUE(unexplained[0] == unexplained[1] && unexplained[1] == unexplained[2]);
  EXPECT_GT(explained[0], explained[1]);  // grey tinted towards the first colour, a red
}

TEST_F(FindOverlay, OverlayRejectsBadInputAndLeavesNothing) {
  Fixture f = make_fixture();
  const PpfModel model = small_model();
  EXPECT_THROW(write_find_overlay(dir_ / "missing" / "overlay.ply", f.scene, model, f.result),
               OutputError);
  f.result.instances[1].points.push_back(static_cast<std::uint32_t>(f.scene.size()));
  EXPECT_THROW(write_find_overlay(dir_ / "bad.ply", f.scene, model, f.result),
               std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir_));
}

}  // namespace
}  // namespace align3d::report
