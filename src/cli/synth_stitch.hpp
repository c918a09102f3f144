// `align3d synth --scene stitch`: the multi-view scans of synth/stitch_scans.hpp written as files
// (private to the tool).
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace align3d::cli {

// The values of synth's flags for --scene stitch (their defaults are declared with the flags).
struct StitchScenesOptions {
  std::uint64_t seed;
  std::string part;  // bracket or flange (the keyed flange)
  int views;         // ring views, at least 2
  bool leaf;         // add the leaf view
};

// scan_00.ply, scan_01.ply, … (binary PLY, positions only, each in its own sensor frame: the
// sensor at the origin looking along +z), scans.txt (their names, one a line, in order),
// model.stl (the object, object frame) and truth.json (each scan's pose in scan_00's frame, its
// eye, the overlap matrix, the leaf), which it returns. Throws UsageError for fewer than 2 views.
nlohmann::json write_stitch_scans(const std::filesystem::path& outdir,
                                  const StitchScenesOptions& o);

}  // namespace align3d::cli
