// Scientific figures drawn with cairo, written as SVG and PNG: 2-D plots (plot.hpp) and heat maps
// (heatmap.hpp).
#pragma once

#include "align3d/report/heatmap.hpp"
#include "align3d/report/plot.hpp"
