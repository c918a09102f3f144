// The ICP loop and its rejection rules. Oracles: a synthetic object moved by a known transform
// (forward: scan → model gives T; inverse: model → scan gives T⁻¹); an exact noise-free subset
// (recovered to rounding); a brute-force nearest-neighbour pass for the first iteration's
// threshold, kept count and RMS; the documented stop reasons; bitwise equality across thread
// counts.
#include "align3d/icp/icp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/icp/rejection.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::kInf;

// The bracket (synth::make_object_scene: an L-bracket with a boss and a dome, ~90 mm) seen whole,
// 8000 points, σ = 0.1 mm,
// 4 % uniform outliers in the scan, moved by 10° about a random axis (fixed seed) and (3, −2, 4)
// mm. Model and scan are independent samplings (spacing ~1.3 mm), so even at the true pose a scan
// point is ~0.5 mm from its nearest model point: point-to-point is biased by a fraction of that.
class IcpScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    Random rng(501);
    const double x = rng.normal(), y = rng.normal(), z = rng.normal();
    synth::ObjectSettings settings;
    settings.rotation_deg = 10;
    settings.rotation_axis = Eigen::Vector3d(x, y, z).normalized();
    settings.translation = {3, -2, 4};
    settings.overlap = 1.0;
    settings.shape = "bracket";
    scene_ = new synth::Scene(synth::make_object_scene(settings));
    estimate_normals(scene_->model, NormalSettings{});
    estimate_normals(scene_->scan, NormalSettings{});
    model_tree_ = new KdTree(scene_->model.positions);
    scan_tree_ = new KdTree(scene_->scan.positions);
  }
  static void TearDownTestSuite() {
    delete scan_tree_;
    delete model_tree_;
    delete scene_;
  }

  static IcpSettings settings_for(IcpMethod method) {
    IcpSettings s;
    s.method = method;
    return s;
  }

  static synth::Scene* scene_;
  static KdTree* model_tree_;
  static KdTree* scan_tree_;
};
synth::Scene* IcpScene::scene_ = nullptr;
KdTree* IcpScene::model_tree_ = nullptr;
KdTree* IcpScene::scan_tree_ = nullptr;

// Measured errors (deg, mm): point-to-point forward 0.04 / 0.013, inverse 0.08 / 0.014;
// point-to-plane forward 0.011 / 0.002, inverse 0.021 / 0.008. Bounds ~3× those.
TEST_F(IcpScene, PointToPointRecoversTheTransformForwardAndInverse) {
  const IcpSettings s = settings_for(IcpMethod::kPointToPoint);
  const IcpResult forward =
      icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
  EXPECT_TRUE(forward.converged);
  EXPECT_TRUE(is_convergence(forward.stop_reason)) << to_string(forward.stop_reason);
  const PoseError ef = pose_error(forward.T_target_source, scene_->T_model_scan);
  EXPECT_LT(ef.rotation_deg, 0.15);
  EXPECT_LT(ef.translation, 0.05);

  const IcpResult inverse =
      icp(scene_->model, scene_->scan, *scan_tree_, Eigen::Isometry3d::Identity(), s);
  EXPECT_TRUE(inverse.converged);
  const PoseError ei = pose_error(inverse.T_target_source, scene_->T_model_scan.inverse());
  EXPECT_LT(ei.rotation_deg, 0.25);
  EXPECT_LT(ei.translation, 0.05);
  EXPECT_EQ(forward.hessian, Matrix6d::Zero());  // documented: zero for point-to-point
}

