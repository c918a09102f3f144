// A target prepared once (prepared_target.hpp) against the plain target: the same pose to the bit
// on every path (ICP alone, auto with the global stage, global fpfh and ppf, ICP run the other way
// round), right against the known transform, for many sources in a row (the cached descriptors are
// reused) and from several threads at once.
#include "align3d/prepared_target.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <thread>

#include "align3d/align.hpp"
#include "align3d/error.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"

namespace align3d {
namespace {

void expect_same(const AlignResult& plain, const AlignResult& prepared, const std::string& what) {
  EXPECT_EQ(plain.success, prepared.success) << what;
  EXPECT_EQ(plain.path, prepared.path) << what;
  EXPECT_EQ(plain.reversed, prepared.reversed) << what;
  EXPECT_EQ(plain.transformation.matrix(), prepared.transformation.matrix()) << what;
  EXPECT_EQ(plain.support.overlap, prepared.support.overlap) << what;
  EXPECT_EQ(plain.refine.total_iterations, prepared.refine.total_iterations) << what;
  ASSERT_EQ(plain.global.has_value(), prepared.global.has_value()) << what;
  if (plain.global) {
    EXPECT_EQ(plain.global->voxel, prepared.global->voxel) << what;
  }
  ASSERT_EQ(plain.warnings.size(), prepared.warnings.size()) << what;
  for (std::size_t i = 0; i < plain.warnings.size(); ++i)
    EXPECT_EQ(plain.warnings[i].message, prepared.warnings[i].message) << what;
}

// The scan of `s` turned by a further `angle` about a fixed axis, and the truth for it.
struct Turned {
  PointCloud scan;
  Eigen::Isometry3d truth;
};
Turned turned(const synth::Scene& s, double angle) {
  const Eigen::Isometry3d turn = rigid_transform(angle, Eigen::Vector3d(1, 2, -0.5), {3, -1, 2});
  return {transformed(s.scan, turn), s.T_model_scan * turn.inverse()};
}

TEST(PreparedTarget, SamePoseAsThePlainTargetOnEveryPath) {
  synth::ObjectSettings os;
  os.shape = "bracket";
  const synth::Scene s = synth::make_object_scene(os);
  const PreparedTarget model(s.model);
  struct Case {
    double angle;  // 0: ICP alone suffices; 120: the global stage must run
    InitPolicy init;
    GlobalMethod method;
  };
  for (const Case c : {Case{0, InitPolicy::kIdentity, GlobalMethod::kFpfh},
                       Case{0, InitPolicy::kAuto, GlobalMethod::kFpfh},
                       Case{120, InitPolicy::kAuto, GlobalMethod::kFpfh},
                       Case{120, InitPolicy::kGlobal, GlobalMethod::kFpfh},
                       Case{120, InitPolicy::kGlobal, GlobalMethod::kPpf}}) {
    const Turned t = turned(s, c.angle);
    AlignSettings settings;
    settings.init = c.init;
    settings.global.method = c.method;
    const std::string what =
        std::to_string(c.angle) + " deg, " + to_string(c.init) + ", " + to_string(c.method);
    const AlignResult plain = align(t.scan, s.model, settings);
    const AlignResult first = align(t.scan, model, settings);
    const AlignResult again = align(t.scan, model, settings);  // descriptors from the cache
    expect_same(plain, first, what);
    expect_same(plain, again, what + ", again");
    ASSERT_EQ(first.global.has_value(), c.angle > 0) << what;
    if (c.method == GlobalMethod::kFpfh) {  // ppf is not asked to be right on this box-like part
      EXPECT_LT(pose_error(first.transformation, t.truth).rotation_deg, 0.1) << what;
    }
  }
}

TEST(PreparedTarget, ManyScansAgainstOneModel) {
  const synth::Scene s = synth::make_object_scene();
  const PreparedTarget model(s.model);
  for (const double angle : {10.0, 60.0, 90.0, 150.0, 180.0}) {
    const Turned t = turned(s, angle);
    const AlignResult r = align(t.scan, model);
    expect_same(align(t.scan, s.model), r, std::to_string(angle) + " deg");
    EXPECT_LT(pose_error(r.transformation, t.truth).rotation_deg, 0.1) << angle;
  }
}

// A part placed in a wide floor: ICP runs the scene onto the part (align.hpp), the prepared target
// being the scene.
TEST(PreparedTarget, PartIntoAWideScene) {
  const synth::Scene s = synth::make_object_scene();
  const double size = bounding_box_diagonal(s.model);
  PointCloud scene = transformed(s.model, s.T_model_scan.inverse());
  for (int i = -40; i <= 40; ++i)
    for (int j = -40; j <= 40; ++j)
      scene.positions.emplace_back(0.1 * size * i, 0.1 * size * j, -0.6 * size);
  const PreparedTarget prepared(scene);
  const AlignResult plain = align(s.model, scene);
  const AlignResult r = align(s.model, prepared);
  ASSERT_TRUE(r.reversed);
  expect_same(plain, r, "part into scene");
  EXPECT_LT(pose_error(r.transformation, s.T_model_scan.inverse()).rotation_deg, 0.1);
}

TEST(PreparedTarget, ConcurrentCallsGiveTheSerialResults) {
  synth::ObjectSettings os;
  os.shape = "bracket";
  const synth::Scene s = synth::make_object_scene(os);
  const PreparedTarget model(s.model);
  const std::vector<double> angles = {20.0, 100.0, 140.0, 170.0};
  std::vector<Turned> scans;
  std::vector<AlignResult> serial, parallel(angles.size());
  for (const double a : angles) {
    scans.push_back(turned(s, a));
    serial.push_back(align(scans.back().scan, s.model));
  }
  // Two threads at once, each with a 1-thread pool, sharing the target and its descriptor cache.
  AlignSettings one;
  one.threads = 1;
  auto work = [&](std::size_t first) {
    for (std::size_t i = first; i < angles.size(); i += 2)
      parallel[i] = align(scans[i].scan, model, one);
  };
  std::thread a(work, 0), b(work, 1);
  a.join();
  b.join();
  for (std::size_t i = 0; i < angles.size(); ++i)
    expect_same(serial[i], parallel[i], std::to_string(angles[i]) + " deg");
}

TEST(PreparedTarget, RejectsOtherNormalSettingsAndNamesTheTarget) {
  const synth::Scene s = synth::make_object_scene();
  const PreparedTarget model(s.model);
  AlignSettings k10;
  k10.refine.normals.k = 10;
  EXPECT_THROW(align(s.scan, model, k10), std::invalid_argument);
  PointCloud few;
  few.positions.assign(s.model.positions.begin(), s.model.positions.begin() + 5);
  try {
    const PreparedTarget bad(few);
    FAIL() << "no DataError";
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "target");
  }
}

}  // namespace
}  // namespace align3d
