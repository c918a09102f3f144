// What a stitch writes besides its JSON report (`align3d stitch --output, --figure, --html`, and
// the Python package's align3d.stitch): the merged cloud as PLY, the figure (stitch_figure.hpp) and
// an offline HTML page. Each file is written atomically (OutputError naming it on failure, nothing
// left behind).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/stitch.hpp"

namespace align3d::report {

// Binary PLY of result.merged in the first scan's frame (io/ply_attributes.hpp): float x y z, float
// nx ny nz when the merged cloud has normals and, with `scan_index`, int `scan` (merged_scan: the
// input index of the scan most of the point's voxel came from). Throws std::invalid_argument when
// merged_scan does not hold one index per merged point.
void write_merged_ply(const std::filesystem::path& path, const StitchResult& result,
                      bool scan_index = true);

struct StitchPageInfo {
  std::vector<std::string> files;  // each scan's file as the user named it ("" in memory); empty:
                                   // none named
  std::string units;               // of the data, a label (may be empty)
  std::string title = "Stitch report";
};

// One self-contained HTML page (html.hpp: no network, the figure embedded as base64 PNG; same
// result, same bytes): a summary, every warning, the figure, a table of the poses (file,
// connected, kept edges, the pose's rotation angle and translation, the residual's pairs, RMS and
// 95th percentile), a table of the edges (scans, overlap, RMS, kept or why not, residuals against
// the optimised graph) and the timings. Throws as write_stitch_figure for a bad result or names,
// OutputError naming `page` when it cannot be written.
void write_stitch_page(const std::filesystem::path& page, const StitchResult& result,
                       const StitchPageInfo& info);

// The files one stitch asks for (empty: not written).
struct StitchOutputs {
  std::string merged, figure, html;  // --output, --figure, --html
  bool scan_index = true;            // the merged PLY's `scan` property (--no-scan-index: false)
  StitchPageInfo info;               // the files named in the legend and the page, the units
};

// Writes each file `outputs` names, in the order above. The figure's legend names each scan by its
// file's name (without the folder), or "scan k".
void write_stitch_outputs(const StitchOutputs& outputs, const StitchResult& result);

// stitch() names a scan that cannot be used "scan K" (its input index); the front ends name its
// file instead: `e` with files[K] as its subject, or `e` itself when it names no scan or K has no
// file
// ("" for data in memory).
DataError naming_scan_file(const DataError& e, const std::vector<std::string>& files);

}  // namespace align3d::report
