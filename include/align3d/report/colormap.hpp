// The colours of deviation maps (inspection): a diverging map centred on 0 and scaled to the
// tolerance band, shared by the coloured PLY, the rendered views and the colour bar, so that a
// colour means the same deviation everywhere.
#pragma once

#include "align3d/inspect.hpp"
#include "align3d/report/plot.hpp"

namespace align3d::report {

// Within the band: Moreland's cool-warm map (2009; nine anchor colours, interpolated), blue at the
// lower limit through light grey at 0 to red at the upper limit, each side scaled to its own limit
// (an asymmetric band keeps grey at 0). Outside the band: saturated colours that the band never
// uses, dark blue below and dark red above, so that out-of-tolerance points stand out. NaN (an
// outlier): mid grey.
Rgb deviation_color(double deviation, const Tolerance& band);

inline constexpr Rgb kBelowColor{0.10, 0.05, 0.45};
inline constexpr Rgb kAboveColor{0.45, 0.00, 0.05};
inline constexpr Rgb kOutlierColor{0.50, 0.50, 0.50};

}  // namespace align3d::report
