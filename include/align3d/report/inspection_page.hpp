// The inspection's report (`align3d inspect … --html PAGE`): one offline HTML page with the
// verdict, the colour-mapped views of the part (render.hpp), the deviation histogram
// (histogram.hpp), the statistics, the registration, the CAD mesh check and every warning; and the
// same figures as files for those who want them alone (the README shows views.png).
//
// The page opens in a browser without a network: every figure is embedded as base64 PNG
// (html.hpp), and it has no script and no link. It is written atomically: the figures are drawn in
// a temporary folder that is removed afterwards, and the page replaces the destination only once
// complete. Same inputs, same bytes (no time, host or path of the temporary folder is printed).
#pragma once

#include <filesystem>
#include <string>

#include "align3d/inspect.hpp"
#include "align3d/mesh.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d::report {

struct InspectionPageInfo {
  std::string scan_name;  // the scan's and the CAD model's files, as the user named them
  std::string cad_name;
  std::string units = "mm";  // of the data (may be empty)
  std::string title = "Inspection report";
};

// Writes views.png (the four views with the colour bar, write_views_figure) and histogram.png and
// histogram.svg (write_deviation_histogram) into the existing folder `dir`, each atomically.
// `scan` is the inspected scan in its own frame (the registration moves it onto the CAD model),
// `cad` the cleaned mesh the deviations were measured against (MeshIndex::mesh()). Throws
// std::invalid_argument when nothing was measured (the registration failed) or the deviation map
// does not match the scan, OutputError naming the file that cannot be written.
void write_inspection_figures(const std::filesystem::path& dir, const InspectResult& result,
                              const PointCloud& scan, const TriangleMesh& cad,
                              const InspectionPageInfo& info);

// Writes the page to `page`. A failed registration gives a page with the verdict, the registration
// and the warnings but no figure. Throws OutputError naming `page` when its folder does not exist
// or it cannot be written (nothing is then left there), std::invalid_argument as above for a
// deviation map that does not match the scan.
void write_inspection_page(const std::filesystem::path& page, const InspectResult& result,
                           const PointCloud& scan, const TriangleMesh& cad,
                           const InspectionPageInfo& info);

}  // namespace align3d::report
