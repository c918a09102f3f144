#include "align3d/evaluate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "align3d/align.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "align3d/synth/scenes.hpp"
#include "detail/random.hpp"
#include "synth/outliers.hpp"

namespace align3d {
namespace {

constexpr const char* kEvaluationScenes[] = {"chapter", "bracket", "bumpy-sphere", "animal"};

Eigen::Vector3d random_unit(Random& rng) {
  // Uniform on the sphere: z uniform in [−1, 1], azimuth uniform.
  const double z = rng.uniform(-1, 1), phi = rng.uniform(0, 6.283185307179586);
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Counter-based stream: trial k of a run draws from its own generator, so results do not depend on
// which trials ran before.
Random trial_rng(std::uint64_t seed, std::uint64_t k) {
  return Random(splitmix64(seed + 0x9E3779B97F4A7C15ULL * k));
}

// Two range scans of the animal (synth/depth_scenes.hpp) from azimuths 70° apart, each in its own
// camera frame: 61 % of the source lies within 1 mm of the target at the truth. The source gets 5 %
// outliers, uniform in its bounding box, as the object views have.
EvalScene animal_scans() {
  synth::ObjectViewsSettings vs;
  vs.object = "animal";
  vs.target_height = 45;
  vs.azimuth_deg = {30, 100};
  const synth::ObjectViews v = synth::make_object_views(vs);
  EvalScene scene{"animal", v.views[1].valid_points(), v.views[0].valid_points(),
                  v.T_camera_object[0] * v.T_camera_object[1].inverse()};
  Random rng(vs.seed);
  synth::add_outliers(scene.source.positions, scene.source.size() * 5 / 95, rng);
  return scene;
}

AlignSettings method_settings(EvalMethod method, std::uint64_t seed, int threads) {
  AlignSettings s;
  s.seed = seed;
  s.threads = threads;
  switch (method) {
    case EvalMethod::kPointToPoint:
      s.init = InitPolicy::kIdentity;
      s.refine.method = IcpMethod::kPointToPoint;
      break;
    case EvalMethod::kPointToPlane:
      s.init = InitPolicy::kIdentity;
      break;
    case EvalMethod::kGicp:
      s.init = InitPolicy::kIdentity;
      s.refine.method = IcpMethod::kGicp;
      break;
    case EvalMethod::kSymmetric:
      s.init = InitPolicy::kIdentity;
      s.refine.method = IcpMethod::kSymmetric;
      break;
    case EvalMethod::kGlobal:
      s.init = InitPolicy::kGlobal;
      break;
    case EvalMethod::kAuto:
      break;
  }
  return s;
}

}  // namespace

const char* to_string(EvalMethod m) {
  switch (m) {
    case EvalMethod::kPointToPoint:
      return "point-to-point ICP";
    case EvalMethod::kPointToPlane:
      return "point-to-plane ICP";
    case EvalMethod::kGicp:
      return "GICP";
    case EvalMethod::kSymmetric:
      return "symmetric ICP";
    case EvalMethod::kGlobal:
      return "global (fpfh) + point-to-plane ICP";
    case EvalMethod::kAuto:
      return "align3d default (init auto)";
  }
  return "?";
}

EvalScene evaluation_scene(const std::string& name) {
  if (name == "chapter") {
    const synth::Scene chapter = synth::make_conveyor_scene();
    return {name, chapter.scan, chapter.model, chapter.T_model_scan};
  }
  if (name == "bracket" || name == "bumpy-sphere") {
    synth::ObjectSettings s;
    s.shape = name;
    s.outlier_fraction = 0.05;
    const synth::Scene o = synth::make_object_scene(s);
    return {name, o.scan, o.model, o.T_model_scan};
  }
  if (name == "animal") return animal_scans();
  std::string names;
  for (const char* n : kEvaluationScenes) names += std::string(names.empty() ? "" : ", ") + n;
  throw std::invalid_argument("evaluation scene: expected one of " + names + ", got '" + name +
                              "'");
}

std::vector<EvalScene> evaluation_scenes() {
  std::vector<EvalScene> scenes;
  for (const char* name : kEvaluationScenes) scenes.push_back(evaluation_scene(name));
  return scenes;
}

TrialResult run_trial(const EvalScene& scene, EvalMethod method, double angle_deg,
                      const Eigen::Vector3d& axis, const Eigen::Vector3d& t, std::uint64_t seed,
                      int threads) {
  // The source placed on the target, then turned about the target's centroid c and shifted: the
  // identity is then exactly `angle_deg` and |t| (at c) from the truth.
  const Eigen::Vector3d c = centroid(scene.target);
  const Eigen::Isometry3d P =
      Eigen::Translation3d(t + c) * rigid_transform(angle_deg, axis) * Eigen::Translation3d(-c);
  const PointCloud moved = transformed(scene.source, P * scene.T_target_source);
  const Eigen::Isometry3d truth = P.inverse();  // target ≈ truth·moved

  const auto start = std::chrono::steady_clock::now();
  const AlignResult r = align(moved, scene.target, method_settings(method, seed, threads));
  TrialResult out;
  out.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!r.success) {
    out.rotation_error_deg = 180;
    out.translation_error = 1e300;
    return out;
  }
  const PoseError e = pose_error(r.transformation, truth);
  out.rotation_error_deg = e.rotation_deg;
  out.translation_error = e.translation;
  out.success = e.rotation_deg < 1.0 && e.translation < 0.005 * bounding_box_diagonal(scene.target);
  return out;
}

SuccessRow success_rate(const EvalScene& scene, EvalMethod method, int trials, std::uint64_t seed,
                        int threads, const ProgressCallback& progress) {
  SuccessRow row{scene.name, method, trials, 0, 0, 0};
  const double half_diagonal = 0.5 * bounding_box_diagonal(scene.target);
  std::vector<double> times;
  for (int k = 0; k < trials; ++k) {
    if (progress)
      progress({"trials", static_cast<std::size_t>(k), static_cast<std::size_t>(trials)});
    Random rng = trial_rng(seed, static_cast<std::uint64_t>(k));
    const double angle = rng.uniform(0, 180);
    const Eigen::Vector3d axis = random_unit(rng);
    const Eigen::Vector3d t = random_unit(rng) * rng.uniform(0, half_diagonal);
    const TrialResult r =
        run_trial(scene, method, angle, axis, t, seed + static_cast<std::uint64_t>(k), threads);
    row.successes += r.success;
    row.worst_rotation_error_deg = std::max(row.worst_rotation_error_deg, r.rotation_error_deg);
    times.push_back(r.time_ms);
  }
  if (!times.empty()) {
    std::nth_element(times.begin(), times.begin() + static_cast<std::ptrdiff_t>(times.size() / 2),
                     times.end());
    row.median_time_ms = times[times.size() / 2];
  }
  return row;
}

Basin convergence_basin(const EvalScene& scene, EvalMethod method,
                        const std::vector<double>& angles_deg,
                        const std::vector<double>& translation_fractions, int trials_per_cell,
                        std::uint64_t seed, int threads, const ProgressCallback& progress) {
  Basin basin{angles_deg, translation_fractions, trials_per_cell,
              Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(translation_fractions.size()),
                                    static_cast<Eigen::Index>(angles_deg.size()))};
  const double diagonal = bounding_box_diagonal(scene.target);
  const auto total =
      static_cast<std::size_t>(translation_fractions.size() * angles_deg.size() *
                               static_cast<std::size_t>(std::max(0, trials_per_cell)));
  std::uint64_t k = 0;
  for (std::size_t row = 0; row < translation_fractions.size(); ++row)
    for (std::size_t col = 0; col < angles_deg.size(); ++col) {
      int successes = 0;
      for (int trial = 0; trial < trials_per_cell; ++trial, ++k) {
        if (progress) progress({"basin trials", static_cast<std::size_t>(k), total});
        Random rng = trial_rng(seed, k);
        const Eigen::Vector3d axis = random_unit(rng);
        const Eigen::Vector3d t = random_unit(rng) * translation_fractions[row] * diagonal;
        successes += run_trial(scene, method, angles_deg[col], axis, t, seed + k, threads).success;
      }
      basin.success(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(col)) =
          static_cast<double>(successes) / std::max(1, trials_per_cell);
    }
  return basin;
}

}  // namespace align3d
