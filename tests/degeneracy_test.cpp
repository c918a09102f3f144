// Degeneracy (icp/degeneracy.hpp): geometry that leaves pose directions free must not let the
// point-to-plane estimate drift along them, and the free directions must be reported.
#include "align3d/icp/degeneracy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "align3d/icp/icp.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/normals.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

// Closed form: for a diagonal H the eigenvectors are the axes; a candidate without aligned support
// is free (no step along it), with support it takes the full Gauss-Newton step rhs_i / H_ii.
TEST(SolveConstrained, DiagonalSystemStepsOnlyAlongHeldDirections) {
  Vector6d d;
  d << 400, 400, 1e-3, 1, 1, 1e-4;
  const Matrix6d H = d.asDiagonal();
  Vector6d rhs;
  rhs << 4, -8, 0.5, 1, 2, -3;
  const SystemAnalysis a = analyse_system(H);
  ASSERT_TRUE(a.usable);
  // Candidates: the ω_z axis and the v_z axis (both far below 1 % of the largest eigenvalue).
  int candidates = 0;
  for (int i = 0; i < 6; ++i) candidates += a.candidate(i);
  EXPECT_EQ(candidates, 2);
  const ConstrainedSolve unheld = solve_constrained(a, rhs, Vector6d::Zero());
  Vector6d expected;
  expected << 4 / 400.0, -8 / 400.0, 0, 1, 2, 0;
  EXPECT_LT((unheld.x - expected).norm(), 1e-12);
  ASSERT_EQ(unheld.weak.size(), 2u);
  // Weakest first: ω_z (1e-3 / L², L² = tr(H_ωω) / tr(H_vv) ≈ 400), then v_z (1e-4).
  EXPECT_NEAR(std::abs(unheld.weak[0].rotation.z()), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(unheld.weak[1].translation.z()), 1.0, 1e-12);
  // Fully held by aligned pairs: the plain solution H⁻¹·rhs.
  const ConstrainedSolve held = solve_constrained(a, rhs, a.values);
  EXPECT_TRUE(held.weak.empty());
  EXPECT_LT((held.x - rhs.cwiseQuotient(d)).norm(), 1e-9 * rhs.cwiseQuotient(d).norm());
}

TEST(SolveConstrained, ZeroSystemMovesNothingAndReportsAllSix) {
  const SystemAnalysis a = analyse_system(Matrix6d::Zero());
  EXPECT_FALSE(a.usable);
  const ConstrainedSolve s = solve_constrained(a, Vector6d::Ones(), Vector6d::Zero());
  EXPECT_EQ(s.x, Vector6d::Zero());
  EXPECT_EQ(s.weak.size(), 6u);
}

// Noisy samples of surfaces, with target normals estimated from the noisy points (so the free
// directions are weak, not exactly zero, as on real scans).
PointCloud sample(int n, Random& rng, double sigma,
                  const std::function<Eigen::Vector3d(Random&)>& draw) {
  PointCloud c;
  for (int i = 0; i < n; ++i)
    c.positions.push_back(draw(rng) +
                          sigma * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()));
  return c;
}

struct Outcome {
  IcpResult result;
  Eigen::Isometry3d init;
};

// Source = target geometry sampled afresh, moved by `init`⁻¹ (so `init` is a perfect pose) and
// then started from `init` composed with `offset`: the pose error to remove is `offset`.
// `s`: the run's settings (point-to-plane by default).
Outcome run(const std::function<Eigen::Vector3d(Random&)>& draw, const Eigen::Isometry3d& offset,
            IcpSettings s = {}) {
  Random rng(5);
  PointCloud target = sample(20000, rng, 0.05, draw);
  const KdTree tree(target.positions);
  estimate_normals(target, tree);
  PointCloud source = sample(15000, rng, 0.05, draw);
  s.rejection = RejectionRule::max_distance(10);
  s.termination.max_iterations = 100;
  Outcome out;
  out.init = offset;
  out.result = icp(source, target, tree, offset, s);
  return out;
}

Eigen::Vector3d on_plane(Random& rng) { return {rng.uniform(-100, 100), rng.uniform(-75, 75), 0}; }

