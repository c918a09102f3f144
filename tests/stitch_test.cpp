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

double rotation_error_deg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return pose_error(a, b).rotation_deg;
}

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

TEST(MultiviewIcp, RecoversPosesFromPerturbedStart) {
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
  ms.max_distance = 4, ms.length = 150, ms.tolerance = 1e-5;
  const MultiviewResult r = multiview_icp(scans, links, start, ms);
  // From 0.5° off (about scan 0's sensor: ~4 mm at the object) to the target: 0.1° and
  // 0.1 % of the object's diameter (~200 mm).
  for (std::size_t k = 1; k < 8; ++k) {
    const PoseError after = pose_error(r.poses[k], v.truth[k]);
    EXPECT_LT(after.rotation_deg, 0.1) << k;
    EXPECT_LT(after.translation, 0.2) << k;
  }
}

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
