// The pipeline, align(), against known transforms: the chapter's scene, partial views 10°-180°
// apart (the auto policy must choose the global stage where ICP alone fails and keep ICP where it
// succeeds), range scans of an object, a part in a depth-camera scene with NaN holes (defaults
// that follow the object), and one test per warning.
#include "align3d/align.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <utility>

#include "align3d/error.hpp"
#include "align3d/evaluate.hpp"
#include "align3d/synth/camera.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "align3d/synth/scenes.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

bool has_warning(const AlignResult& r, const std::string& code) {
  return std::any_of(r.warnings.begin(), r.warnings.end(),
                     [&](const Warning& w) { return w.code == code; });
}

std::string codes(const AlignResult& r) {
  std::string out;
  for (const Warning& w : r.warnings) out += w.code + ": " + w.message + "\n";
  return out;
}

TEST(Align, ChapterSceneWithDefaults) {
  const synth::Scene s = synth::make_conveyor_scene();
  const AlignResult r = align(s.scan, s.model);
  ASSERT_TRUE(r.success) << r.failure;
  EXPECT_EQ(r.path, "initial");  // ICP from the identity is well supported: no global stage
  EXPECT_FALSE(r.global.has_value());
  EXPECT_TRUE(r.warnings.empty()) << codes(r);
  const PoseError e = pose_error(r.transformation, s.T_model_scan);
  EXPECT_LT(e.rotation_deg, 0.05);
  EXPECT_LT(e.translation, 0.02);
  // The support of the right answer: the scan lies on the model where they overlap (4310 of 6497
  // points come from the model; the 2187 others are the intruder wall and the cropped side).
  EXPECT_GT(r.support.overlap, 0.6);
  EXPECT_NEAR(r.support.noise, 0.1, 0.03);  // σ = 0.1 mm on the scan, the model is noise-free
}

// A partial view (60 % of an object, 5 % outliers) turned by `angle` about a fixed axis. From the
// identity, ICP without hops succeeds at small angles and lands in wrong minima at large ones
// (measured: from 50° on for the bracket and the bumpy sphere, at 60° for the animal, which with
// hops is right up to 120°); the default must be right everywhere, and take the global stage's
// answer exactly where that ICP failed.
class PartialViews : public ::testing::TestWithParam<std::tuple<std::string, double>> {};

TEST_P(PartialViews, AutoChoosesGlobalExactlyWhereIcpAloneFails) {
  synth::ObjectSettings os;
  os.shape = std::get<0>(GetParam());
  os.rotation_deg = std::get<1>(GetParam());
  os.seed = 3;
  os.outlier_fraction = 0.05;
  const synth::Scene s = synth::make_object_scene(os);
  AlignSettings icp_alone;  // ICP as `auto` runs it first: from the identity, without hops
  icp_alone.init = InitPolicy::kIdentity;
  icp_alone.refine.hop = false;
  const AlignResult a = align(s.scan, s.model, icp_alone);
  const bool icp_right = pose_error(a.transformation, s.T_model_scan).rotation_deg < 0.1;
  if (os.rotation_deg >= 90) {  // the test must exercise both paths
    EXPECT_FALSE(icp_right);
  }
  if (os.rotation_deg <= 30) {
    EXPECT_TRUE(icp_right);
  }
  // ICP alone is never wrong in silence: it fails, or it warns.
  if (!icp_right) {
    EXPECT_TRUE(!a.success || !a.warnings.empty()) << codes(a);
  }

  const AlignResult r = align(s.scan, s.model);
  ASSERT_TRUE(r.success) << r.failure;
  const PoseError e = pose_error(r.transformation, s.T_model_scan);
  EXPECT_LT(e.rotation_deg, 0.1) << r.path;
  EXPECT_LT(e.translation, 0.05) << r.path;
  EXPECT_EQ(r.path, icp_right ? "initial" : "global") << r.reason;
  EXPECT_TRUE(r.warnings.empty()) << codes(r);
}

INSTANTIATE_TEST_SUITE_P(Angles, PartialViews,
                         ::testing::Combine(::testing::Values("bracket", "bumpy-sphere", "animal"),
                                            ::testing::Values(10.0, 60.0, 120.0, 180.0)));

