// The stitch engine (stitch.hpp) and its steps: the pose graph (stitch/pose_graph.hpp) against
// known poses, with a wrong edge injected; the multi-view ICP (stitch/multiview_icp.hpp) from
// perturbed poses; the whole engine on generated range scans against the generator's truth.
#include "align3d/stitch.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "align3d/error.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/stitch/multiview_icp.hpp"
#include "align3d/stitch/pose_graph.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "align3d/synth/stitch_scans.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

// Truth poses of `n` nodes on a ring (node 0 the identity), each facing the ring's centre.
std::vector<Eigen::Isometry3d> ring_poses(std::size_t n) {
  std::vector<Eigen::Isometry3d> X(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double a = 360.0 * static_cast<double>(k) / static_cast<double>(n);
    X[k] = rigid_transform(
        a, Eigen::Vector3d::UnitZ(),
        Eigen::Vector3d(100 * std::cos(deg_to_rad(a)), 100 * std::sin(deg_to_rad(a)), 5.0 * k));
  }
  const Eigen::Isometry3d X0inv = X[0].inverse();
  for (auto& x : X) x = X0inv * x;
  return X;
}

// An edge s → t consistent with poses X (target ≈ T·source), perturbed by `error`.
PoseGraphEdge ring_edge(const std::vector<Eigen::Isometry3d>& X, std::size_t s, std::size_t t,
                        const Eigen::Isometry3d& error = Eigen::Isometry3d::Identity()) {
  PoseGraphEdge e;
  e.source = s, e.target = t;
  e.transformation = error * X[t].inverse() * X[s];
  e.information = 1e4 * Matrix6d::Identity();
  e.information.topLeftCorner<3, 3>() *= 1e4;  // rotation is fixed far better, as from ICP
  e.pairs = 10000;
  e.sigma = 0.1;
  e.weight = 0.5;
  return e;
}

// Every node of the ring joined to its next and its next but one: exact edges.
std::vector<PoseGraphEdge> ring_edges(const std::vector<Eigen::Isometry3d>& X) {
  std::vector<PoseGraphEdge> edges;
  for (std::size_t k = 0; k < X.size(); ++k) {
    edges.push_back(ring_edge(X, k, (k + 1) % X.size()));
    edges.push_back(ring_edge(X, k, (k + 2) % X.size()));
  }
  return edges;
}

using test::rotation_error_deg;

TEST(PoseGraph, RecoversRingPosesFromConsistentEdges) {
  const auto X = ring_poses(8);
  std::vector<PoseGraphEdge> edges = ring_edges(X);
  const PoseGraphResult r = optimize_pose_graph(8, edges, {});
  for (std::size_t k = 0; k < 8; ++k) {
    EXPECT_TRUE(r.connected[k]);
    EXPECT_LT(rotation_error_deg(r.poses[k], X[k]), 1e-6) << k;
    EXPECT_LT((r.poses[k].translation() - X[k].translation()).norm(), 1e-6) << k;
  }
  EXPECT_TRUE(std::all_of(r.kept.begin(), r.kept.end(), [](bool b) { return b; }));
}

// One edge 15° and 20 mm off, with the largest weight so the spanning tree starts from it: it is
// pruned and the others' poses are exact.
TEST(PoseGraph, PrunesAnInjectedWrongEdge) {
  const auto X = ring_poses(8);
  std::vector<PoseGraphEdge> edges = ring_edges(X);
  edges[5] = ring_edge(X, edges[5].source, edges[5].target,
                       rigid_transform(15, Eigen::Vector3d(1, 2, 3), {20, 0, 0}));
  edges[5].weight = 0.9;
  PoseGraphSettings s;
  s.robust_distance = 0.5, s.prune_rotation_deg = 1, s.prune_translation = 2;
  const PoseGraphResult r = optimize_pose_graph(8, edges, s);
  for (std::size_t e = 0; e < edges.size(); ++e) EXPECT_EQ(r.kept[e], e != 5) << e;
  for (std::size_t k = 0; k < 8; ++k) {
    EXPECT_LT(rotation_error_deg(r.poses[k], X[k]), 1e-6) << k;
    EXPECT_LT((r.poses[k].translation() - X[k].translation()).norm(), 1e-6) << k;
  }
  EXPECT_GT(r.rotation_residual_deg[5], 14.0);
}

