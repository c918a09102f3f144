#include "align3d/chapter.hpp"

#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"

namespace align3d {
namespace {

IcpExperiment run(const ChapterScene& scene, std::string name, const AlignSettings& settings) {
  IcpExperiment e{std::move(name), settings, align(scene.scan, scene.model, settings)};
  const Eigen::Isometry3d& T = e.result.transformation;
  e.rotation_deg = rad_to_deg(rotation_angle(T.linear()));
  const PoseError error = pose_error(T, scene.T_model_scan);
  e.rotation_error_deg = error.rotation_deg;
  e.translation_error = error.translation;
  return e;
}

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return rad_to_deg(std::atan2(a.cross(b).norm(), a.dot(b)));
}

}  // namespace

ChapterScene generate_chapter_scene(std::uint64_t seed) {
  synth::ConveyorSettings cs;
  cs.seed = seed;
  const synth::Scene s = synth::make_conveyor_scene(cs);
  const synth::Plate cluttered = synth::make_plate(synth::chapter_plate(seed, true));
  return {s.model,         s.scan,
          s.T_model_scan,  synth::make_plate(synth::chapter_plate(seed, false)).cloud,
          cluttered.cloud, cluttered.true_normal,
          cs.noise_sigma};
}

AlignSettings chapter_settings(IcpMethod method, const Eigen::Isometry3d& initial_pose) {
  AlignSettings s;
  s.init = InitPolicy::kPose;
  s.initial_pose = initial_pose;
  s.refine.method = method;
  s.refine.rejection = RejectionRule::median(2.5, 0.5);
  s.refine.termination.rms_change = 1e-5;  // mm
  s.refine.termination.rms_change_relative = false;
  s.refine.termination.rotation = 0;  // the chapter stops on the RMS change (and the cap) only
  return s;
}

ChapterResults run_chapter_experiments(const ChapterScene& scene, int threads,
                                       const ProgressCallback& progress) {
  constexpr std::size_t kSteps = 7;
  std::size_t done = 0;
  auto step = [&](const std::string& task) {
    if (progress) progress({task, done++, kSteps});
  };
  auto with_threads = [&](AlignSettings s) {
    s.threads = threads;
    return s;
  };
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d bad = rigid_transform(40, Eigen::Vector3d::UnitZ());  // 39.3's bad value

  ChapterResults r;
  step("point-to-point ICP, good initial value");
  r.p2p_good = run(scene, "point-to-point, identity init",
                   with_threads(chapter_settings(IcpMethod::kPointToPoint, identity)));
  step("point-to-point ICP, bad initial value");
  r.p2p_bad = run(scene, "point-to-point, bad init",
                  with_threads(chapter_settings(IcpMethod::kPointToPoint, bad)));
  step("point-to-plane ICP");
  r.p2plane = run(scene, "point-to-plane, identity init",
                  with_threads(chapter_settings(IcpMethod::kPointToPlane, identity)));
  step("align3d defaults");
  r.defaults = run(scene, "align3d register defaults, identity init", with_threads({}));
  // The remedy: global registration, then the chapter's point-to-plane ICP. (The global stage
  // does not depend on the initial value.)
  step("global registration + point-to-plane ICP");
  AlignSettings remedy = with_threads(chapter_settings(IcpMethod::kPointToPlane, bad));
  remedy.init = InitPolicy::kGlobal;
  r.global = run(scene, "bad init + global (fpfh) + point-to-plane", remedy);
  step("plane correction");
  RectifySettings plain;
  plain.robust = false;  // the chapter's least-squares fit
  r.plate = rectify(scene.plate, plain);
  step("plane correction with clutter");
  r.cluttered_plain = rectify(scene.plate_cluttered, plain);
  r.cluttered_robust = rectify(scene.plate_cluttered);
  r.cluttered_plain_error_deg = angle_deg(r.cluttered_plain.normal, scene.cluttered_true_normal);
  r.cluttered_robust_error_deg = angle_deg(r.cluttered_robust.normal, scene.cluttered_true_normal);
  if (progress) progress({"done", kSteps, kSteps});
  return r;
}

}  // namespace align3d