TEST_F(IcpScene, PointToPlaneRecoversTheTransformForwardAndInverse) {
  const IcpSettings s = settings_for(IcpMethod::kPointToPlane);
  const IcpResult forward =
      icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
  EXPECT_TRUE(forward.converged);
  EXPECT_TRUE(is_convergence(forward.stop_reason)) << to_string(forward.stop_reason);
  const PoseError ef = pose_error(forward.T_target_source, scene_->T_model_scan);
  EXPECT_LT(ef.rotation_deg, 0.05);
  EXPECT_LT(ef.translation, 0.02);
  // Point-to-plane RMS at the solution: the noise (σ = 0.1 mm) plus the bracket's edges, where
  // independently sampled points meet the neighbouring face's plane (measured 0.155).
  EXPECT_GT(forward.rms, 0.09);
  EXPECT_LT(forward.rms, 0.2);

  const IcpResult inverse =
      icp(scene_->model, scene_->scan, *scan_tree_, Eigen::Isometry3d::Identity(), s);
  EXPECT_TRUE(inverse.converged);
  const PoseError ei = pose_error(inverse.T_target_source, scene_->T_model_scan.inverse());
  EXPECT_LT(ei.rotation_deg, 0.07);
  EXPECT_LT(ei.translation, 0.03);
  // The final system is a symmetric positive definite 6×6 (a sphere with bumps fixes all 6 dof).
  EXPECT_LT((forward.hessian - forward.hessian.transpose()).cwiseAbs().maxCoeff(),
            1e-9 * forward.hessian.cwiseAbs().maxCoeff());
  EXPECT_EQ(forward.hessian.llt().info(), Eigen::Success);
}

TEST_F(IcpScene, ExactSubsetIsRecoveredToRounding) {
  // Source = every third model point, moved by T⁻¹, no noise: at the true pose every source point
  // coincides with its target point, so both metrics reach T up to rounding.
  PointCloud source;
  const Eigen::Isometry3d T = scene_->T_model_scan;
  for (std::size_t i = 0; i < scene_->model.size(); i += 3)
    source.positions.push_back(T.inverse() * scene_->model.positions[i]);
  for (const IcpMethod method : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane}) {
    IcpSettings s = settings_for(method);
    // At the exact pose the distances are rounding (~1e-14 mm), and 2.5 × their median would cut
    // pairs at random; a floor of 0.01 mm (the chapter's rule has one for this reason) keeps all.
    s.rejection = RejectionRule::median(2.5, 0.01);
    s.termination.max_iterations = 200;
    s.termination.rms_change = 0;  // stop only when the update is negligible
    const IcpResult r = icp(source, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    EXPECT_EQ(r.stop_reason, StopReason::kTransformChange) << to_string(method);
    const PoseError e = pose_error(r.T_target_source, T);
    EXPECT_LT(e.rotation_deg, 1e-6) << to_string(method);
    EXPECT_LT(e.translation, 1e-6) << to_string(method);
    EXPECT_LT(r.rms, 1e-6) << to_string(method);
    EXPECT_EQ(r.correspondences, source.size());
  }
}