// Two range scans of the test object, each in its own camera frame, `apart` degrees apart on a
// circle around it (synth/depth_scenes.hpp: overlap 0.91 at 10°, 0.46 at 60°).
TEST(Align, RangeScansOfAnObject) {
  for (const double apart : {10.0, 60.0}) {
    synth::ObjectViewsSettings vs;
    vs.azimuth_deg = {30, 30 + apart};
    const synth::ObjectViews v = synth::make_object_views(vs);
    const PointCloud target = v.views[0].valid_points(), source = v.views[1].valid_points();
    const Eigen::Isometry3d truth = v.T_camera_object[0] * v.T_camera_object[1].inverse();
    const AlignResult r = align(source, target);
    ASSERT_TRUE(r.success) << apart << ": " << r.failure;
    const PoseError e = pose_error(r.transformation, truth);
    EXPECT_LT(e.rotation_deg, 0.1) << apart << " " << r.path;
    EXPECT_LT(e.translation, 0.2) << apart << " " << r.path;  // σ = 0.1 mm at 0.5 m
  }
}

// Two range scans of the animal 70° apart (evaluation_scenes()'s "animal": both partial, 61 %
// overlap, thin legs, ears and a tail). From the truth itself point-to-plane's coarse stages lose
// the pose (the pairs between the parts one scan sees and the other does not, 2-17 mm from the
// other surface, pull it away); GICP's coarse stages, step 3's candidate (icp/refine.hpp), hold it.
// ICP alone and the default both register them from 0-30° and 10 % of the diagonal (before the
// candidate, none of the six was right: each warned or failed). From 0° the default's first ICP
// (no step 3) ends far off and the global stage finds no pose; ICP rerun with step 3 mends it
// (align.hpp; without that rerun it ended 91° off, with warnings).
TEST(Align, RangeScansOfTheAnimal) {
  const EvalScene scans = evaluation_scene("animal");
  ASSERT_EQ(scans.name, "animal");
  const double diagonal = bounding_box_diagonal(scans.target);
  const Eigen::Vector3d c = centroid(scans.target);
  for (const double angle : {0.0, 10.0, 30.0})
    for (const InitPolicy init : {InitPolicy::kIdentity, InitPolicy::kAuto}) {
      const Eigen::Isometry3d P =
          Eigen::Translation3d(c + 0.1 * diagonal * Eigen::Vector3d(0, 0.6, 0.8)) *
          rigid_transform(angle, Eigen::Vector3d(1, 2, -1)) * Eigen::Translation3d(-c);
      AlignSettings settings;
      settings.init = init;
      const AlignResult r =
          align(transformed(scans.source, P * scans.T_target_source), scans.target, settings);
      ASSERT_TRUE(r.success) << angle << "°: " << r.failure;
      const PoseError e =
          pose_error(r.transformation * P * scans.T_target_source, scans.T_target_source);
      EXPECT_LT(e.rotation_deg, 1) << angle << "° " << r.path;
      EXPECT_LT(e.translation, 0.005 * diagonal) << angle << "° " << r.path;
    }
}

