#include "align3d/report/evaluation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "align3d/coarse/global.hpp"
#include "align3d/registration.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "detail/random.hpp"

namespace align3d::report {
namespace {

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

}  // namespace

const char* to_string(EvalMethod m) {
  switch (m) {
    case EvalMethod::kPointToPoint:
      return "point-to-point ICP";
    case EvalMethod::kPointToPlane:
      return "point-to-plane ICP";
    case EvalMethod::kGlobal:
      return "global (fpfh) + point-to-plane ICP";
  }
  return "?";
}

std::vector<EvalScene> evaluation_scenes() {
  std::vector<EvalScene> scenes;
  const synth::Scene chapter = synth::make_conveyor_scene();
  scenes.push_back({"chapter", chapter.scan, chapter.model, chapter.T_model_scan});
  for (const char* shape : {"bracket", "bumpy-sphere"}) {
    synth::ObjectSettings s;
    s.shape = shape;
    s.outlier_fraction = 0.05;
    const synth::Scene o = synth::make_object_scene(s);
    scenes.push_back({shape, o.scan, o.model, o.T_model_scan});
  }
  return scenes;
}

TrialResult run_trial(const EvalScene& scene, EvalMethod method, double angle_deg,
                      const Eigen::Vector3d& axis, const Eigen::Vector3d& t, std::uint64_t seed) {
  const Eigen::Isometry3d P = rigid_transform(angle_deg, axis, t);
  const PointCloud moved = transformed(scene.source, P);
  const Eigen::Isometry3d truth = scene.truth * P.inverse();  // target ≈ truth·moved

  const auto start = std::chrono::steady_clock::now();
  RegistrationSettings settings;
  settings.method =
      method == EvalMethod::kPointToPoint ? IcpMethod::kPointToPoint : IcpMethod::kPointToPlane;
  Eigen::Isometry3d init = Eigen::Isometry3d::Identity();
  TrialResult r;
  if (method == EvalMethod::kGlobal) {
    GlobalSettings gs;
    gs.seed = seed;
    const GlobalResult g = global_register(moved, scene.target, gs);
    if (!g.success) {
      r.time_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      r.rotation_error_deg = 180;
      r.translation_error = 1e300;
      return r;
    }
    init = g.T_target_source;
  }
  const RegistrationResult reg = register_clouds(moved, scene.target, init, settings);
  r.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const Eigen::Isometry3d& T = reg.icp.T_target_source;
  r.rotation_error_deg = rad_to_deg(rotation_angle(T.linear().transpose() * truth.linear()));
  r.translation_error = (T.translation() - truth.translation()).norm();
  r.success = r.rotation_error_deg < 1.0 &&
              r.translation_error < 0.005 * bounding_box_diagonal(scene.target);
  return r;
}

SuccessRow success_rate(const EvalScene& scene, EvalMethod method, int trials, std::uint64_t seed) {
  SuccessRow row{scene.name, method, trials, 0, 0, 0};
  const double half_diagonal = 0.5 * bounding_box_diagonal(scene.target);
  std::vector<double> times;
  for (int k = 0; k < trials; ++k) {
    Random rng = trial_rng(seed, static_cast<std::uint64_t>(k));
    const double angle = rng.uniform(0, 180);
    const Eigen::Vector3d axis = random_unit(rng);
    const Eigen::Vector3d t = random_unit(rng) * rng.uniform(0, half_diagonal);
    const TrialResult r =
        run_trial(scene, method, angle, axis, t, seed + static_cast<std::uint64_t>(k));
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
                        std::uint64_t seed) {
  Basin basin{angles_deg, translation_fractions, trials_per_cell,
              Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(translation_fractions.size()),
                                    static_cast<Eigen::Index>(angles_deg.size()))};
  const double diagonal = bounding_box_diagonal(scene.target);
  std::uint64_t k = 0;
  for (std::size_t row = 0; row < translation_fractions.size(); ++row)
    for (std::size_t col = 0; col < angles_deg.size(); ++col) {
      int successes = 0;
      for (int trial = 0; trial < trials_per_cell; ++trial, ++k) {
        Random rng = trial_rng(seed, k);
        const Eigen::Vector3d axis = random_unit(rng);
        const Eigen::Vector3d t = random_unit(rng) * translation_fractions[row] * diagonal;
        successes += run_trial(scene, method, angles_deg[col], axis, t, seed + k).success;
      }
      basin.success(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(col)) =
          static_cast<double>(successes) / std::max(1, trials_per_cell);
    }
  return basin;
}

}  // namespace align3d::report
