// A PNG read back with cairo, with pixel access, for the tests of the figure writers. The figures
// are opaque, so cairo's premultiplied alpha does not matter.
#pragma once

#include <cairo.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>

namespace align3d::test {

class PngImage {
 public:
  explicit PngImage(const std::filesystem::path& path)
      : surface_(cairo_image_surface_create_from_png(path.c_str())) {}
  ~PngImage() { cairo_surface_destroy(surface_); }
  PngImage(const PngImage&) = delete;
  PngImage& operator=(const PngImage&) = delete;

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

}  // namespace align3d::test