// A 180 mm part in a 1.4 m depth-camera scene (640 × 480, Kinect-like noise σ ≈ 1.6 mm, NaN
// holes, projector shadows): a floor, the part at a new pose, three other objects. The model is
// the part as the same camera saw it alone (a teach-in view). The global stage's sampling follows
// the part, whichever role it has; sampling with the scene's size (its diagonal / 50, ~30 mm: the
// rule before) leaves the part a handful of points and finds nothing right.
class PartInScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    using namespace synth;
    PinholeCamera camera;
    camera.T_world_camera = look_at({60, -150, 900}, {0, 0, 0}, {0, 1, 0});
    Rectangle floor;
    floor.half_size = {700, 500};
    auto part_at = [](const Eigen::Isometry3d& T) {
      std::vector<Shape> out;
      for (const Shape& s : test_object_shapes()) out.push_back(transformed(s, T));
      return out;
    };
    std::vector<Shape> teach = {floor};
    for (const Shape& s : part_at(Eigen::Isometry3d::Identity())) teach.push_back(s);
    const OrganizedCloud seen = render(camera, teach, DepthSensorSettings{}, 100);
    model_ = new PointCloud;
    for (std::size_t i = 0; i < seen.positions.size(); ++i)
      if (seen.shape[i] >= 1) model_->positions.push_back(seen.positions[i]);  // not the floor

    const Eigen::Isometry3d pose = rigid_transform(-16, Eigen::Vector3d::UnitZ(), {-60, 25, 0});
    std::vector<Shape> shapes = {floor};
    for (const Shape& s : part_at(pose)) shapes.push_back(s);
    shapes.push_back(Sphere{{-250, 150, 60}, 60});
    Cylinder cylinder;
    cylinder.pose.translation() = Eigen::Vector3d(220, -180, 50);
    cylinder.radius = 45;
    cylinder.half_height = 50;
    shapes.push_back(cylinder);
    Box box;
    box.pose = rigid_transform(20, Eigen::Vector3d::UnitZ(), {250, 200, 40});
    box.half_size = {80, 50, 40};
    shapes.push_back(box);
    const OrganizedCloud image = render(camera, shapes, DepthSensorSettings{}, 1);
    ASSERT_LT(image.valid_count(), image.positions.size());  // there are holes
    scene_ = new PointCloud(image.valid_points());
    // scene ≈ T·model: the camera frame of the teach-in to the world, the part moved, back.
    truth_ = new Eigen::Isometry3d(camera.T_world_camera.inverse() * pose * camera.T_world_camera);
  }
  static void TearDownTestSuite() {
    delete model_;
    delete scene_;
    delete truth_;
  }
  // The part's pose in the scene from a result in either role; right within the noise.
  static void expect_found(const AlignResult& r, bool scene_is_source, const std::string& what) {
    ASSERT_TRUE(r.success) << what << ": " << r.failure;
    const Eigen::Isometry3d T = scene_is_source ? r.transformation.inverse() : r.transformation;
    const PoseError e = pose_error(T, *truth_);
    EXPECT_LT(e.rotation_deg, 2.0) << what;
    EXPECT_LT(e.translation, 6.0) << what;  // mm, against σ ≈ 1.6 mm per point
  }
  static PointCloud* model_;
  static PointCloud* scene_;
  static Eigen::Isometry3d* truth_;
};
PointCloud* PartInScene::model_ = nullptr;
PointCloud* PartInScene::scene_ = nullptr;
Eigen::Isometry3d* PartInScene::truth_ = nullptr;

TEST_F(PartInScene, FoundWithDefaultsInEitherRole) {
  for (const InitPolicy init : {InitPolicy::kAuto, InitPolicy::kGlobal}) {
    AlignSettings s;
    s.init = init;
    const AlignResult scene_onto_model = align(*scene_, *model_, s);
    expect_found(scene_onto_model, true, std::string("scene as source, ") + to_string(init));
    EXPECT_EQ(scene_onto_model.support.object, Role::kTarget);
    EXPECT_FALSE(scene_onto_model.reversed);
    const AlignResult model_into_scene = align(*model_, *scene_, s);
    expect_found(model_into_scene, false, std::string("model as source, ") + to_string(init));
    EXPECT_EQ(model_into_scene.support.object, Role::kSource);
    EXPECT_TRUE(model_into_scene.reversed);  // ICP ran the scene onto the part
  }
}

TEST_F(PartInScene, SamplingWithTheScenesSizeFindsNothingRight) {
  AlignSettings s;
  s.init = InitPolicy::kGlobal;
  s.global.voxel = bounding_box_diagonal(*scene_) / 50;
  const AlignResult r = align(*model_, *scene_, s);
  const bool right = r.success && pose_error(r.transformation, *truth_).rotation_deg < 2.0;
  EXPECT_FALSE(right);
  s.global.voxel = 0;  // the default: from the part
  const AlignResult defaults = align(*model_, *scene_, s);
  ASSERT_TRUE(defaults.global.has_value());
  EXPECT_LT(defaults.global->voxel, 0.25 * bounding_box_diagonal(*scene_) / 50);
}

// ---- one test per warning ----

