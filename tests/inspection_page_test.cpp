// The inspection's page and histogram (report/inspection_page.hpp, report/histogram.hpp), from an
// InspectResult filled by hand with known numbers: no registration runs here.
#include "align3d/report/inspection_page.hpp"

#include <cairo.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/report/colormap.hpp"
#include "align3d/report/histogram.hpp"
#include "mesh_test_util.hpp"
#include "test_util.hpp"

namespace align3d::report {
namespace {

namespace fs = std::filesystem;

using test::kNan;

// A 10 mm cube and 400 scan points on its top face (20 × 20), 10 of them 0.15 above the band,
// 10 of them 0.2 below, the rest 0.01; plus 5 outliers far off. The scan is in its own frame:
// CAD = T · scan.
struct Inspection {
  TriangleMesh cad = test::box_mesh({0, 0, 0}, {10, 10, 10});
  PointCloud scan;
  InspectResult r;
};

Eigen::Isometry3d scan_to_cad() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));
  T.pretranslate(Eigen::Vector3d(1, 2, 3));
  return T;
}

void fill_map(Inspection& in) {
  const Eigen::Isometry3d T = scan_to_cad();
  for (int i = 0; i < 20; ++i) {
    for (int j = 0; j < 20; ++j) {
      const int k = 20 * i + j;
      const double d = k < 10 ? 0.15 : k < 20 ? -0.2 : 0.01;
      in.scan.positions.push_back(T.inverse() *
                                  Eigen::Vector3d(0.25 + 0.5 * i, 0.25 + 0.5 * j, 10 + d));
      in.r.map.deviation.push_back(d);
    }
  }
  for (int k = 0; k < 5; ++k) {
    in.scan.positions.push_back(T.inverse() * Eigen::Vector3d(-5, k, 0));
    in.r.map.deviation.push_back(kNan);
  }
  in.r.map.outliers = 5;
  in.r.map.max_distance = 0.5;
}

Inspection make_inspection() {
  Inspection in;
  fill_map(in);
  InspectResult& r = in.r;
  r.registration.success = true;
  r.registration.transformation = scan_to_cad();
  r.registration.path = "initial";
  r.registration.refine.total_iterations = 7;
  r.registration.refine.icp.rms = 0.0123;
  r.registration.refine.icp.converged = true;
  r.registration.refine.icp.stop_reason = StopReason::kRmsChange;
  r.registration.support.overlap = 0.873;
  r.stats = {400, 0.01234, 0.0456, 0.0472, -0.2, 0.15, -0.19, -0.05, 0.01, 0.09, 0.149};
  r.gauss = {0.011, 0.0123};
  r.histogram.lo = -0.3;
  r.histogram.hi = 0.3;
  r.histogram.counts.assign(60, 0);
  r.histogram.counts[31] = 380;  // [0.01, 0.02)
  r.histogram.counts[45] = 10;   // 0.15
  r.histogram.counts[10] = 10;   // −0.2
  r.tolerance = {-0.1, 0.1};
  r.within = 380;
  r.below = 10;
  r.above = 10;
  r.within_tolerance = 0.95;
  r.pass = false;
  r.mesh = analyse_topology(in.cad);
  r.repair.flipped_triangles = 2;
  r.warnings = {{"weak_overlap", "the overlap is 12 % < 20 % & the pose may be wrong"}};
  return in;
}

InspectionPageInfo info() { return {"scan <1>.ply", "part.stl", "mm", "Inspection of part.stl"}; }

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// TMPDIR pointed at a folder of the test's own while it lives, so the page writer's scratch
// folders are counted there: in the shared temporary folder, another test writing a page at the
// same time (ctest -j) changed the count.
class ScopedTmpdir {
 public:
  explicit ScopedTmpdir(const fs::path& dir) {
    if (const char* old = std::getenv("TMPDIR")) old_ = old;
    setenv("TMPDIR", dir.c_str(), 1);
  }
  ~ScopedTmpdir() {
    if (old_.empty())
      unsetenv("TMPDIR");
    else
      setenv("TMPDIR", old_.c_str(), 1);
  }
  ScopedTmpdir(const ScopedTmpdir&) = delete;
  ScopedTmpdir& operator=(const ScopedTmpdir&) = delete;

 private:
  std::string old_;
};

// Scratch folders of the page writer left in the temporary folder.
std::size_t scratch_folders() {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(fs::temp_directory_path())) {
    n += e.path().filename().string().rfind("align3d-inspection-", 0) == 0;
  }
  return n;
}

std::string base64_decode(const std::string& text) {
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  unsigned buffer = 0;
  int bits = 0;
  for (char c : text) {
    if (c == '=') break;
    buffer = buffer << 6 | static_cast<unsigned>(alphabet.find(c));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((buffer >> bits) & 0xff);
    }
  }
  return out;
}

