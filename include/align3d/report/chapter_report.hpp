// The chapter's report (align3d demo): the table that sets our numbers beside the chapter's,
// results.json, figures 39.1-39.6 and report.html, from the experiments of chapter.hpp.
#pragma once

#include <filesystem>
#include <string>

#include "align3d/chapter.hpp"

namespace align3d::report {

// The scene from a directory written by `align3d synth` (model.ply, scan.ply, ground_truth.txt,
// plate.ply, plate_cluttered.ply, and scene.json for the noise level and the cluttered plate's
// normal). Throws IoError naming the file at fault.
ChapterScene read_chapter_scene(const std::filesystem::path& dir);

// The comparison table (markdown): experiment | quantity | chapter | ours.
std::string chapter_table(const ChapterResults& results);

// Writes table.md, results.json, fig39_1..fig39_6 (.svg and .png; 39.6 is the global remedy) and
// report.html into `outdir` (created if missing).
void write_chapter_report(const ChapterScene& scene, const ChapterResults& results,
                          const std::filesystem::path& outdir);

}  // namespace align3d::report