TEST(PoseGraph, NodesNoEdgeReachesAreNotConnected) {
  const auto X = ring_poses(4);
  const PoseGraphResult r = optimize_pose_graph(4, {ring_edge(X, 0, 1), ring_edge(X, 2, 3)}, {});
  EXPECT_TRUE(r.connected[0] && r.connected[1]);
  EXPECT_FALSE(r.connected[2] || r.connected[3]);
  EXPECT_LT(rotation_error_deg(r.poses[1], X[1]), 1e-6);
}

TEST(PoseGraph, RejectsBadEdges) {
  const auto X = ring_poses(3);
  EXPECT_THROW(optimize_pose_graph(2, {ring_edge(X, 0, 2)}, {}), std::invalid_argument);
  EXPECT_THROW(optimize_pose_graph(3, {ring_edge(X, 1, 1)}, {}), std::invalid_argument);
  PoseGraphEdge nan = ring_edge(X, 0, 1);
  nan.information(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(optimize_pose_graph(3, {nan}, {}), std::invalid_argument);
}

// The test object's range scans (synth/depth_scenes.hpp) at six azimuths: scan k into scan 0's
// frame by the generator's poses.
struct Views {
  synth::ObjectViews views;
  std::vector<PointCloud> scans;
  std::vector<Eigen::Isometry3d> truth;  // scan_0 ≈ T·scan_k
};

Views ring_views(int count, double step_deg, std::uint64_t seed = 3) {
  synth::ObjectViewsSettings s;
  s.seed = seed;
  s.azimuth_deg.clear();
  for (int k = 0; k < count; ++k) s.azimuth_deg.push_back(15 + step_deg * k);
  Views v;
  v.views = synth::make_object_views(s);
  for (std::size_t k = 0; k < v.views.views.size(); ++k) {
    v.scans.push_back(v.views.views[k].valid_points());
    v.truth.push_back(v.views.T_camera_object[0] * v.views.T_camera_object[k].inverse());
  }
  return v;
}

// Each cost's Jacobians for both poses (multiview_pair_terms) against central differences of its
// residual, written here from its definition, under the left update x ← exp(ω)(x − c) + c + v
// with the normal turning by exp(ω).
TEST(MultiviewIcp, PairJacobiansMatchFiniteDifferences) {
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0, 1);
  auto vec = [&] { return Eigen::Vector3d(g(rng), g(rng), g(rng)); };
  for (IcpMethod method : kAllIcpMethods)
    for (int trial = 0; trial < 5; ++trial) {
      const Eigen::Vector3d xa = 3 * vec(), xb = xa + 0.2 * vec(), c = vec();
      const Eigen::Vector3d na = vec().normalized();
      const Eigen::Vector3d nb = (na + 0.3 * vec()).normalized();
      // The residual by its definition (multiview_icp.hpp), independent of the code under test.
      auto residual = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                          const Eigen::Vector3d& ma, const Eigen::Vector3d& mb) -> Eigen::Vector3d {
        switch (method) {
          case IcpMethod::kPointToPlane:
            return Eigen::Vector3d(mb.dot(a - b), 0, 0);
          case IcpMethod::kSymmetric:
            return Eigen::Vector3d((ma + mb).dot(a - b), 0, 0);
          default:
            return a - b;
        }
      };
      const MultiviewPairTerms t = multiview_pair_terms(method, xa, xb, na, nb, c);
      EXPECT_EQ(t.rows,
                method == IcpMethod::kPointToPlane || method == IcpMethod::kSymmetric ? 1 : 3);
      EXPECT_LT((t.e - residual(xa, xb, na, nb)).norm(), 1e-12);
      const double h = 1e-6;
      for (int j = 0; j < 6; ++j) {
        Vector6d xi = Vector6d::Zero();
        xi(j) = h;
        auto moved = [&](const Vector6d& x, const Eigen::Vector3d& p, bool normal) {
          const Eigen::Matrix3d R = so3_exp(x.head<3>());
          return normal ? Eigen::Vector3d(R * p) : Eigen::Vector3d(R * (p - c) + c + x.tail<3>());
        };
        const Eigen::Vector3d da = (residual(moved(xi, xa, false), xb, moved(xi, na, true), nb) -
                                    residual(moved(-xi, xa, false), xb, moved(-xi, na, true), nb)) /
                                   (2 * h);
        const Eigen::Vector3d db = (residual(xa, moved(xi, xb, false), na, moved(xi, nb, true)) -
                                    residual(xa, moved(-xi, xb, false), na, moved(-xi, nb, true))) /
                                   (2 * h);
        EXPECT_LT((da - t.ja.col(j)).norm(), 1e-6) << to_string(method) << " a " << j;
        EXPECT_LT((db - t.jb.col(j)).norm(), 1e-6) << to_string(method) << " b " << j;
      }
      if (method == IcpMethod::kGicp) {
        const Eigen::Matrix3d C = GicpFactor::covariance(na) + GicpFactor::covariance(nb);
        EXPECT_LT((t.M * C - Eigen::Matrix3d::Identity()).norm(), 1e-9);
      }
    }
}

