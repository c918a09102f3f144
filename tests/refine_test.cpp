// refine()'s default schedule (rejection `auto`) against ground truth on the chapter's scene, its
// harder variants and partial views of non-planar objects (issue #2, "Robust defaults").
#include "align3d/icp/refine.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "align3d/evaluate.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/synth/scenes.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::rotation_error_deg;
using test::translation_error;

const Eigen::Isometry3d kIdentity = Eigen::Isometry3d::Identity();

class ConveyorVariant : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

// The bar: rotation error < 0.05°, translation error < 0.02 mm, from the identity, default
// flags; on every variant and several seeds.
TEST_P(ConveyorVariant, DefaultRegistrationRecoversThePose) {
  auto settings = synth::ConveyorSettings::variant(std::get<0>(GetParam()));
  settings.seed = static_cast<std::uint64_t>(std::get<1>(GetParam()));
  const synth::Scene scene = synth::make_conveyor_scene(settings);
  const RefineResult r = refine(scene.scan, scene.model, kIdentity);
  EXPECT_TRUE(r.icp.converged);
  EXPECT_LT(rotation_error_deg(r.icp.T_target_source, scene.T_model_scan), 0.05);
  EXPECT_LT(translation_error(r.icp.T_target_source, scene.T_model_scan), 0.02);
  // The intruder wall is kept out: fitness is the scan's share of model points (4310 / 6497).
  EXPECT_NEAR(r.icp.fitness, 4310.0 / 6497.0, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Variants, ConveyorVariant,
                         ::testing::Combine(::testing::Values("chapter", "wide-plane",
                                                              "small-features", "large-offset"),
                                            ::testing::Values(39, 1, 2)));

// On the extreme variant the chapter's median rule locks onto the plane and ends degrees off; the
// default lands in the right basin (its accuracy is then limited by the tiny features' few points).
TEST(Refine, DefaultFindsTheBasinWhereTheMedianRuleLocksOntoThePlane) {
  const synth::Scene scene =
      synth::make_conveyor_scene(synth::ConveyorSettings::variant("extreme"));
  RefineSettings median;
  median.rejection = RejectionRule::median(2.5, 0.5);
  const RefineResult locked = refine(scene.scan, scene.model, kIdentity, median);
  EXPECT_GT(rotation_error_deg(locked.icp.T_target_source, scene.T_model_scan), 1.0);
  const RefineResult r = refine(scene.scan, scene.model, kIdentity);
  EXPECT_LT(rotation_error_deg(r.icp.T_target_source, scene.T_model_scan), 0.1);
  EXPECT_LT(translation_error(r.icp.T_target_source, scene.T_model_scan), 0.05);
}

class ObjectView : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

// Partial views (~60 % overlap, 4 % outliers, independent sampling, σ = 0.1): not the same points,
// so the sampling itself limits accuracy a little.
TEST_P(ObjectView, DefaultRegistrationRecoversThePose) {
  synth::ObjectSettings s;
  s.shape = std::get<0>(GetParam());
  s.seed = static_cast<std::uint64_t>(std::get<1>(GetParam()));
  const synth::Scene scene = synth::make_object_scene(s);
  const RefineResult r = refine(scene.scan, scene.model, kIdentity);
  EXPECT_TRUE(r.icp.converged);
  EXPECT_LT(rotation_error_deg(r.icp.T_target_source, scene.T_model_scan), 0.05);
  EXPECT_LT(translation_error(r.icp.T_target_source, scene.T_model_scan), 0.03);
}

INSTANTIATE_TEST_SUITE_P(Shapes, ObjectView,
                         ::testing::Combine(::testing::Values("bracket", "bumpy-sphere", "animal"),
                                            ::testing::Values(1, 2, 3)));

PointCloud scaled(const PointCloud& c, double s) {
  PointCloud out = c;
  for (auto& p : out.positions) p *= s;
  return out;
}

// Unit independence: the same scene in metres gives the same rotation and the translation / 1000.
TEST(Refine, DefaultsAreUnitIndependent) {
  const synth::Scene mm = synth::make_conveyor_scene();
  const RefineResult a = refine(mm.scan, mm.model, kIdentity);
  const RefineResult b = refine(scaled(mm.scan, 1e-3), scaled(mm.model, 1e-3), kIdentity);
  EXPECT_EQ(a.total_iterations, b.total_iterations);
  EXPECT_LT(rad_to_deg(rotation_angle(a.icp.T_target_source.linear().transpose() *
                                      b.icp.T_target_source.linear())),
            1e-6);
  EXPECT_LT(
      (a.icp.T_target_source.translation() * 1e-3 - b.icp.T_target_source.translation()).norm(),
      1e-9);
  EXPECT_NEAR(a.icp.rms * 1e-3, b.icp.rms, 1e-9);
}

TEST(Refine, SameResultWithOneOrTwoThreads) {
  const synth::Scene scene = synth::make_conveyor_scene();
  RefineSettings one, two;
  one.threads = 1;
  two.threads = 2;
  const RefineResult a = refine(scene.scan, scene.model, kIdentity, one);
  const RefineResult b = refine(scene.scan, scene.model, kIdentity, two);
  EXPECT_EQ(a.icp.T_target_source.matrix(), b.icp.T_target_source.matrix());
  EXPECT_EQ(a.total_iterations, b.total_iterations);
}

// Target normals are estimated only where pairs need them; the pose is that of a run on a target
// whose normals were all estimated beforehand (used as given), to rounding.
TEST(Refine, EstimatesOnlyTheTargetNormalsItUses) {
  synth::ObjectSettings s;
  s.shape = "bracket";
  const synth::Scene scene = synth::make_object_scene(s);
  PointCloud with_normals = scene.model;
  estimate_normals(with_normals, NormalSettings{});
  for (const bool automatic : {true, false}) {
    RefineSettings settings;
    if (!automatic) settings.rejection = RejectionRule::max_distance(2.0);
    const RefineResult lazy = refine(scene.scan, scene.model, kIdentity, settings);
    const RefineResult given = refine(scene.scan, with_normals, kIdentity, settings);
    EXPECT_GT(lazy.estimated_normals, scene.model.size() / 4);
    EXPECT_LT(lazy.estimated_normals, scene.model.size());
    EXPECT_EQ(lazy.undefined_normals, 0u);
    EXPECT_EQ(given.estimated_normals, 0u);
    EXPECT_EQ(lazy.total_iterations, given.total_iterations);
    EXPECT_TRUE(lazy.icp.T_target_source.isApprox(given.icp.T_target_source, 1e-12));
  }
}

TEST(Refine, RejectsCloudsThatCannotBeRegistered) {
  const synth::Scene scene = synth::make_conveyor_scene();
  PointCloud few;
  few.positions.assign(scene.model.positions.begin(), scene.model.positions.begin() + 5);
  EXPECT_THROW(refine(few, scene.model, kIdentity), DataError);
  PointCloud line;
  for (int i = 0; i < 100; ++i) line.positions.emplace_back(i, 2 * i, 3 * i);
  EXPECT_THROW(refine(line, scene.model, kIdentity), DataError);
  EXPECT_THROW(refine(scene.scan, line, kIdentity), DataError);
  PointCloud spot;
  spot.positions.assign(50, Eigen::Vector3d(1, 2, 3));
  EXPECT_THROW(refine(spot, scene.model, kIdentity), DataError);
}

// Basin hopping (refine.hpp, step 3). On the bumpy sphere a turn about an axis through the sphere's
// centre and one dome moves only the other domes and the post, whose pairs with the sphere under
// them exert no torque: from 20-30° and 5-10 % of the diagonal the coarse stages stopped in such a
// turn in some trials (this test failed on the schedule before the hop). Every trial of these cells
// must succeed (rotation < 1°, translation < 0.5 % of the diagonal, the evaluation's criterion).
TEST(Refine, BasinHoppingLeavesTheBumpySpheresWrongTurns) {
  const EvalScene sphere = evaluation_scene("bumpy-sphere");
  const Basin basin =
      convergence_basin(sphere, EvalMethod::kPointToPlane, {20, 30}, {0.05, 0.1}, 8, /*seed=*/1);
  EXPECT_EQ(basin.success, Eigen::MatrixXd::Ones(2, 2)) << basin.success;
}

// A partial view of the animal (synth/depth_scenes.hpp: a quadruped of ellipsoids; 60 % of its
// surface, 5 % outliers) against its whole surface, 10° and 30° and 10 % of the diagonal off:
// every method alone, every trial right. (Two range scans of it, both partial, are another matter:
// evaluation_scenes()'s "animal", align_test.cpp.)
TEST(Refine, EveryMethodAloneRegistersAViewOfTheAnimalFromThirtyDegrees) {
  synth::ObjectSettings s;
  s.shape = "animal";
  s.outlier_fraction = 0.05;
  const synth::Scene o = synth::make_object_scene(s);
  const EvalScene animal{"animal view", o.scan, o.model, o.T_model_scan};
  for (const EvalMethod m : {EvalMethod::kPointToPoint, EvalMethod::kPointToPlane,
                             EvalMethod::kGicp, EvalMethod::kSymmetric}) {
    const Basin basin = convergence_basin(animal, m, {10, 30}, {0.1}, 8, /*seed=*/1);
    EXPECT_EQ(basin.success, Eigen::MatrixXd::Ones(1, 2)) << to_string(m) << "\n" << basin.success;
  }
}

// The evaluation's scenes by name; the animal's scans have 5 % outliers appended to the source,
// inside the bounding box of its surface points and, at the truth, off the target's surface.
TEST(EvaluationScene, ByNameWithTheAnimalsOutliersLast) {
  const EvalScene scans = evaluation_scene("animal");
  EXPECT_EQ(scans.name, "animal");
  std::size_t surface = scans.source.size();  // n surface points, then n·5/95 outliers
  while (surface + surface * 5 / 95 > scans.source.size()) --surface;
  ASSERT_EQ(surface + surface * 5 / 95, scans.source.size());
  Eigen::AlignedBox3d box;
  for (std::size_t i = 0; i < surface; ++i) box.extend(scans.source.positions[i]);
  const KdTree tree(scans.target.positions);
  const double spacing = point_spacing(scans.target, tree);
  std::size_t off = 0, outliers = 0;
  for (std::size_t i = surface; i < scans.source.size(); ++i, ++outliers) {
    EXPECT_TRUE(box.contains(scans.source.positions[i]));
    Neighbor n;
    tree.nearest(scans.T_target_source * scans.source.positions[i], n);
    off += n.sq_distance > 4 * spacing * spacing;
  }
  EXPECT_GT(off, outliers * 9 / 10);
  EXPECT_THROW(evaluation_scene("rabbit"), std::invalid_argument);
  std::vector<std::string> names;
  for (const EvalScene& s : evaluation_scenes()) names.push_back(s.name);
  EXPECT_EQ(names, (std::vector<std::string>{"chapter", "bracket", "bumpy-sphere", "animal"}));
}

// Two range scans of the animal (evaluation_scenes()'s "animal": each sees a side the other does
// not, 61 % overlap, 5 % outliers). Point-to-plane's coarse stages lose the truth even from the
// truth (the unshared points within their reach pull it off, refine.hpp); GICP's hold it, and are
// tried when the pose is unconfirmed (step 3).
TEST(Refine, GicpCandidateHoldsTheTruthOfTwoRangeScansOfTheAnimal) {
  const EvalScene scans = evaluation_scene("animal");
  const double diagonal = bounding_box_diagonal(scans.target);
  auto right = [&](const RefineResult& r) {
    return rotation_error_deg(r.icp.T_target_source, scans.T_target_source) < 1.0 &&
           translation_error(r.icp.T_target_source, scans.T_target_source) < 0.005 * diagonal;
  };
  const RefineResult from_truth = refine(scans.source, scans.target, scans.T_target_source);
  EXPECT_TRUE(right(from_truth));
  EXPECT_TRUE(from_truth.hopped);
  EXPECT_TRUE(std::any_of(from_truth.stages.begin(), from_truth.stages.end(),
                          [](const StageRecord& s) { return s.hop && s.metric == "gicp"; }));
  EXPECT_TRUE(from_truth.unconfirmed);
  RefineSettings without;
  without.gicp_candidate = false;
  EXPECT_FALSE(right(refine(scans.source, scans.target, scans.T_target_source, without)));
  // With no candidate at all, step 3's test still says the pose is unconfirmed (align() reruns
  // ICP with step 3 on that).
  without.hop = false;
  const RefineResult bare = refine(scans.source, scans.target, scans.T_target_source, without);
  EXPECT_FALSE(right(bare));
  EXPECT_TRUE(bare.unconfirmed);
  EXPECT_EQ(bare.hops, 0);
}

// Step 3 resumed (RefineSettings::resume): the bare run above, continued, holds the truth as the
// run with step 3 from the start does, without repeating its stages: the bare run's stages come
// first, unchanged, and every stage after them is a candidate's, all but the final stage again.
TEST(Refine, ResumedRunContinuesWithStepThree) {
  const EvalScene scans = evaluation_scene("animal");
  const double diagonal = bounding_box_diagonal(scans.target);
  RefineSettings bare;
  bare.hop = false;
  bare.gicp_candidate = false;
  const RefineResult first = refine(scans.source, scans.target, scans.T_target_source, bare);
  ASSERT_TRUE(first.unconfirmed);
  ASSERT_GT(first.stages.size(), 1u);
  RefineSettings continued;
  continued.resume = &first;
  const RefineResult r = refine(scans.source, scans.target, scans.T_target_source, continued);
  EXPECT_LT(rotation_error_deg(r.icp.T_target_source, scans.T_target_source), 1.0);
  EXPECT_LT(translation_error(r.icp.T_target_source, scans.T_target_source), 0.005 * diagonal);
  EXPECT_TRUE(r.hopped);
  ASSERT_GT(r.stages.size(), first.stages.size() + 1);
  for (std::size_t k = 0; k < first.stages.size(); ++k) {
    EXPECT_EQ(r.stages[k].iterations, first.stages[k].iterations) << k;
    EXPECT_EQ(r.stages[k].max_distance, first.stages[k].max_distance) << k;
    EXPECT_FALSE(r.stages[k].hop) << k;
  }
  for (std::size_t k = first.stages.size(); k + 1 < r.stages.size(); ++k)
    EXPECT_TRUE(r.stages[k].hop) << k;
  EXPECT_FALSE(r.stages.back().hop);
  RefineSettings fixed = continued;
  fixed.rejection = RejectionRule::max_distance(0.1 * diagonal);
  EXPECT_THROW(refine(scans.source, scans.target, scans.T_target_source, fixed),
               std::invalid_argument);
}

// The target on them: from the identity, every start up to 30° and 10 % of the diagonal
// right. Without the GICP candidate, of 40 such starts (8 a cell at 0-60° and 10 %) none was, and 2
// of 100 random ones (`align3d evaluate`).
TEST(Refine, TwoRangeScansOfTheAnimalFromThirtyDegrees) {
  const EvalScene scans = evaluation_scene("animal");
  const Basin basin =
      convergence_basin(scans, EvalMethod::kPointToPlane, {0, 10, 30}, {0.1}, 8, /*seed=*/1);
  EXPECT_EQ(basin.success, Eigen::MatrixXd::Ones(1, 3)) << basin.success;
}

// Step 3's test: a pose with too few pairs within the reach is unconfirmed, whatever the RMS of
// those few (it once counted as confirmed, so step 3 tried nothing and the final stage found no
// pairs: bench/compare_basin.py's animal had such starts at 10-20°).
TEST(Refine, TooFewPairsWithinTheReachIsNoConfirmation) {
  const synth::Scene scene = synth::make_conveyor_scene();
  const double diagonal = bounding_box_diagonal(scene.model);
  const Eigen::Isometry3d far(Eigen::Translation3d(2 * diagonal, 0, 0));
  const RefineResult r = refine(scene.scan, scene.model, far);
  EXPECT_EQ(r.icp.stop_reason, StopReason::kTooFewCorrespondences);
  EXPECT_TRUE(r.unconfirmed);
  EXPECT_FALSE(r.hopped);
}

// A pose the data confirm is not hopped from; from 32 starts 30° and 10 % of the diagonal off the
// bumpy sphere's truth (axes spread evenly, shifts across them), some coarse ends are unconfirmed
// and hopped from, and every start ends right (the target). Before the hop 24 of these 32
// ended right, with hops of 29° and 57° 30, 31 once candidates were compared within the noise's
// reach (2026-11-28; the one left diverged to 83° in the coarse stages, out of their reach), 32
// with the third round's 86°.
TEST(Refine, HopsOnlyFromAnUnconfirmedPose) {
  const synth::Scene scene = synth::make_conveyor_scene();
  const RefineResult confirmed = refine(scene.scan, scene.model, kIdentity);
  EXPECT_EQ(confirmed.hops, 0);
  EXPECT_FALSE(confirmed.hopped);
  EXPECT_FALSE(confirmed.unconfirmed);
  for (const StageRecord& s : confirmed.stages) EXPECT_FALSE(s.hop);

  const EvalScene sphere = evaluation_scene("bumpy-sphere");
  const Eigen::Vector3d c = centroid(sphere.target);
  const double diagonal = bounding_box_diagonal(sphere.target);
  int hopped = 0, right = 0;
  for (int k = 0; k < 32; ++k) {
    const double phi = 2.399963 * k, z = 1 - (2 * k + 1) / 32.0;  // a Fibonacci sphere
    const Eigen::Vector3d axis(std::sqrt(1 - z * z) * std::cos(phi),
                               std::sqrt(1 - z * z) * std::sin(phi), z);
    const Eigen::Vector3d shift = 0.1 * diagonal * Eigen::Vector3d(axis.y(), axis.z(), axis.x());
    const Eigen::Isometry3d start = Eigen::Translation3d(shift) * Eigen::Translation3d(c) *
                                    Eigen::AngleAxisd(deg_to_rad(30.0), axis) *
                                    Eigen::Translation3d(-c) * sphere.T_target_source;
    const RefineResult r = refine(sphere.source, sphere.target, start);
    if (r.hopped) {
      ++hopped;
      EXPECT_TRUE(r.unconfirmed);
      EXPECT_GT(r.hops, 0);
      EXPECT_TRUE(std::any_of(r.stages.begin(), r.stages.end(),
                              [](const StageRecord& s) { return s.hop; }));
    }
    right += rotation_error_deg(r.icp.T_target_source, sphere.T_target_source) < 1.0 &&
             translation_error(r.icp.T_target_source, sphere.T_target_source) < 0.005 * diagonal;
  }
  EXPECT_GT(hopped, 0);
  EXPECT_EQ(right, 32);
}

}  // namespace
}  // namespace align3d
