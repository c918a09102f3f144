// Axis ticks and their labels, shared by the figure kinds: 1-2-5 steps on a linear axis, powers of
// ten on a logarithmic one. Private to the report library.
#pragma once

#include <cairo.h>

#include <string>
#include <vector>

#include "canvas.hpp"

namespace align3d::report::detail {

struct Tick {
  double pos;  // plot coordinate (log10 of the value on a log axis)
  std::string label;
};

struct Ticks {
  std::vector<Tick> major;
  std::vector<double> minor;
};

// Replaces a leading '-' by the typographic minus U+2212.
std::string with_unicode_minus(std::string s);

// Major ticks on a 1-2-5 grid of the range, about one per `target_px` of `length_px`. Horizontal
// labels (measured in the current font) are spread until neighbours keep 12 pixels between them.
Ticks linear_ticks(cairo_t* cr, Range r, double length_px, double target_px, bool horizontal);

// Ticks of a log axis; `r` holds log10 of the values. Powers of ten (every k-th when crowded) with
// minor ticks at 2..9 when a decade has room; 1, 2 and 5 times powers of ten within two decades;
// linear 1-2-5 steps of the value within a factor of about 2.5.
Ticks log_ticks(cairo_t* cr, Range r, double length_px);

}  // namespace align3d::report::detail
