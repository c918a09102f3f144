// The deviation histogram of an inspection (inspect.hpp), drawn with plot.hpp: each bin a bar in
// the colour of its centre's deviation (colormap.hpp), the tolerance band shaded behind with its
// limits as dashed lines labelled above the plot, the robust Gauss fit as a curve (its mean and σ
// in the legend) and a note of what the histogram leaves out.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include "align3d/deviation.hpp"
#include "align3d/inspect.hpp"

namespace align3d::report {

struct HistogramFigureSettings {
  std::string units = "mm";  // of the deviations (may be empty)
  std::string title = "Deviation histogram";
  int width = 1100, height = 600;  // as Figure (plot.hpp)
  // A logarithmic count axis: the few points outside the band (a dent, a burr) stay visible next to
  // a noise peak of a hundred thousand. Linear when no bin holds a point.
  bool log_counts = true;
};

// Writes `stem`.svg and `stem`.png (write_figure, plot.hpp). The Gauss curve is the fit's density
// scaled to counts: N · bin width · φ((x − mean) / σ) / σ, N the histogram's total (its bins, below
// and above), so its area matches the bars'; left out when σ is 0, and on a log axis where it
// falls below half a point per bin. `outliers` (points set apart
// before the statistics) are named in the note with the points beyond the histogram's range.
// Throws std::invalid_argument for a histogram without bins or with lo >= hi, a band without 0
// (as InspectSettings), and as write_figure.
void write_deviation_histogram(const Histogram& histogram, const GaussFit& gauss,
                               const Tolerance& band, std::size_t outliers,
                               const std::filesystem::path& stem,
                               const HistogramFigureSettings& settings = {});

}  // namespace align3d::report
