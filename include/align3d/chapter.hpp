// The chapter's experiments (sections 39.2-39.5) on its scene, run through align() (align.hpp):
// the engine behind `align3d demo`. report/chapter_report.hpp writes their table, figures and page.
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>

#include "align3d/align.hpp"
#include "align3d/plane/rectify.hpp"
#include "align3d/progress.hpp"

namespace align3d {

struct ChapterScene {
  PointCloud model, scan;          // target and source
  Eigen::Isometry3d T_model_scan;  // ground truth: model ≈ T·scan
  PointCloud plate, plate_cluttered;
  // The cluttered plate's true up normal, to score the plane fits (NaN when unknown: a scene read
  // from a directory without scene.json).
  Eigen::Vector3d cluttered_true_normal = Eigen::Vector3d::Constant(std::nan(""));
  double noise_sigma = 0.1;  // of the scan, for the noise floor in figure 39.3
};

// Generated as `align3d synth` writes it: synth::make_conveyor_scene and the plates
// (report::read_chapter_scene reads such a directory back).
ChapterScene generate_chapter_scene(std::uint64_t seed = 39);

struct IcpExperiment {
  std::string name;
  AlignSettings settings;
  AlignResult result;
  double rotation_deg = 0;        // angle of the recovered rotation
  double rotation_error_deg = 0;  // angle of R_estᵀ·R_gt
  double translation_error = 0;   // |t_est − t_gt|
};

struct ChapterResults {
  IcpExperiment p2p_good;  // 39.2: point-to-point from the identity
  IcpExperiment p2p_bad;   // 39.3: point-to-point from an extra 40° about Z
  IcpExperiment p2plane;   // 39.4: point-to-plane from the identity
  IcpExperiment defaults;  // beyond the chapter: align()'s defaults (`align3d register`)
  // Beyond the chapter, its remedy (39.3): from the bad initial value, global registration (fpfh)
  // and point-to-plane ICP with the chapter's settings (result.global holds the coarse stage).
  IcpExperiment global;
  RectifyResult plate;                              // 39.5: plane correction of the tilted plate
  RectifyResult cluttered_plain, cluttered_robust;  // the cluttered plate, LSQ vs RANSAC + LSQ
  // Angle between each fit's normal and the true one (NaN when the truth is unknown).
  double cluttered_plain_error_deg = 0, cluttered_robust_error_deg = 0;
};

// The chapter's ICP: the given metric from the given pose, median × 2.5 rejection with a 0.5 mm
// floor, |ΔRMS| < 1e-5 mm (absolute), no transform criterion, at most 60 iterations.
AlignSettings chapter_settings(IcpMethod method, const Eigen::Isometry3d& initial_pose);

ChapterResults run_chapter_experiments(const ChapterScene& scene, int threads = 0,
                                       const ProgressCallback& progress = {});

}  // namespace align3d
