// The JSON reports, written in one place: every command's report and the chapter's results.json
// are built here, so the same result has the same keys everywhere (the Python binding's to_dict()
// too). docs/report.md documents every key: type, unit, meaning. Matrices are 4 arrays of 4
// numbers, row-major; a non-finite number is written as null.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "align3d/align.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/find.hpp"
#include "align3d/inspect.hpp"
#include "align3d/plane/rectify.hpp"
#include "align3d/stitch.hpp"
#include "align3d/warning.hpp"

namespace align3d::report {

nlohmann::json to_json(const Eigen::Isometry3d& T);  // 4 arrays of 4 numbers, row-major
nlohmann::json to_json(const Eigen::Vector3d& v);    // 3 numbers
nlohmann::json matrix6_json(const Matrix6d& m);      // 6 arrays of 6 numbers, row-major
nlohmann::json to_json(const std::vector<Warning>& warnings);
nlohmann::json to_json(const GlobalResult& g);
nlohmann::json to_json(const Support& s);
nlohmann::json to_json(const FitEvidence& f);

// What the report says of the inputs (the library sees clouds, the caller knows their files).
struct InputInfo {
  std::string path;  // may be empty
  std::size_t points = 0;
  std::size_t triangles = 0;  // a mesh: its triangles (points: its vertices); 0 for a cloud
};

// The report of one registration (`align3d register`; docs/report.md, "register"). With `truth`
// (target ≈ truth·source) it adds the pose errors.
nlohmann::json registration_report(const AlignResult& result, const AlignSettings& settings,
                                   const InputInfo& source, const InputInfo& target,
                                   const std::optional<Eigen::Isometry3d>& truth = std::nullopt);

// The report of one inspection (`align3d inspect`; docs/report.md, "inspect"): the registration's
// report (scan as source, CAD as target) with the deviation statistics, the tolerance, the verdict
// and every warning.
nlohmann::json inspection_report(const InspectResult& result, const InspectSettings& settings,
                                 const InputInfo& scan, const InputInfo& cad);

// The report of one search for instances (`align3d find`; docs/report.md, "find"): the instances
// best first (transformation MODEL → SCENE, score, visible fraction, RMS, the symmetry), the model,
// the scene, the settings used, the timings and every warning.
nlohmann::json find_report(const FindResult& result, const FindSettings& settings,
                           const InputInfo& model, const InputInfo& scene);

// The report of one stitch (`align3d stitch`; docs/report.md, "stitch"): per scan in input order
// its pose (scan_0 ≈ T·scan_k), whether it was connected and its residual; every edge found (kept
// or not) with its pose, overlap, RMS, residuals against the graph and information matrix; the
// merged cloud (`merged_file` as written, "" when not; `scan_index`: whether it carries the `scan`
// property), the settings, the timings and every warning. `scans` names each input (its path, ""
// for data in memory) and must have one entry per scan of `result` (std::invalid_argument).
nlohmann::json stitch_report(const StitchResult& result, const StitchSettings& settings,
                             const std::vector<InputInfo>& scans, const std::string& merged_file,
                             bool scan_index);

// The report of one plane correction (`align3d rectify`; docs/report.md, "rectify").
nlohmann::json rectify_report(const RectifyResult& result, const RectifySettings& settings,
                              const InputInfo& cloud);

// Writes `report` pretty-printed to `path`, atomically (io/atomic_file.hpp), or to `out` when the
// path is "-".
void write_json(const std::string& path, const nlohmann::json& report, std::ostream& out);

}  // namespace align3d::report
