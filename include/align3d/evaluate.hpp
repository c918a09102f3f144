// Evaluation of registration from arbitrary starting poses, through align() (align.hpp): success
// rates over seeded random initial poses, and the convergence basin (success over a grid of
// initial rotation angle × translation magnitude, random axes and directions, as in Rusinkiewicz
// 2019's symmetric-ICP study). The engine behind `align3d evaluate`.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "align3d/point_cloud.hpp"
#include "align3d/progress.hpp"

namespace align3d {

struct EvalScene {
  std::string name;
  PointCloud source, target;          // scan and model
  Eigen::Isometry3d T_target_source;  // the truth: target ≈ T·source
};

// The chapter scene; partial views (~60 % of the surface, 5 % outliers) of a bracket and a bumpy
// sphere against their whole surface; two range scans of an animal 70° apart (61 % overlap, 5 %
// outliers added to the source).
std::vector<EvalScene> evaluation_scenes();
// One of them by name (chapter, bracket, bumpy-sphere, animal); std::invalid_argument otherwise.
EvalScene evaluation_scene(const std::string& name);

// What runs from each starting pose: ICP alone (refine's defaults, init identity) with each
// metric, the global stage (fpfh) then ICP, or align()'s default (init auto).
enum class EvalMethod { kPointToPoint, kPointToPlane, kGicp, kSymmetric, kGlobal, kAuto };
const char* to_string(EvalMethod m);

struct TrialResult {
  bool success = false;  // rotation error < 1° and translation error < 0.5 % of the diagonal
  double rotation_error_deg = 0, translation_error = 0, time_ms = 0;
};

// Places the source on the target (the truth), turns it by `angle_deg` about `axis` through the
// target's centroid and shifts it by `t` (so the identity is that far from the truth, Rusinkiewicz
// 2019's protocol), registers it back from the identity and scores it against the truth.
// `threads` as everywhere.
TrialResult run_trial(const EvalScene& scene, EvalMethod method, double angle_deg,
                      const Eigen::Vector3d& axis, const Eigen::Vector3d& t, std::uint64_t seed,
                      int threads = 0);

struct SuccessRow {
  std::string scene;
  EvalMethod method;
  int trials = 0, successes = 0;
  double median_time_ms = 0, worst_rotation_error_deg = 0;
};

// `trials` seeded random poses per scene: angle uniform in [0°, 180°], uniform random axis,
// translation uniform in [0, ½ diagonal] in a uniform random direction. `progress` hears of each
// trial.
SuccessRow success_rate(const EvalScene& scene, EvalMethod method, int trials, std::uint64_t seed,
                        int threads = 0, const ProgressCallback& progress = {});

struct Basin {
  std::vector<double> angles_deg;             // columns
  std::vector<double> translation_fractions;  // rows, fractions of the target's diagonal
  int trials_per_cell = 0;
  Eigen::MatrixXd success;  // rows × columns, in [0, 1]
};

Basin convergence_basin(const EvalScene& scene, EvalMethod method,
                        const std::vector<double>& angles_deg,
                        const std::vector<double>& translation_fractions, int trials_per_cell,
                        std::uint64_t seed, int threads = 0, const ProgressCallback& progress = {});

}  // namespace align3d