// The embedded PNGs of a page, decoded.
std::vector<std::string> embedded_pngs(const std::string& page) {
  const std::string prefix = "data:image/png;base64,";
  std::vector<std::string> pngs;
  for (auto at = page.find(prefix); at != std::string::npos; at = page.find(prefix, at + 1)) {
    const auto start = at + prefix.size();
    pngs.push_back(base64_decode(page.substr(start, page.find('"', start) - start)));
  }
  return pngs;
}

struct PngSize {
  int width = 0, height = 0;
};
PngSize png_size(const fs::path& file) {
  cairo_surface_t* s = cairo_image_surface_create_from_png(file.c_str());
  PngSize size;
  if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
    size = {cairo_image_surface_get_width(s), cairo_image_surface_get_height(s)};
  }
  cairo_surface_destroy(s);
  return size;
}

TEST(InspectionPage, WritesAnOfflinePageWithTheVerdictNumbersAndWarnings) {
  const Inspection in = make_inspection();
  test::TempDir dir("inspection_page_test"), scratch("inspection_page_scratch");
  const ScopedTmpdir tmp(scratch.path());
  const std::size_t scratch_before = scratch_folders();
  write_inspection_page(dir / "page.html", in.r, in.scan, in.cad, info());
  EXPECT_EQ(entries(dir.path()), std::vector<std::string>{"page.html"});
  EXPECT_EQ(scratch_folders(), scratch_before);
  const std::string page = read(dir / "page.html");
  EXPECT_NE(page.find(">FAIL<"), std::string::npos);
  EXPECT_NE(page.find("95.00\u2009% of 400 measured points"), std::string::npos);
  EXPECT_NE(page.find("\u22120.1 \u2026 +0.1 mm"), std::string::npos);  // the band
  EXPECT_NE(page.find("scan &lt;1&gt;.ply"), std::string::npos);        // names escaped
  for (const char* number :
       {"+0.0123 mm", "0.0456 mm", "0.0472 mm", "\u22120.2000 mm", "+0.1500 mm", "\u22120.1900 mm",
        "\u22120.0500 mm", "+0.0100 mm", "+0.0900 mm", "+0.1490 mm", "+0.0110 mm", "0.0123 mm",
        "0.5000 mm", "87.30\u2009%", "rms_change (converged)", "0.995004", ">-0.099833<"}) {
    EXPECT_NE(page.find(number), std::string::npos) << number;
  }
  EXPECT_NE(page.find("<li class=warn><b>weak_overlap</b>: the overlap is 12 % &lt; 20 % &amp; "
                      "the pose may be wrong</li>"),
            std::string::npos);
  // Offline: two embedded PNGs, every source a data URI, no link, no script.
  EXPECT_EQ(count(page, "src=\"data:image/png;base64,"), 2u);
  EXPECT_EQ(count(page, "src="), 2u);
  EXPECT_EQ(count(page, "http:") + count(page, "https:") + count(page, "<script"), 0u);
}

TEST(InspectionPage, EmbeddedFiguresDecodeToTheirSizes) {
  const Inspection in = make_inspection();
  test::TempDir dir("inspection_page_test");
  write_inspection_page(dir / "page.html", in.r, in.scan, in.cad, info());
  const auto pngs = embedded_pngs(read(dir / "page.html"));
  ASSERT_EQ(pngs.size(), 2u);
  std::ofstream(dir / "views.png", std::ios::binary) << pngs[0];
  std::ofstream(dir / "histogram.png", std::ios::binary) << pngs[1];
  const PngSize views = png_size(dir / "views.png"), histogram = png_size(dir / "histogram.png");
  EXPECT_GT(views.width, 2 * 640);  // two 640 × 480 panels a row, plus the colour bar
  EXPECT_GT(views.height, 2 * 480);
  EXPECT_EQ(histogram.width, HistogramFigureSettings{}.width);
  EXPECT_EQ(histogram.height, HistogramFigureSettings{}.height);
}

TEST(InspectionPage, PassingPartShowsPass) {
  Inspection in = make_inspection();
  in.r.pass = true;
  in.r.warnings.clear();
  test::TempDir dir("inspection_page_test");
  write_inspection_page(dir / "page.html", in.r, in.scan, in.cad, info());
  const std::string page = read(dir / "page.html");
  EXPECT_NE(page.find(">PASS<"), std::string::npos);
  EXPECT_EQ(page.find(">FAIL<"), std::string::npos);
  EXPECT_NE(page.find("No warnings."), std::string::npos);
}

TEST(InspectionPage, SameInputSameBytes) {
  const Inspection in = make_inspection();
  test::TempDir dir("inspection_page_test");
  write_inspection_page(dir / "a.html", in.r, in.scan, in.cad, info());
  write_inspection_page(dir / "b.html", in.r, in.scan, in.cad, info());
  EXPECT_EQ(read(dir / "a.html"), read(dir / "b.html"));
}