// From 0.5° off (about scan 0's sensor: ~4 mm at the object) to the target, 0.1° and
// 0.1 % of the object's diameter (~200 mm), with every cost stitch() runs there (point-to-point
// it does not: stitch.hpp) and with a chosen kernel.
struct MultiviewCase {
  IcpMethod method;
  RobustKernel kernel;
};

class MultiviewMethods : public ::testing::TestWithParam<MultiviewCase> {};

TEST_P(MultiviewMethods, RecoverPosesFromPerturbedStart) {
  const Views v = ring_views(8, 45);
  std::vector<PointCloud> clouds = v.scans;
  std::vector<std::unique_ptr<KdTree>> trees;
  std::vector<MultiviewScan> scans(clouds.size());
  std::vector<Eigen::Isometry3d> start(clouds.size());
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 1);
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    trees.push_back(std::make_unique<KdTree>(clouds[k].positions));
    NormalSettings ns;
    ns.viewpoint = Eigen::Vector3d::Zero();
    estimate_normals(clouds[k], *trees.back(), ns);
    scans[k] = {&clouds[k], trees.back().get(), {}};
    for (std::uint32_t i = 0; i < clouds[k].size(); i += 3) scans[k].sample.push_back(i);
    start[k] = k == 0 ? v.truth[k]
                      : rigid_transform(0.5, Eigen::Vector3d(g(rng), g(rng), g(rng)),
                                        Eigen::Vector3d(g(rng), g(rng), g(rng)) * 0.5) *
                            v.truth[k];
  }
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (std::size_t k = 0; k < 8; ++k) links.emplace_back(k, (k + 1) % 8);
  MultiviewSettings ms;
  ms.max_distance = 4, ms.length = 150, ms.tolerance = 1e-5 * 150;  // stitch()'s
  ms.method = GetParam().method;
  ms.kernel = GetParam().kernel;
  const MultiviewResult r = multiview_icp(scans, links, start, ms);
  for (std::size_t k = 1; k < 8; ++k) {
    const PoseError after = pose_error(r.poses[k], v.truth[k]);
    EXPECT_LT(after.rotation_deg, 0.1) << k;
    EXPECT_LT(after.translation, 0.2) << k;
  }
  // Settled: it stopped before the cap, every scan's last move under the tolerance; after one
  // iteration from 0.5° off (~1.3 units at the length, 0.5 at the centre), every scan but the first
  // still moved.
  EXPECT_LT(r.iterations, ms.max_iterations);
  ASSERT_EQ(r.last_step.size(), 8u);
  for (double step : r.last_step) EXPECT_LT(step, ms.tolerance);
  ms.max_iterations = 1;
  const MultiviewResult one = multiview_icp(scans, links, start, ms);
  EXPECT_LT(one.last_step[0], 1e-9);  // held
  for (std::size_t k = 1; k < 8; ++k) EXPECT_GT(one.last_step[k], 100 * ms.tolerance) << k;
}

INSTANTIATE_TEST_SUITE_P(
    Costs, MultiviewMethods,
    ::testing::Values(MultiviewCase{IcpMethod::kPointToPlane, RobustKernel::kGemanMcClure},
                      MultiviewCase{IcpMethod::kGicp, RobustKernel::kGemanMcClure},
                      MultiviewCase{IcpMethod::kSymmetric, RobustKernel::kGemanMcClure},
                      MultiviewCase{IcpMethod::kSymmetric, RobustKernel::kHuber}),
    [](const ::testing::TestParamInfo<MultiviewCase>& info) {
      std::string name =
          std::string(to_string(info.param.method)) + "_" + to_string(info.param.kernel);
      std::replace(name.begin(), name.end(), '-', '_');
      return name;
    });