TEST(AlignWarnings, WrongMinimumFromTheIdentity) {
  synth::ObjectSettings os;
  os.shape = "bracket";
  os.rotation_deg = 120;
  os.seed = 3;
  const synth::Scene s = synth::make_object_scene(os);
  AlignSettings icp_alone;
  icp_alone.init = InitPolicy::kIdentity;
  const AlignResult r = align(s.scan, s.model, icp_alone);
  ASSERT_GT(pose_error(r.transformation, s.T_model_scan).rotation_deg, 10.0);  // indeed wrong
  EXPECT_TRUE(has_warning(r, "weak_overlap")) << codes(r);
  EXPECT_TRUE(has_warning(r, "high_rms")) << codes(r);
}

TEST(AlignWarnings, PlaneOnPlaneIsDegenerate) {
  Random rng(4);
  PointCloud a, b;
  for (int i = 0; i < 3000; ++i) {
    a.positions.emplace_back(rng.uniform(0, 100), rng.uniform(0, 80), rng.normal() * 0.05);
    b.positions.emplace_back(rng.uniform(0, 100), rng.uniform(0, 80), rng.normal() * 0.05);
  }
  AlignSettings s;
  s.init = InitPolicy::kIdentity;
  const AlignResult r = align(a, b, s);
  ASSERT_TRUE(r.success) << r.failure;
  EXPECT_TRUE(has_warning(r, "degenerate")) << codes(r);
}

// The chapter's point-to-point experiment from the identity (README, Warnings).
AlignSettings chapter_point_to_point() {
  AlignSettings settings;
  settings.init = InitPolicy::kIdentity;
  settings.refine.rejection = RejectionRule::median(2.5, 0.5);
  settings.refine.method = IcpMethod::kPointToPoint;
  return settings;
}

TEST(AlignWarnings, IterationCapIsNotConvergence) {
  const synth::Scene s = synth::make_conveyor_scene();
  AlignSettings settings = chapter_point_to_point();
  settings.refine.termination.max_iterations = 2;
  const AlignResult r = align(s.scan, s.model, settings);
  EXPECT_TRUE(has_warning(r, "not_converged")) << codes(r);
}

// The chapter's point-to-point from the identity creeps along the conveyor: its next update is
// many standard deviations of its covariance long (IcpResult::pending_sigmas). Point-to-plane
// from the same start reaches its stationary point.
TEST(AlignWarnings, CreepingRunStoppedShort) {
  const synth::Scene s = synth::make_conveyor_scene();
  AlignSettings settings = chapter_point_to_point();
  const AlignResult creeping = align(s.scan, s.model, settings);
  EXPECT_TRUE(has_warning(creeping, "stopped_short")) << codes(creeping);
  EXPECT_GT(creeping.refine.icp.pending_sigmas, kStoppedShortSigmas);
  settings.refine.method = IcpMethod::kPointToPlane;
  const AlignResult settled = align(s.scan, s.model, settings);
  EXPECT_FALSE(has_warning(settled, "stopped_short")) << codes(settled);
  EXPECT_LT(settled.refine.icp.pending_sigmas, 0.1);
}

// A box has symmetries: a half turn lays it onto itself as well as the truth does.
TEST(AlignWarnings, SymmetricPartIsAmbiguous) {
  Random rng(8);
  const PointCloud target = test::box_surface(8000, rng);
  const Eigen::Isometry3d P = rigid_transform(70, {1, 2, 3}, {15, -10, 5});
  const PointCloud source = transformed(test::box_surface(8000, rng), P);
  AlignSettings s;
  s.init = InitPolicy::kGlobal;
  const AlignResult r = align(source, target, s);
  ASSERT_TRUE(r.success) << r.failure;
  EXPECT_TRUE(has_warning(r, "ambiguous")) << codes(r);
}

// ICP from the identity ends in a wrong minimum, and the global stage, given no hypotheses to
// draw, finds no pose either: the answer comes with both facts.
TEST(AlignWarnings, GlobalStageFoundNothingEither) {
  synth::ObjectSettings os;
  os.shape = "bracket";
  os.rotation_deg = 120;
  os.seed = 3;
  const synth::Scene s = synth::make_object_scene(os);
  AlignSettings settings;
  settings.global.ransac_iterations = 0;
  const AlignResult r = align(s.scan, s.model, settings);
  ASSERT_TRUE(r.global.has_value()) << r.reason;
  EXPECT_FALSE(r.global->success);
  EXPECT_TRUE(has_warning(r, "global_failed")) << codes(r);
  EXPECT_TRUE(has_warning(r, "high_rms")) << codes(r);
  EXPECT_EQ(r.path, "initial");
}