TEST_F(IcpScene, MedianRejectionKeepsAnIntruderWallOut) {
  // A wall of 20 % extra points, 15 mm beyond the scan's +x extent, with no counterpart in the
  // model. Measured: median rule 0.03° / 0.015 mm (p2p), 0.012° / 0.002 mm (p2pl); no rejection
  // 7.4° / 8.7 mm and 7.5° / 11 mm.
  Random rng(502);
  Eigen::AlignedBox3d box;
  for (const auto& p : scene_->scan.positions) box.extend(p);
  PointCloud source = scene_->scan;
  const auto wall = static_cast<int>(0.2 * static_cast<double>(scene_->scan.size()));
  for (int i = 0; i < wall; ++i) {
    const double y = rng.uniform(box.min().y(), box.max().y());
    const double z = rng.uniform(box.min().z(), box.max().z());
    source.positions.emplace_back(box.max().x() + 15, y, z);
  }
  for (const IcpMethod method : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane}) {
    IcpSettings s = settings_for(method);
    s.rejection = RejectionRule::median();
    const IcpResult robust =
        icp(source, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    s.rejection = RejectionRule::none();
    const IcpResult naive =
        icp(source, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    const PoseError er = pose_error(robust.T_target_source, scene_->T_model_scan);
    const PoseError en = pose_error(naive.T_target_source, scene_->T_model_scan);
    EXPECT_LT(er.rotation_deg, 0.15) << to_string(method);
    EXPECT_LT(er.translation, 0.05) << to_string(method);
    EXPECT_GT(en.rotation_deg, 2.0) << to_string(method);
    EXPECT_GT(en.translation, 2.0) << to_string(method);
    // The wall is rejected: kept pairs cannot exceed the object's points.
    EXPECT_LE(robust.correspondences, scene_->scan.size()) << to_string(method);
    EXPECT_EQ(naive.correspondences, source.size()) << to_string(method);
  }
}

TEST_F(IcpScene, HistoryHasOneRecordPerEvaluatedPoseWithTheRuleThreshold) {
  const std::size_t n = scene_->scan.size();
  for (const IcpMethod method : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane}) {
    IcpSettings s = settings_for(method);
    s.rejection = RejectionRule::max_distance(15.0);  // wider than the initial misalignment
    IcpResult r = icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    EXPECT_TRUE(r.converged) << to_string(method);
    ASSERT_EQ(r.history.size(), static_cast<std::size_t>(r.iterations) + 1) << to_string(method);
    for (const auto& h : r.history) {
      EXPECT_EQ(h.threshold, 15.0);
      EXPECT_LE(h.kept, n);
      EXPECT_GE(h.kept, n / 2);  // the object is in reach from the start
    }
    EXPECT_DOUBLE_EQ(r.fitness, static_cast<double>(r.correspondences) / static_cast<double>(n));

    s.rejection = RejectionRule::none();
    r = icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    ASSERT_EQ(r.history.size(), static_cast<std::size_t>(r.iterations) + 1);
    for (const auto& h : r.history) {
      EXPECT_EQ(h.threshold, kInf);
      EXPECT_EQ(h.kept, n);  // nothing rejected, every query finds a neighbour
    }
    EXPECT_EQ(r.fitness, 1.0);

    s.rejection = RejectionRule::median(2.5, 1.0);
    r = icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    ASSERT_EQ(r.history.size(), static_cast<std::size_t>(r.iterations) + 1);
    for (const auto& h : r.history) {
      EXPECT_GE(h.threshold, 1.0);  // the floor
      EXPECT_LE(h.kept, n);
    }
  }
}

TEST_F(IcpScene, FirstIterationMatchesABruteForceNearestNeighbourPass) {
  // At the initial pose: distances by brute force, the threshold = 2.5 × upper median (the
  // chapter's sorted[n/2]), kept = distances <= threshold, RMS over the kept distances.
  Eigen::Isometry3d init = Eigen::Isometry3d::Identity();
  init.linear() = so3_exp(Eigen::Vector3d(0.01, -0.02, 0.015));
  init.translation() = Eigen::Vector3d(0.5, 0.2, -0.3);
  const auto& source = scene_->scan.positions;
  const auto& target = scene_->model.positions;
  std::vector<double> distances;
  for (const auto& p : source) {
    const Eigen::Vector3d q = init * p;
    double best = kInf;
    for (const auto& t : target) best = std::min(best, (q - t).squaredNorm());
    distances.push_back(std::sqrt(best));
  }
  std::vector<double> sorted = distances;
  std::sort(sorted.begin(), sorted.end());
  const double threshold = 2.5 * sorted[sorted.size() / 2];
  std::size_t kept = 0;
  double sq_sum = 0;
  for (double d : distances) {
    if (d > threshold) continue;
    ++kept;
    sq_sum += d * d;
  }
  IcpSettings s = settings_for(IcpMethod::kPointToPoint);
  s.rejection = RejectionRule::median(2.5);
  s.termination.max_iterations = 1;
  const IcpResult r = icp(scene_->scan, scene_->model, *model_tree_, init, s);
  ASSERT_EQ(r.history.size(), 2u);  // the initial pose, then the pose after one update
  EXPECT_NEAR(r.history[0].threshold, threshold, 1e-12 * threshold);
  EXPECT_EQ(r.history[0].kept, kept);
  EXPECT_NEAR(r.history[0].rms, std::sqrt(sq_sum / static_cast<double>(kept)), 1e-12);
}