TEST(InspectionPage, MissingFolderThrowsOutputErrorAndLeavesNothing) {
  const Inspection in = make_inspection();
  test::TempDir dir("inspection_page_test"), scratch("inspection_page_scratch");
  const ScopedTmpdir tmp(scratch.path());
  const std::size_t scratch_before = scratch_folders();
  const fs::path page = dir / "missing" / "page.html";
  try {
    write_inspection_page(page, in.r, in.scan, in.cad, info());
    FAIL() << "no OutputError";
  } catch (const OutputError& e) {
    EXPECT_EQ(e.path(), page);
  }
  EXPECT_TRUE(entries(dir.path()).empty());
  EXPECT_EQ(scratch_folders(), scratch_before);
}

TEST(InspectionPage, FailedRegistrationGivesAPageWithoutFigures) {
  Inspection in = make_inspection();
  in.r.registration.success = false;
  in.r.registration.failure = "too few correspondences";
  in.r.map = {};
  in.r.pass = false;
  test::TempDir dir("inspection_page_test");
  write_inspection_page(dir / "page.html", in.r, in.scan, in.cad, info());
  const std::string page = read(dir / "page.html");
  EXPECT_NE(page.find(">FAIL<"), std::string::npos);
  EXPECT_NE(page.find("too few correspondences"), std::string::npos);
  EXPECT_EQ(page.find("data:image"), std::string::npos);
  EXPECT_THROW(write_inspection_figures(dir.path(), in.r, in.scan, in.cad, info()),
               std::invalid_argument);
}

TEST(InspectionPage, FiguresAloneGoIntoTheFolder) {
  const Inspection in = make_inspection();
  test::TempDir dir("inspection_page_test");
  write_inspection_figures(dir.path(), in.r, in.scan, in.cad, info());
  EXPECT_EQ(entries(dir.path()),
            (std::vector<std::string>{"histogram.png", "histogram.svg", "views.png"}));
}

TEST(InspectionPage, MapThatDoesNotMatchTheScanThrows) {
  Inspection in = make_inspection();
  in.r.map.deviation.pop_back();
  test::TempDir dir("inspection_page_test");
  EXPECT_THROW(write_inspection_page(dir / "page.html", in.r, in.scan, in.cad, info()),
               std::invalid_argument);
  EXPECT_TRUE(entries(dir.path()).empty());
}

// The histogram's bars in their deviation colours: the count of pixels within one level per
// channel of `c` (cairo rounds colours to 8 bits its own way).
long pixels_near(const fs::path& png, const Rgb& c) {
  cairo_surface_t* s = cairo_image_surface_create_from_png(png.c_str());
  const int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
  const int stride = cairo_image_surface_get_stride(s) / 4;
  const auto* data = reinterpret_cast<const std::uint32_t*>(cairo_image_surface_get_data(s));
  long n = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::uint32_t v = data[y * stride + x];
      bool near = true;
      for (int k = 0; k < 3; ++k) {
        const int channel = static_cast<int>((v >> (16 - 8 * k)) & 0xff);
        near = near && std::abs(channel - static_cast<int>(std::lround(255 * c[k]))) <= 1;
      }
      n += near;
    }
  }
  cairo_surface_destroy(s);
  return n;
}

TEST(InspectionPageHistogram, BarsTakeTheColourOfTheirCentre) {
  const Inspection in = make_inspection();
  test::TempDir dir("inspection_page_test");
  for (bool log_counts : {true, false}) {
    HistogramFigureSettings settings;
    settings.log_counts = log_counts;
    write_deviation_histogram(in.r.histogram, in.r.gauss, in.r.tolerance, in.r.map.outliers,
                              dir / "histogram", settings);
    EXPECT_EQ(png_size(dir / "histogram.png").width, settings.width);
    EXPECT_EQ(png_size(dir / "histogram.png").height, settings.height);
    // The tall bin [0.01, 0.02) and the two out-of-band bins, each filled with its colour.
    EXPECT_GT(pixels_near(dir / "histogram.png", deviation_color(0.015, in.r.tolerance)), 100);
    EXPECT_GT(pixels_near(dir / "histogram.png", kAboveColor), 4);
    EXPECT_GT(pixels_near(dir / "histogram.png", kBelowColor), 4);
  }
}

TEST(InspectionPageHistogram, EmptyHistogramStillDrawsAndBadOnesThrow) {
  test::TempDir dir("inspection_page_test");
  Histogram h;
  h.lo = -1;
  h.hi = 1;
  h.counts.assign(10, 0);
  EXPECT_NO_THROW(write_deviation_histogram(h, {}, {-0.5, 0.5}, 3, dir / "empty"));
  h.counts.clear();
  EXPECT_THROW(write_deviation_histogram(h, {}, {-0.5, 0.5}, 0, dir / "bad"),
               std::invalid_argument);
  h.counts.assign(10, 1);
  EXPECT_THROW(write_deviation_histogram(h, {}, {0.1, 0.5}, 0, dir / "bad"),
               std::invalid_argument);  // a band without 0
  EXPECT_EQ(entries(dir.path()), (std::vector<std::string>{"empty.png", "empty.svg"}));
}

}  // namespace
}  // namespace align3d::report
