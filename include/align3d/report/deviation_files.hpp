// The files an inspection writes besides its JSON report (align3d inspect --output, --csv,
// --histogram): the deviation map as a coloured PLY, every point's deviation and closest CAD point
// as CSV, and the histogram with its Gauss fit as CSV. Each is written atomically (OutputError on
// failure, nothing left behind).
#pragma once

#include <filesystem>

#include "align3d/inspect.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d::report {

// The scan moved into the CAD frame, in the scan's point order, as binary PLY: float x y z, float
// `deviation` (NaN for outliers) and uchar red green blue from deviation_color (colormap.hpp).
void write_deviation_ply(const std::filesystem::path& path, const PointCloud& scan,
                         const InspectResult& result);

// One row per scan point, in its order: index,x,y,z (CAD frame),deviation,closest_x,closest_y,
// closest_z (its closest point on the CAD surface),triangle (of the cleaned mesh), %.9g; an
// outlier's deviation, closest point and triangle are empty.
void write_deviation_csv(const std::filesystem::path& path, const PointCloud& scan,
                         const InspectResult& result);

// One row per histogram bin: bin_lo,bin_hi,count,gauss (the count the Gauss fit expects there).
void write_histogram_csv(const std::filesystem::path& path, const InspectResult& result);

// The files one inspection asks for (empty: not written), and what the HTML page names.
struct InspectionOutputs {
  std::string ply, csv, histogram, html;  // --output, --csv, --histogram, --html
  std::string figures;                    // --figures: a folder for views.png, histogram.png/svg
  std::string scan_path, cad_path;        // shown on the page
  std::string units;                      // a label for the page ("": none)
};

// Writes each file `outputs` names, in the order above (the CLI's and the Python package's
// inspect): for a failed registration only the page (it says why). The figures' folder is created
// when missing.
void write_inspection_outputs(const InspectionOutputs& outputs, const PointCloud& scan,
                              const InspectResult& result);

}  // namespace align3d::report