TEST_F(IcpScene, IterationCapIsNotConvergence) {
  for (const IcpMethod method : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane}) {
    IcpSettings s = settings_for(method);
    s.termination.max_iterations = 1;
    const IcpResult r =
        icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    EXPECT_EQ(r.iterations, 1) << to_string(method);
    EXPECT_EQ(r.history.size(), 2u);
    EXPECT_EQ(r.stop_reason, StopReason::kMaxIterations) << to_string(r.stop_reason);
    EXPECT_FALSE(r.converged);
    // One step did move the estimate toward the truth.
    const PoseError e = pose_error(r.T_target_source, scene_->T_model_scan);
    EXPECT_LT(e.rotation_deg, 10.0);
  }
  IcpSettings s = settings_for(IcpMethod::kPointToPlane);
  s.termination.max_iterations = 0;
  const IcpResult r =
      icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
  EXPECT_EQ(r.iterations, 0);
  ASSERT_EQ(r.history.size(), 1u);  // the initial pose is still evaluated
  EXPECT_EQ(r.rms, r.history[0].rms);
  EXPECT_EQ(r.stop_reason, StopReason::kMaxIterations);
  EXPECT_FALSE(r.converged);
  EXPECT_TRUE(r.T_target_source.isApprox(Eigen::Isometry3d::Identity()));
  s.termination.max_iterations = -3;  // a negative cap is a cap of 0, not "no cap"
  const IcpResult negative =
      icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
  EXPECT_EQ(negative.iterations, 0);
  EXPECT_EQ(negative.history.size(), 1u);
}