double yaw_deg(const Eigen::Isometry3d& T) {
  const Eigen::Vector3d x = T.linear() * Eigen::Vector3d::UnitX();
  return rad_to_deg(std::atan2(x.y(), x.x()));
}

// Reported: a plane's two translations and the turn about its normal (z).
void expect_plane_directions(const IcpResult& r) {
  ASSERT_EQ(r.degenerate_directions.size(), 3u);
  Eigen::Vector3d rot = Eigen::Vector3d::Zero(), trans = Eigen::Vector3d::Zero();
  for (const auto& w : r.degenerate_directions) {
    rot += w.rotation.cwiseAbs2();
    trans += w.translation.cwiseAbs2();
  }
  EXPECT_NEAR(rot.z(), 1.0, 1e-3);
  EXPECT_NEAR(trans.x() + trans.y(), 2.0, 1e-3);
}

// The tilt and the height off the plane (z = 0) removed, a 5° yaw and the in-plane shift of
// `free_part` kept.
void expect_held_directions_fixed(const IcpResult& r, const Eigen::Isometry3d& free_part) {
  const Eigen::Isometry3d& T = r.T_target_source;
  EXPECT_LT(std::acos(std::min(1.0, (T.linear() * Eigen::Vector3d::UnitZ()).z())),
            deg_to_rad(0.01));
  EXPECT_LT(std::abs(T.translation().z()), 0.01);
  EXPECT_NEAR(yaw_deg(T), 5.0, 0.01);
  EXPECT_LT((T.translation() - free_part.translation()).head<2>().norm(), 0.1);
}

// Started off only along the free directions, the pose must stay put: without the guard the noise
// in the normals pulls it millimetres away along the plane.
TEST(Degeneracy, SinglePlaneStartedAlongTheFreeDirectionsStaysPut) {
  const Eigen::Isometry3d start = rigid_transform(5, {0, 0, 1}, {4, -3, 0});
  const Outcome o = run(on_plane, start);
  const Eigen::Isometry3d& T = o.result.T_target_source;
  EXPECT_LT((T.translation() - start.translation()).norm(), 0.01);
  EXPECT_LT(test::rotation_error_deg(T, start), 0.005);
  expect_plane_directions(o.result);
}

// With a tilt and a height error as well, those are removed and the yaw is kept. (The in-plane
// position moves by tilt × the height of the rotation centre, a consequence of removing the tilt
// about the target centroid, not a drift: at most 2° × 1 mm here.)
TEST(Degeneracy, SinglePlaneFixesTiltAndHeightAndKeepsTheYaw) {
  const Eigen::Isometry3d free_part = rigid_transform(5, {0, 0, 1}, {4, -3, 0});
  const Eigen::Isometry3d offset = rigid_transform(2, {1, 0.5, 0}, {0, 0, 1.5}) * free_part;
  const Outcome o = run(on_plane, offset);
  expect_held_directions_fixed(o.result, free_part);
  expect_plane_directions(o.result);
}

// Point-to-point's closed-form step analyses no system, but onto the target's surface (tangent
// planes of a point cloud, or a mesh's triangles) each residual lies along its partner's normal:
// the step removes the tilt and the height without moving along the plane, and point-to-plane's
// system of its pairs reports the three free directions.
void expect_point_to_point_on_plane(const IcpResult& r, const Eigen::Isometry3d& free_part) {
  expect_held_directions_fixed(r, free_part);
  expect_plane_directions(r);
}

TEST(Degeneracy, PointToPointOntoTangentPlanesReportsThePlanesFreeDirections) {
  const Eigen::Isometry3d free_part = rigid_transform(5, {0, 0, 1}, {4, -3, 0});
  const Eigen::Isometry3d offset = rigid_transform(2, {1, 0.5, 0}, {0, 0, 1.5}) * free_part;
  IcpSettings s;
  s.method = IcpMethod::kPointToPoint;
  s.tangent_planes = true;
  expect_point_to_point_on_plane(run(on_plane, offset, s).result, free_part);
  // Sample to sample it analyses no system.
  s.tangent_planes = false;
  EXPECT_TRUE(run(on_plane, offset, s).result.degenerate_directions.empty());
}