TEST(Stitch, RingOfViewsWithinATenthOfADegree) {
  const Views v = ring_views(8, 45);
  const StitchResult r = stitch(v.scans);
  ASSERT_EQ(r.scans.size(), 8u);
  for (std::size_t k = 0; k < 8; ++k) {
    ASSERT_TRUE(r.scans[k].connected) << k;
    const PoseError e = pose_error(r.scans[k].transformation, v.truth[k]);
    EXPECT_LT(e.rotation_deg, 0.1) << k;
    EXPECT_LT(e.translation, 0.001 * r.diameter) << k;
  }
  EXPECT_GT(r.merged.size(), 1000u);
  EXPECT_EQ(r.merged_scan.size(), r.merged.size());
  // Right poses: the final check finds no two scans contradicting each other.
  for (const Warning& w : r.warnings) EXPECT_NE(w.code, "inconsistent_scans") << w.message;
}

// How far scan k's stitched pose puts its points' centroid from where the truth puts it.
double centroid_miss(const StitchResult& r, const synth::StitchScans& set, std::size_t k) {
  const Eigen::Vector3d c = centroid(set.scans[k]);
  return (r.scans[k].transformation * c - set.T_first_scan[k] * c).norm();
}

// Every scan of a generated set connected, within `degrees` of its true pose and, at its points'
// centroid, within 0.1 % of the object's diameter.
void expect_every_scan_within(const StitchResult& r, const synth::StitchScans& set, double degrees,
                              bool but_leaf_and_parent = false) {
  for (std::size_t k = 0; k < set.scans.size(); ++k) {
    const auto i = static_cast<int>(k);
    if (but_leaf_and_parent && (i == set.leaf || i == set.leaf_parent)) continue;
    SCOPED_TRACE("scan " + std::to_string(k));
    ASSERT_TRUE(r.scans[k].connected);
    EXPECT_LT(pose_error(r.scans[k].transformation, set.T_first_scan[k]).rotation_deg, degrees);
    EXPECT_LT(centroid_miss(r, set, k), 0.001 * set.diameter);
  }
}

// The generated rings of synth/stitch_scans.hpp (no leaf): the box-like bracket, whose side views
// fit each other turned by a quarter or a half, and the near-symmetric keyed flange, whose views
// fit each other turned about its axis. Issue 17's target: every scan within 0.1° and, at its
// points' centroid, 0.1 % of the object's diameter of the truth.
TEST(Stitch, GeneratedRingsOfTheBracketAndTheFlangeAtTheTarget) {
  for (const auto& [object, seed] : {std::pair{synth::StitchObject::kBracket, 2},
                                     std::pair{synth::StitchObject::kKeyedFlange, 1}}) {
    synth::StitchScanSettings g;
    g.object = object;
    g.seed = seed;
    g.leaf = false;
    const synth::StitchScans set = synth::make_stitch_scans(g);
    StitchSettings s;
    s.threads = 2;
    SCOPED_TRACE(synth::to_string(object));
    expect_every_scan_within(stitch(set.scans, s), set, 0.1);
  }
}

// An object's ring as `align3d synth --scene stitch --part P --no-leaf` writes it: seed 39, float32
// coordinates.
synth::StitchScans ring_as_written(synth::StitchObject object) {
  synth::StitchScanSettings g;
  g.object = object;
  g.seed = 39;
  g.leaf = false;
  synth::StitchScans set = synth::make_stitch_scans(g);
  for (PointCloud& scan : set.scans)
    for (Eigen::Vector3d& p : scan.positions) p = p.cast<float>().cast<double>();
  return set;
}

// The keyed flange's ring as the CLI writes it (ring_as_written): its views pair turned about the
// axis, and only the lugs tell the turn. Each scan's turn within 0.05° (the noise allows σ ≈ 0.009°
// about the axis: the Fisher information of the overlapping pairs at the truth), its centroid
// within 0.1 % of the diameter. Linking only the kept edges in the multi-view ICP left half the
// ring 0.24–0.26° off about it. No scan is called ambiguous: scan 1's alternative 2.5° about the
// axis, refined, settled on the very pose its chosen one did, and was taken for another placement
// (`ambiguous_scans` on a right pose) until find_ambiguous() compared the two refined.
TEST(Stitch, KeyedFlangeRingAsWrittenWithinTheNoiseAboutItsAxis) {
  const synth::StitchScans set = ring_as_written(synth::StitchObject::kKeyedFlange);
  StitchSettings s;
  s.threads = 2;
  const StitchResult r = stitch(set.scans, s);
  expect_every_scan_within(r, set, 0.05);
  for (const Warning& w : r.warnings) EXPECT_NE(w.code, "ambiguous_scans") << w.message;
}

