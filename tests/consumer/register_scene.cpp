// Registers the chapter's conveyor scene (scan onto model, from the identity) with the installed
// library and checks the recovered transform against the scene's ground truth. Exits 1 when the
// error exceeds the accuracy the README states for the default settings on this scene: rotation
// < 0.05°, translation < 0.02 mm.
#include <align3d/align.hpp>
#include <align3d/synth/scenes.hpp>
#include <cstdio>
#include <numbers>

int main() {
  const align3d::synth::Scene scene = align3d::synth::make_conveyor_scene();
  // The registration call (target ≈ T·source), with the defaults.
  const align3d::AlignResult result = align3d::align(scene.scan, scene.model);
  if (!result.success || !result.warnings.empty()) return 1;
  const Eigen::Isometry3d& T = result.transformation;

  const Eigen::Matrix3d R_error = T.rotation().transpose() * scene.T_model_scan.rotation();
  const double rotation_error_deg = Eigen::AngleAxisd(R_error).angle() * 180 / std::numbers::pi;
  const double translation_error = (T.translation() - scene.T_model_scan.translation()).norm();
  std::printf("register_scene: rotation error %.4f deg, translation error %.4f mm\n",
              rotation_error_deg, translation_error);
  return rotation_error_deg < 0.05 && translation_error < 0.02 ? 0 : 1;
}
