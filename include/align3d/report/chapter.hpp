// The chapter's experiments (sections 39.2-39.5) on its scene, and their report: the table that
// sets our numbers beside the chapter's, results.json, figures 39.1-39.6 and report.html.
#pragma once

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "align3d/coarse/global.hpp"
#include "align3d/plane/rectify.hpp"
#include "align3d/registration.hpp"

namespace align3d::report {

struct ChapterScene {
  PointCloud model, scan;          // target and source
  Eigen::Isometry3d T_model_scan;  // ground truth
  PointCloud plate, plate_cluttered;
  // The cluttered plate's true up normal, to score the plane fits (NaN when unknown: a scene read
  // from a directory without scene.json).
  Eigen::Vector3d cluttered_true_normal = Eigen::Vector3d::Constant(std::nan(""));
  double noise_sigma = 0.1;  // of the scan, for the noise floor in figure 39.3
};

// Generated (synth::make_conveyor_scene + plates, as `align3d synth` writes them) or read from a
// directory written by `align3d synth` (model.ply, scan.ply, ground_truth.txt, plate.ply,
// plate_cluttered.ply, and scene.json for the noise level and the cluttered plate's normal).
ChapterScene generate_chapter_scene(std::uint64_t seed = 39);
ChapterScene read_chapter_scene(const std::filesystem::path& dir);

struct IcpExperiment {
  std::string name;
  Eigen::Isometry3d init;
  RegistrationResult result;
  double rotation_deg = 0;        // angle of the recovered rotation
  double rotation_error_deg = 0;  // angle of R_estᵀ·R_gt
  double translation_error = 0;   // |t_est − t_gt|
};

struct ChapterResults {
  IcpExperiment p2p_good;  // 39.2: point-to-point from the identity
  IcpExperiment p2p_bad;   // 39.3: point-to-point from an extra 40° about Z
  IcpExperiment p2plane;   // 39.4: point-to-plane from the identity
  IcpExperiment robust;    // beyond the chapter: `align3d register` defaults from the identity
  // Beyond the chapter, its remedy (39.3): bad initial value, then global registration (fpfh) and
  // point-to-plane ICP with the chapter's settings.
  IcpExperiment global;
  GlobalResult global_coarse;
  RectifyResult plate;                              // 39.5: plane correction of the tilted plate
  RectifyResult cluttered_plain, cluttered_robust;  // the cluttered plate, LSQ vs RANSAC + LSQ
  // Angle between each fit's normal and the true one (NaN when the truth is unknown).
  double cluttered_plain_error_deg = 0, cluttered_robust_error_deg = 0;
};

// The chapter's ICP settings: median × 2.5 with a 0.5 mm floor, |ΔRMS| < 1e-5 mm, 60 iterations.
RegistrationSettings chapter_settings(IcpMethod method);

ChapterResults run_chapter_experiments(const ChapterScene& scene, int threads = 0);

// The comparison table (markdown): experiment | quantity | chapter | ours.
std::string chapter_table(const ChapterResults& results);

// Writes table.md, results.json, fig39_1..fig39_6 (.svg and .png; 39.6 is the global remedy) and
// report.html into `outdir`.
void write_chapter_report(const ChapterScene& scene, const ChapterResults& results,
                          const std::filesystem::path& outdir);

}  // namespace align3d::report