// The bracket's ring as the CLI writes it (ring_as_written): its side view from just above the
// floor (scan 5) fits the view across the part (scan 3) turned by a half better than the truth fits
// its two neighbours, so the pairs' scores alone put it there; refined on all the scans it covers
// far less there than at the truth (selection.cpp, settle()). Without that step it ended 180° off.
TEST(Stitch, BracketRingAsWrittenAtTheTarget) {
  const synth::StitchScans set = ring_as_written(synth::StitchObject::kBracket);
  StitchSettings s;
  s.threads = 2;
  const StitchResult r = stitch(set.scans, s);
  expect_every_scan_within(r, set, 0.1);
  for (const Warning& w : r.warnings) EXPECT_NE(w.code, "ambiguous_scans") << w.message;
}

// Whether scan k is connected more than 1° or 1 % of the diameter (at its centroid) off the truth.
bool placed_wrong(const StitchResult& r, const synth::StitchScans& set, std::size_t k) {
  return r.scans[k].connected &&
         (pose_error(r.scans[k].transformation, set.T_first_scan[k]).rotation_deg > 1 ||
          centroid_miss(r, set, k) > 0.01 * set.diameter);
}

// Whether the scan carries a warning that doubts its pose.
bool doubted(const StitchScan& scan) {
  return std::any_of(scan.warnings.begin(), scan.warnings.end(), [](const std::string& w) {
    return w == "single_edge_scan" || w == "ambiguous_scans" || w == "inconsistent_scans";
  });
}

// Never silently wrong when a part of the ring is turned as a whole: the bracket's ring with every
// view at one low elevation (25° or 15° above the horizontal instead of 50° and 25° alternating;
// the leaf's parent at 5° or 0°) sees mostly its box-like sides, whose views fit each other turned
// by a half. With the stitch as it is (2026-11-29), views 1 to 4 (25°), or 2, 3, 4, 6 and 7 (15°),
// end 90-180° off, consistent among themselves, with the rest and with free space. Each scan more
// than 1° or 1 % of the diameter off must carry a warning that doubts its pose; without
// selection.cpp's find_ambiguous_parts() none of the four (25°) and two of the five (15°) did.
TEST(Stitch, AScanTurnedWithAPartOfTheRingIsNeverSilent) {
  for (const auto& [elevation, parent] : {std::pair{25.0, 5.0}, std::pair{15.0, 0.0}}) {
    synth::StitchScanSettings g;
    g.high_elevation_deg = g.low_elevation_deg = elevation;
    g.parent_elevation_deg = parent;
    StitchSettings s;
    s.threads = 2;
    const synth::StitchScans set = synth::make_stitch_scans(g);
    const StitchResult r = stitch(set.scans, s);
    for (std::size_t k = 0; k < set.scans.size(); ++k) {
      if (placed_wrong(r, set, k)) {
        EXPECT_TRUE(doubted(r.scans[k]))
            << "elevation " << elevation << ", scan " << k << " is wrong and not doubted";
      }
    }
  }
}

// A scan that stronger candidates put elsewhere is doubted even where, so placed, it covers less
// of itself: the keyed flange with every view at 15° (the leaf's parent at 0°, no leaf). Views 2, 3
// and 4 end 160° off together (2026-11-29); view 2's right placement has candidates of 0.95 from
// its two neighbours against 0.37 where it lies, but beside the turned views 3 and 4 it covers
// 0.73 of the view against 0.86 there, and it was silent (selection.cpp, find_ambiguous()). Views
// 3 and 4 are left: no pair found their right pose (view 4 is still silent). View 2 must be at the
// truth or doubted, and no scan at the truth called ambiguous.
TEST(Stitch, AScanStrongerCandidatesPutElsewhereIsDoubted) {
  synth::StitchScanSettings g;
  g.object = synth::StitchObject::kKeyedFlange;
  g.high_elevation_deg = g.low_elevation_deg = 15;
  g.parent_elevation_deg = 0;
  g.leaf = false;
  StitchSettings s;
  s.threads = 2;
  const synth::StitchScans set = synth::make_stitch_scans(g);
  const StitchResult r = stitch(set.scans, s);
  EXPECT_TRUE(!placed_wrong(r, set, 2) || doubted(r.scans[2]));
  for (std::size_t k = 0; k < set.scans.size(); ++k) {
    const auto& w = r.scans[k].warnings;
    if (!placed_wrong(r, set, k)) {
      EXPECT_EQ(std::count(w.begin(), w.end(), "ambiguous_scans"), 0) << "scan " << k;
    }
  }
}