TEST_F(IcpScene, TooFewCorrespondencesStopsWithoutConverging) {
  // A 1 µm search radius around a start that is millimetres off: (almost) no pairs. The failed
  // attempt is recorded in the history, but no update is applied.
  for (const IcpMethod method : {IcpMethod::kPointToPoint, IcpMethod::kPointToPlane}) {
    IcpSettings s = settings_for(method);
    s.rejection = RejectionRule::max_distance(1e-3);
    const IcpResult r =
        icp(scene_->scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    EXPECT_EQ(r.stop_reason, StopReason::kTooFewCorrespondences) << to_string(method);
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(r.iterations, 0);
    ASSERT_EQ(r.history.size(), 1u);
    EXPECT_LT(r.history[0].kept, method == IcpMethod::kPointToPoint ? 3u : 6u);
    EXPECT_EQ(r.history[0].threshold, 1e-3);
    EXPECT_TRUE(r.T_target_source.isApprox(Eigen::Isometry3d::Identity()));
    EXPECT_LT(r.correspondences, 6u);
  }
}

TEST_F(IcpScene, SameBitsWithOneAndTwoThreads) {
  // 8000+ source points: several 1024-point chunks, so the reduction order is actually exercised.
  ASSERT_GT(scene_->scan.size(), 4096u);
  PointCloud scan = scene_->scan;
  estimate_normals(scan);
  for (const IcpMethod method : kAllIcpMethods) {
    IcpSettings s = settings_for(method);
    // A fixed scale, and the scale from each iteration's median residual.
    s.kernel = method == IcpMethod::kPointToPoint ? RobustKernel::kNone : RobustKernel::kCauchy;
    s.kernel_scale = method == IcpMethod::kPointToPlane ? 1.0 : 0.0;
    s.covariance = true;
    s.threads = 1;
    const IcpResult one = icp(scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    s.threads = 2;
    const IcpResult two = icp(scan, scene_->model, *model_tree_, Eigen::Isometry3d::Identity(), s);
    EXPECT_TRUE(
        (one.T_target_source.matrix().array() == two.T_target_source.matrix().array()).all())
        << to_string(method);
    EXPECT_EQ(one.iterations, two.iterations);
    EXPECT_EQ(one.rms, two.rms);
    EXPECT_EQ(one.correspondences, two.correspondences);
    EXPECT_TRUE((one.hessian.array() == two.hessian.array()).all());
    EXPECT_TRUE((one.covariance.array() == two.covariance.array()).all());
    EXPECT_GT(one.covariance.trace(), 0.0);
    ASSERT_EQ(one.history.size(), two.history.size());
    for (std::size_t i = 0; i < one.history.size(); ++i) {
      EXPECT_EQ(one.history[i].rms, two.history[i].rms);
      EXPECT_EQ(one.history[i].kept, two.history[i].kept);
      EXPECT_EQ(one.history[i].threshold, two.history[i].threshold);
    }
  }
}

TEST(IcpNormalCache, SameBitsAsWithEveryNormalEstimatedFirst) {
  // A view of ~60 % of the bracket: ICP with normals estimated on demand gives the same pose, RMS
  // and history bits as with all target normals estimated first (the oracle), with 1 and 2
  // threads, while estimating normals for only part of the target: every point that a kept pair
  // uses at the final pose (a brute-force nearest-neighbour pass) and not all of them.
  synth::ObjectSettings settings;
  settings.shape = "bracket";
  settings.overlap = 0.6;
  const synth::Scene scene = synth::make_object_scene(settings);
  PointCloud model = scene.model;
  estimate_normals(model, NormalSettings{});
  const KdTree tree(scene.model.positions);
  IcpSettings s;
  s.rejection = RejectionRule::max_distance(2.0);
  const IcpResult want = icp(scene.scan, model, tree, Eigen::Isometry3d::Identity(), s);
  ASSERT_TRUE(want.converged);
  for (int threads : {1, 2}) {
    s.threads = threads;
    NormalCache cache(scene.model, tree, NormalSettings{});
    const IcpResult got = icp(scene.scan, cache, Eigen::Isometry3d::Identity(), s);
    EXPECT_TRUE(
        (got.T_target_source.matrix().array() == want.T_target_source.matrix().array()).all());
    EXPECT_EQ(got.rms, want.rms);
    ASSERT_EQ(got.history.size(), want.history.size());
    for (std::size_t i = 0; i < got.history.size(); ++i)
      EXPECT_EQ(got.history[i].rms, want.history[i].rms);
    EXPECT_LT(cache.estimated(), scene.model.size() * 9 / 10);
    std::size_t used = 0;
    for (const auto& p : scene.scan.positions) {
      const Eigen::Vector3d q = got.T_target_source * p;
      std::size_t best = 0;
      for (std::size_t j = 1; j < scene.model.size(); ++j)
        if ((scene.model.positions[j] - q).squaredNorm() <
            (scene.model.positions[best] - q).squaredNorm())
          best = j;
      if ((scene.model.positions[best] - q).norm() > 2.0) continue;
      ++used;
      EXPECT_TRUE(cache.known(best)) << best;
    }
    EXPECT_GT(used, scene.scan.size() / 2);
  }
}

TEST_F(IcpScene, RejectsMissingNormalsAndAForeignTree) {
  PointCloud bare;
  bare.positions = scene_->model.positions;
  const KdTree bare_tree(bare.positions);
  EXPECT_THROW(icp(scene_->scan, bare, bare_tree, Eigen::Isometry3d::Identity(),
                   settings_for(IcpMethod::kPointToPlane)),
               std::invalid_argument);
  EXPECT_NO_THROW(icp(scene_->scan, bare, bare_tree, Eigen::Isometry3d::Identity(),
                      settings_for(IcpMethod::kPointToPoint)));
  EXPECT_THROW(icp(scene_->scan, scene_->model, *scan_tree_, Eigen::Isometry3d::Identity(),
                   settings_for(IcpMethod::kPointToPoint)),
               std::invalid_argument);
}

TEST(IcpRejection, ParsesValidRules) {
  RejectionRule r = parse_rejection_rule("median");
  EXPECT_EQ(r.kind, RejectionRule::Kind::kMedian);
  EXPECT_EQ(r.factor, 2.5);
  EXPECT_EQ(r.floor, 0.0);
  r = parse_rejection_rule("median:3");
  EXPECT_EQ(r.kind, RejectionRule::Kind::kMedian);
  EXPECT_EQ(r.factor, 3.0);
  EXPECT_EQ(r.floor, 0.0);
  r = parse_rejection_rule("median:2.5:0.5");
  EXPECT_EQ(r.kind, RejectionRule::Kind::kMedian);
  EXPECT_EQ(r.factor, 2.5);
  EXPECT_EQ(r.floor, 0.5);
  r = parse_rejection_rule("distance:1.5");
  EXPECT_EQ(r.kind, RejectionRule::Kind::kDistance);
  EXPECT_EQ(r.distance, 1.5);
  EXPECT_EQ(r.search_bound(), 1.5);
  r = parse_rejection_rule("none");
  EXPECT_EQ(r.kind, RejectionRule::Kind::kNone);
  EXPECT_EQ(r.search_bound(), kInf);
}

TEST(IcpRejection, RejectsBadRules) {
  for (const std::string bad : {"median:-1", "distance:", "foo", "distance:abc", "", "median:0",
                                "distance:0", "distance:-2", "median:2:-1", "median:1:2:3",
                                "none:1", "distance:1.5x", "median:nan", "distance:inf"}) {
    EXPECT_THROW(parse_rejection_rule(bad), std::invalid_argument) << "'" << bad << "'";
  }
}

TEST(IcpRejection, ToStringRoundTrips) {
  for (const std::string text : {"median:2.5", "median:3:0.5", "distance:1.5", "none"}) {
    const RejectionRule r = parse_rejection_rule(text);
    EXPECT_EQ(to_string(r), text);
    const RejectionRule back = parse_rejection_rule(to_string(r));
    EXPECT_EQ(back.kind, r.kind);
    EXPECT_EQ(back.factor, r.factor);
    EXPECT_EQ(back.floor, r.floor);
    EXPECT_EQ(back.distance, r.distance);
  }
}

TEST(IcpRejection, ThresholdOfEachRule) {
  std::vector<double> d = {4, 1, 3, 2};  // upper median (sorted[n/2]) = 3
  EXPECT_EQ(rejection_threshold(RejectionRule::median(2.5), d), 7.5);
  d = {4, 1, 3, 2, 5};  // median 3
  EXPECT_EQ(rejection_threshold(RejectionRule::median(2.0), d), 6.0);
  EXPECT_EQ(rejection_threshold(RejectionRule::median(2.0, 10.0), d), 10.0);  // the floor wins
  d.clear();
  EXPECT_EQ(rejection_threshold(RejectionRule::median(2.0, 0.7), d), 0.7);
  d = {100.0};
  EXPECT_EQ(rejection_threshold(RejectionRule::max_distance(1.25), d), 1.25);
  EXPECT_EQ(rejection_threshold(RejectionRule::none(), d), kInf);
}

// A source that overhangs the target's rim: two random samplings (σ = 0.02) of one bumpy surface,
// the target over x ∈ [0, 30], the source over [0, 40]; the truth is the identity. The overhang's
// points pair with the rim and drag point-to-point along x (measured 0.54-0.74 and 0.27-0.57° on
// three seeds); with reciprocity (IcpSettings::reciprocity, refine()'s 1) they are set aside and
// the pose stays (0.03-0.05, 0.04-0.07°). At a given pose the RMS and the pairs are those without
// it.
PointCloud bumpy_patch(double x_max, int n, Random& rng) {
  PointCloud c;
  for (int i = 0; i < n; ++i) {
    const double x = rng.uniform(0, x_max), y = rng.uniform(0, 30);
    c.positions.emplace_back(
        x, y, 2 * std::sin(0.3 * x) * std::cos(0.25 * y) + 0.1 * x + 0.02 * rng.normal());
  }
  return c;
}

// check_termination on a constructed history: a loop that repeats a state of period p (same pair
// count and RMS) stops as a cycle for every p up to kCycleLookback, not before the state repeats
// and not for a longer period; settings that would never stop otherwise (rms_change 0, no
// transform criterion).
TEST(IcpTermination, StopsAtACycleOfAnyPeriodUpToTheLookback) {
  TerminationSettings settings;
  settings.rms_change = 0;
  settings.rotation = 0;
  const Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  for (std::size_t period = 2; period <= kCycleLookback + 2; ++period) {
    std::vector<IterationRecord> history;
    std::size_t stopped_at = 0;
    StopReason reason = StopReason::kMaxIterations;
    for (std::size_t k = 0; k < 3 * period && stopped_at == 0; ++k) {
      // States 1 + k mod p: distinct within a period (RMS and pairs), equal a period apart.
      const std::size_t state = 1 + k % period;
      history.push_back({1e-4 * (1 + 1e-3 * static_cast<double>(state)), 1000 + state, 0.01});
      const double previous = k == 0 ? std::nan("") : history[k - 1].rms;
      if (check_termination(history, previous, delta, 1.0, settings, reason)) stopped_at = k;
    }
    if (period <= kCycleLookback) {
      EXPECT_EQ(stopped_at, period) << "period " << period;  // the first repeated state
      EXPECT_EQ(reason, StopReason::kCycle) << "period " << period;
    } else {
      EXPECT_EQ(stopped_at, 0u) << "period " << period;
    }
  }
}

TEST(IcpReciprocity, SetsAsideTheOverhangThatDragsPointToPointOffTheRim) {
  Random rng(1);
  const PointCloud target = bumpy_patch(30, 3000, rng);
  const PointCloud source = bumpy_patch(40, 4000, rng);
  const KdTree tree(target.positions);
  IcpSettings plain;
  plain.method = IcpMethod::kPointToPoint;
  plain.rejection = RejectionRule::max_distance(2.0);
  plain.termination.max_iterations = 200;
  IcpSettings reciprocal = plain;
  reciprocal.reciprocity = 1.0;
  reciprocal.reciprocity_floor = 0.13;  // half the target's point spacing, as refine()
  const Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  const IcpResult dragged = icp(source, target, tree, truth, plain);
  const IcpResult kept = icp(source, target, tree, truth, reciprocal);
  EXPECT_TRUE(kept.converged);
  EXPECT_LT(dragged.T_target_source.translation().x(), -0.4);  // toward the rim's inside
  EXPECT_LT(pose_error(kept.T_target_source, truth).translation, 0.1);
  EXPECT_LT(pose_error(kept.T_target_source, truth).rotation_deg, 0.15);

  plain.termination.max_iterations = reciprocal.termination.max_iterations = 0;
  const IcpResult a = icp(source, target, tree, truth, plain);
  const IcpResult b = icp(source, target, tree, truth, reciprocal);
  EXPECT_EQ(a.correspondences, b.correspondences);
  EXPECT_DOUBLE_EQ(a.rms, b.rms);
}

// Two random samplings (σ = 0.02) of one bumpy patch, the target with normals; the truth is the
// identity, the start 1° and 0.3 off it.
class IcpTangentPlanes : public ::testing::Test {
 protected:
  IcpTangentPlanes() { estimate_normals(target, NormalSettings{}); }
  Random rng{3};
  PointCloud target = bumpy_patch(30, 3000, rng);
  const PointCloud source = bumpy_patch(30, 3000, rng);
  const KdTree tree{target.positions};
  const Eigen::Isometry3d start = rigid_transform(1.0, {1, 2, 3}, {0.3, -0.2, 0.1});
};

// Point-to-point onto tangent planes (IcpSettings::tangent_planes): two random samplings (σ = 0.02)
// of one bumpy patch, the truth the identity, from 1° and 0.3 off, run to a standstill. Paired
// sample to sample, point-to-point stops where the pairs' offsets along the surface balance, off
// the truth (measured 0.17°, 0.09); paired with the feet it stops at point-to-plane's stationary
// point (icp.hpp: the same normal equations), which the noise sets (0.013°, 0.009), with its RMS.
TEST_F(IcpTangentPlanes, PointToPointStopsWherePointToPlaneDoes) {
  const Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
  IcpSettings samples;
  samples.method = IcpMethod::kPointToPoint;
  samples.rejection = RejectionRule::max_distance(2.0);
  samples.termination = {2000, 0, false, 1e-12, 1e-12};
  IcpSettings feet = samples;
  feet.tangent_planes = true;
  IcpSettings plane = samples;
  plane.method = IcpMethod::kPointToPlane;
  const IcpResult a = icp(source, target, tree, start, samples);
  const IcpResult b = icp(source, target, tree, start, feet);
  const IcpResult c = icp(source, target, tree, start, plane);
  ASSERT_TRUE(b.converged && c.converged);
  const PoseError sampled = pose_error(a.T_target_source, truth);
  const PoseError noise = pose_error(c.T_target_source, truth);
  EXPECT_GT(sampled.rotation_deg, 5 * noise.rotation_deg);
  EXPECT_LT(noise.rotation_deg, 0.03);
  EXPECT_LT(noise.translation, 0.03);
  const PoseError apart = pose_error(b.T_target_source, c.T_target_source);
  EXPECT_LT(apart.rotation_deg, 1e-4);
  EXPECT_LT(apart.translation, 1e-4);
  EXPECT_NEAR(b.rms, c.rms, 1e-6);
  EXPECT_NEAR(b.rms, 0.02 * std::sqrt(2.0), 0.01);  // two samplings' plane distance, ≈ σ√2

  PointCloud bare = target;
  bare.normals.clear();
  EXPECT_THROW(icp(source, bare, tree, start, feet), std::invalid_argument);
}

// IcpResult::pending_sigmas: how far, in the covariance's standard deviations, the returned pose
// lies from the stationary point. Point-to-point onto tangent planes stopped early (a loose RMS
// rule; its closed-form step converges linearly) must say so, within a factor 2 of the true
// distance to that point (point-to-plane run to a standstill, the same normal equations:
// IcpTangentPlanes above) in the standard deviations of the covariance there; run to a standstill
// it and point-to-plane report a small fraction of a standard deviation. The early run's
// covariance takes the shortfall in: the distance is within 1.5 of its standard deviations.
TEST_F(IcpTangentPlanes, PendingStepMeasuresTheDistanceLeftToTheStationaryPoint) {
  IcpSettings feet;
  feet.method = IcpMethod::kPointToPoint;
  feet.tangent_planes = true;
  feet.covariance = true;
  feet.rejection = RejectionRule::max_distance(2.0);
  feet.termination = {2000, 0, false, 1e-12, 1e-12};
  IcpSettings plane = feet;
  plane.method = IcpMethod::kPointToPlane;
  const IcpResult still = icp(source, target, tree, start, plane);
  const IcpResult settled = icp(source, target, tree, start, feet);
  ASSERT_TRUE(still.converged && settled.converged);
  EXPECT_LT(still.pending_sigmas, 0.01);
  EXPECT_LT(settled.pending_sigmas, 0.01);

  feet.termination = {2000, 2e-3, true, 0, 0};
  const IcpResult early = icp(source, target, tree, start, feet);
  ASSERT_TRUE(early.converged);
  const Eigen::Isometry3d left = still.T_target_source * early.T_target_source.inverse();
  const Vector6d xi = se3_log(left);
  const double distance = std::sqrt(xi.dot(still.covariance.ldlt().solve(xi)));
  const double covered = std::sqrt(xi.dot(early.covariance.ldlt().solve(xi)));
  std::printf(
      "stopped after %d updates, %.2f sigmas from the stationary point, %.2f pending, "
      "%.2f of its own covariance's\n",
      early.iterations, distance, early.pending_sigmas, covered);
  EXPECT_GT(distance, 2);
  EXPECT_GT(early.pending_sigmas, 0.5 * distance);
  EXPECT_LT(early.pending_sigmas, 2 * distance);
  EXPECT_LT(covered, 1.5);
}

}  // namespace
}  // namespace align3d