// Two range scans 120° apart share little (their top faces and one end): ICP from the identity
// slides one face onto another and lays as much of the scan on the other's surface as the global
// stage's right answer does. Neither is clearly better: ambiguous, never silent.
TEST(AlignWarnings, TwoAnswersSupportedAlikeAreAmbiguous) {
  synth::ObjectViewsSettings vs;
  vs.azimuth_deg = {30, 150};
  const synth::ObjectViews v = synth::make_object_views(vs);
  const AlignResult r = align(v.views[1].valid_points(), v.views[0].valid_points());
  ASSERT_GE(r.candidates.size(), 2u);  // the global stage's runner-up too, when it has one
  const Eigen::Isometry3d truth = v.T_camera_object[0] * v.T_camera_object[1].inverse();
  EXPECT_LT(pose_error(r.candidates[1].transformation, truth).rotation_deg, 1.0);  // global: right
  EXPECT_GT(pose_error(r.candidates[0].transformation, truth).rotation_deg, 10.0);
  EXPECT_TRUE(has_warning(r, "ambiguous")) << codes(r);
}

TEST(Align, SameResultWithOneOrTwoThreads) {
  synth::ObjectSettings os;
  os.rotation_deg = 120;  // the global path
  const synth::Scene s = synth::make_object_scene(os);
  AlignSettings one, two;
  one.threads = 1;
  two.threads = 2;
  const AlignResult a = align(s.scan, s.model, one), b = align(s.scan, s.model, two);
  EXPECT_EQ(a.path, b.path);
  EXPECT_EQ(a.transformation.matrix(), b.transformation.matrix());
  EXPECT_EQ(a.support.overlap, b.support.overlap);
}

TEST(Align, NamesTheCloudThatCannotBeRegistered) {
  const synth::Scene s = synth::make_conveyor_scene();
  PointCloud few;
  few.positions.assign(s.model.positions.begin(), s.model.positions.begin() + 5);
  try {
    align(few, s.model);
    FAIL() << "no DataError";
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "source");
  }
  try {
    align(s.scan, few);
    FAIL() << "no DataError";
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "target");
  }
}

TEST(Align, RefusesANonFinitePointNamingTheCloud) {
  const synth::Scene s = synth::make_conveyor_scene();
  PointCloud bad = s.scan;
  bad.positions[17].y() = std::nan("");
  try {
    align(bad, s.model);
    FAIL() << "no DataError";
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "source");
    EXPECT_EQ(e.problem(), "point 17 has a NaN or Inf coordinate");
  }
}

// Each setting no run can use is an std::invalid_argument naming its field, before any work.
TEST(Align, RefusesSettingsNoRunCanUseNamingTheField) {
  const synth::Scene s = synth::make_conveyor_scene();
  const PpfModel model;
  const std::pair<std::string, std::function<void(AlignSettings&)>> cases[] = {
      {"refine.termination.max_iterations",
       [](AlignSettings& a) { a.refine.termination.max_iterations = 0; }},
      {"refine.termination.rms_change",
       [](AlignSettings& a) { a.refine.termination.rms_change = std::nan(""); }},
      {"refine.termination.rotation", [](AlignSettings& a) { a.refine.termination.rotation = -1; }},
      {"refine.normals.k", [](AlignSettings& a) { a.refine.normals.k = 2; }},
      {"threads", [](AlignSettings& a) { a.threads = -1; }},
      {"global.voxel", [](AlignSettings& a) { a.global.voxel = INFINITY; }},
      {"global.ransac_confidence", [](AlignSettings& a) { a.global.ransac_confidence = 1; }},
      {"ppf_model needs init global or auto",
       [&](AlignSettings& a) {
         a.ppf_model = &model;
         a.init = InitPolicy::kIdentity;
       }},
      {"global.voxel with a ppf_model",
       [&](AlignSettings& a) {
         a.ppf_model = &model;
         a.global.voxel = 1;
       }},
  };
  for (const auto& [field, spoil] : cases) {
    AlignSettings settings;
    spoil(settings);
    try {
      align(s.scan, s.model, settings);
      ADD_FAILURE() << field << ": accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace align3d