TEST(Degeneracy, PointToPointOntoAMeshPlaneReportsItsFreeDirections) {
  TriangleMesh plane;
  plane.vertices = {{-120, -90, 0}, {120, -90, 0}, {120, 90, 0}, {-120, 90, 0}};
  plane.triangles = {{0, 1, 2}, {0, 2, 3}};
  const MeshIndex surface(plane);
  Random rng(5);
  const PointCloud source = sample(15000, rng, 0.05, on_plane);
  const Eigen::Isometry3d free_part = rigid_transform(5, {0, 0, 1}, {4, -3, 0});
  const Eigen::Isometry3d offset = rigid_transform(2, {1, 0.5, 0}, {0, 0, 1.5}) * free_part;
  IcpSettings s;
  s.method = IcpMethod::kPointToPoint;
  s.rejection = RejectionRule::max_distance(10);
  s.termination.max_iterations = 100;
  expect_point_to_point_on_plane(icp(source, surface, offset, s), free_part);
}

TEST(Degeneracy, TwoParallelPlanesAreAsFreeAsOne) {
  auto two = [](Random& rng) {
    Eigen::Vector3d p = on_plane(rng);
    if (rng.uniform() < 0.5) p.z() = 40;
    return p;
  };
  const Eigen::Isometry3d start = rigid_transform(-4, {0, 0, 1}, {-3, 6, 0});
  const Outcome o = run(two, start);
  EXPECT_LT((o.result.T_target_source.translation() - start.translation()).norm(), 0.01);
  EXPECT_LT(test::rotation_error_deg(o.result.T_target_source, start), 0.005);
  EXPECT_EQ(o.result.degenerate_directions.size(), 3u);
}

TEST(Degeneracy, CylinderKeepsItsAxialShiftAndSpin) {
  auto cylinder = [](Random& rng) {
    const double phi = rng.uniform(0, deg_to_rad(360));
    return Eigen::Vector3d(30 * std::cos(phi), 30 * std::sin(phi), rng.uniform(-100, 100));
  };
  // Error to remove: 1° tilt and 1 mm off the axis; free: 8 mm along the axis, 10° about it.
  const Eigen::Isometry3d free_part = rigid_transform(10, {0, 0, 1}, {0, 0, 8});
  const Eigen::Isometry3d offset = rigid_transform(1, {1, 0, 0}, {1, 0, 0}) * free_part;
  const Outcome o = run(cylinder, offset);
  const Eigen::Isometry3d& T = o.result.T_target_source;
  EXPECT_LT(std::acos(std::min(1.0, (T.linear() * Eigen::Vector3d::UnitZ()).z())),
            deg_to_rad(0.02));
  EXPECT_LT(T.translation().head<2>().norm(), 0.02);
  EXPECT_NEAR(T.translation().z(), 8.0, 0.05);
  EXPECT_NEAR(yaw_deg(T), 10.0, 0.05);
  EXPECT_EQ(o.result.degenerate_directions.size(), 2u);
}

TEST(Degeneracy, BoxCornerIsFullyConstrained) {
  auto corner = [](Random& rng) {  // three orthogonal faces of a 100 mm cube
    const double u = rng.uniform(0, 100), v = rng.uniform(0, 100);
    const int face = static_cast<int>(rng.uniform(0, 3));
    return face == 0   ? Eigen::Vector3d(u, v, 0)
           : face == 1 ? Eigen::Vector3d(u, 0, v)
                       : Eigen::Vector3d(0, u, v);
  };
  const Eigen::Isometry3d offset = rigid_transform(3, {1, 2, 3}, {2, -1, 1.5});
  const Outcome o = run(corner, offset);
  EXPECT_TRUE(o.result.degenerate_directions.empty());
  EXPECT_LT(test::rotation_error_deg(o.result.T_target_source, Eigen::Isometry3d::Identity()),
            0.02);
  EXPECT_LT(test::translation_error(o.result.T_target_source, Eigen::Isometry3d::Identity()), 0.02);
}

}  // namespace
}  // namespace align3d