// Parts of the keyed flange's ring turned by its lugs' look-alike turn (125°), each scan placed by
// its own wrong pairs, while more right candidates from more scans put them where they belong:
// the rig with its leaf at seed 3, views 4 and 6 (not joined to each other on the ring, so not one
// branch of the choice's tree: no part check looked at them as one) came out 125° off with no
// warning; the ring without a leaf at seed 8, view 1 125° off with no warning, and views 2-4 pulled
// 0.28° off by it. selection.cpp's settle_parts() moves such a part back when its cut's candidates
// agree with the move more strongly, from more pairs of scans, and the move contradicts nothing
// (view 1 at seed 8 also clears a contradiction: 0.018 of it in front of the others' views where
// it lay, 0.001 moved): every ring view (the leaf and its parent aside) must then lie at the noise.
TEST(Stitch, APartOfTheRingTurnedByItsOwnWrongPairsMovesBack) {
  for (const auto& [seed, leaf] : {std::pair{3, true}, std::pair{8, false}}) {
    synth::StitchScanSettings g;
    g.object = synth::StitchObject::kKeyedFlange;
    g.seed = static_cast<std::uint64_t>(seed);
    g.leaf = leaf;
    const synth::StitchScans set = synth::make_stitch_scans(g);
    StitchSettings s;
    s.threads = 2;
    SCOPED_TRACE("seed " + std::to_string(seed));
    expect_every_scan_within(stitch(set.scans, s), set, 0.1, true);
  }
}

// The cost and kernel chosen reach every refinement: the symmetric objective with a Huber kernel
// from the noise stitches the ring to the same bar (its report names them: StitchReport tests).
TEST(Stitch, SymmetricCostWithAKernelWithinATenthOfADegree) {
  const Views v = ring_views(8, 45);
  StitchSettings s;
  s.cost.method = IcpMethod::kSymmetric;
  s.cost.kernel = RobustKernel::kHuber;
  const StitchResult r = stitch(v.scans, s);
  for (std::size_t k = 0; k < v.scans.size(); ++k) {
    ASSERT_TRUE(r.scans[k].connected) << k;
    const PoseError e = pose_error(r.scans[k].transformation, v.truth[k]);
    EXPECT_LT(e.rotation_deg, 0.1) << k;
    EXPECT_LT(e.translation, 0.001 * r.diameter) << k;
  }
}

// Shuffled input, same poses up to the first scan's frame: the relative pose of every two scans
// agrees with the unshuffled run's.
TEST(Stitch, InputOrderDoesNotMatter) {
  const Views v = ring_views(8, 45);
  const std::vector<std::size_t> order = {5, 2, 7, 0, 3, 6, 1, 4};
  std::vector<PointCloud> shuffled;
  for (std::size_t k : order) shuffled.push_back(v.scans[k]);
  const StitchResult r = stitch(shuffled);
  for (std::size_t a = 0; a < order.size(); ++a) {
    ASSERT_TRUE(r.scans[a].connected) << a;
    for (std::size_t b = 0; b < order.size(); ++b) {
      // scan order[a] ≈ T·scan order[b], from the run and from the truth
      const Eigen::Isometry3d run = r.scans[a].transformation.inverse() * r.scans[b].transformation;
      const Eigen::Isometry3d truth = v.truth[order[a]].inverse() * v.truth[order[b]];
      EXPECT_LT(pose_error(run, truth).rotation_deg, 0.1) << a << " " << b;
    }
  }
}

TEST(Stitch, RejectsUnusableInput) {
  const Views v = ring_views(2, 45);
  EXPECT_THROW(stitch({v.scans[0]}), DataError);
  std::vector<PointCloud> scans = v.scans;
  scans[1].positions[7].x() = std::numeric_limits<double>::quiet_NaN();
  try {
    stitch(scans);
    FAIL() << "a NaN was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("scan 1"), std::string::npos) << e.what();
  }
  StitchSettings s;
  s.min_overlap = 0;
  EXPECT_THROW(stitch(v.scans, s), std::invalid_argument);
  s = {};
  s.viewpoints = {Eigen::Vector3d::Zero()};
  EXPECT_THROW(stitch(v.scans, s), std::invalid_argument);
}

}  // namespace
}  // namespace align3d
