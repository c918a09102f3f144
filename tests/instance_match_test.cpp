// ADD-S and BOP's instance matching. Oracles: closed forms (a lattice moved by less than half its
// spacing is off by exactly the move; a ring of n points turned by a whole step is unmoved, by half
// a step off by its chord 2r·sin(π/2n)), invariance to the scene's frame, and a hand-worked
// matching with a duplicate, an excused little-visible instance and a pose of nothing.
#include "align3d/instance_match.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace align3d {
namespace {

// A 5 × 4 × 3 lattice of spacing s.
std::vector<Eigen::Vector3d> lattice(double s) {
  std::vector<Eigen::Vector3d> p;
  for (int x = 0; x < 5; ++x)
    for (int y = 0; y < 4; ++y)
      for (int z = 0; z < 3; ++z) p.emplace_back(s * x, s * y, s * z);
  return p;
}

// Two rings of n points, radius r, at z = 0 and z = h: symmetric under turns by 2π/n about z.
std::vector<Eigen::Vector3d> rings(int n, double r, double h) {
  std::vector<Eigen::Vector3d> p;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * std::numbers::pi * k / n;
    p.emplace_back(r * std::cos(a), r * std::sin(a), 0);
    p.emplace_back(r * std::cos(a), r * std::sin(a), h);
  }
  return p;
}

Eigen::Isometry3d pose(double angle, const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

TEST(AddS, IsExactlyTheMoveForALatticeMovedByLessThanHalfItsSpacing) {
  const AddS add_s(lattice(10));
  const Eigen::Isometry3d truth = pose(0.7, {1, 2, 3}, {100, -50, 20});
  EXPECT_NEAR(add_s(truth, truth), 0, 1e-12);
  const Eigen::Vector3d move(1, 2, 0.5);  // |move| < 5: every point's nearest is still itself
  Eigen::Isometry3d moved = truth;
  moved.translation() += truth.linear() * move;
  EXPECT_NEAR(add_s(moved, truth), move.norm(), 1e-9);
  EXPECT_NEAR(add_s(truth, moved), move.norm(), 1e-9);
}

TEST(AddS, ForgivesTurnsBySymmetryAndMeasuresHalfATurnByItsChord) {
  const int n = 12;
  const double r = 40;
  const AddS add_s(rings(n, r, 15));
  const Eigen::Isometry3d truth = pose(1.1, {0.3, -1, 0.2}, {5, 6, 700});
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  for (int k = 1; k < n; ++k)
    EXPECT_NEAR(add_s(truth * pose(2 * std::numbers::pi * k / n, z, {0, 0, 0}), truth), 0, 1e-9)
        << "turn " << k;
  const double half_step = std::numbers::pi / n;
  EXPECT_NEAR(add_s(truth * pose(half_step, z, {0, 0, 0}), truth), 2 * r * std::sin(half_step / 2),
              1e-9);
}

TEST(AddS, DoesNotDependOnTheSceneFrame) {
  const AddS add_s(lattice(7));
  const Eigen::Isometry3d a = pose(0.4, {1, 0, 1}, {3, 4, 5}), b = pose(-0.2, {0, 1, 1}, {2, 1, 0});
  const Eigen::Isometry3d G = pose(2.5, {-1, 3, 2}, {-300, 40, 1000});
  EXPECT_GT(add_s(a, b), 1);
  EXPECT_NEAR(add_s(G * a, G * b), add_s(a, b), 1e-9);
}

TEST(AddS, RefusesNoPointsAndNonFinitePoints) {
  EXPECT_THROW(AddS(std::vector<Eigen::Vector3d>{}), std::invalid_argument);
  EXPECT_THROW(AddS({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(NAN, 0, 0)}), std::invalid_argument);
}

TEST(MatchInstances, CountsADuplicateAndAPoseOfNothingAsFalseAndExcusesALittleVisibleInstance) {
  const AddS add_s(lattice(10));  // ADD-S of a move under 5 is the move's length (above)
  const Eigen::Isometry3d t0 = pose(0.3, {1, 1, 0}, {0, 0, 0});
  const Eigen::Isometry3d t1 = pose(1.3, {0, 1, 0}, {300, 0, 0});
  const Eigen::Isometry3d t2 = pose(-0.8, {1, 0, 0}, {0, 300, 0});
  const std::vector<TrueInstance> truth = {{t0, 0.9}, {t1, 0.6}, {t2, 0.3}};
  auto moved = [](Eigen::Isometry3d T, double by) {
    T.translation().x() += by;
    return T;
  };
  // Found, best score first: t0 off by 1; t0 again off by 2 (a duplicate); t2 (30 % visible);
  // a pose 500 away from every instance; t1 off by 4, beyond a max_error of 3.
  const std::vector<Eigen::Isometry3d> found = {moved(t0, 1), moved(t0, 2), moved(t2, 0.5),
                                                moved(t1, 500), moved(t1, 4)};
  const InstanceMatch m = match_instances(add_s, found, truth, 3.0);
  EXPECT_EQ(m.match, (std::vector<int>{0, -1, 2, -1, -1}));
  EXPECT_EQ(m.counted, 2u);
  EXPECT_EQ(m.true_positives, 1u);
  EXPECT_EQ(m.false_positives, 3u);
  EXPECT_EQ(m.excused, 1u);
  EXPECT_NEAR(m.error[0], 1, 1e-9);
  EXPECT_NEAR(m.error[1], 2, 1e-9);  // the nearest instance, already taken
  EXPECT_NEAR(m.error[4], 4, 1e-9);
  EXPECT_DOUBLE_EQ(m.recall(), 0.5);
  EXPECT_DOUBLE_EQ(m.precision(), 0.25);
  // With a looser criterion the last pose finds t1, and the duplicate still finds nothing.
  const InstanceMatch loose = match_instances(add_s, found, truth, 4.5);
  EXPECT_EQ(loose.match, (std::vector<int>{0, -1, 2, -1, 1}));
  EXPECT_DOUBLE_EQ(loose.recall(), 1.0);
  EXPECT_DOUBLE_EQ(loose.precision(), 2.0 / 4.0);
}

TEST(MatchInstances, GivesAFoundPoseTheNearestFreeInstance) {
  const AddS add_s(lattice(10));
  const Eigen::Isometry3d a = pose(0, {0, 0, 1}, {0, 0, 0}), b = pose(0, {0, 0, 1}, {3, 0, 0});
  const std::vector<TrueInstance> truth = {{a, 1}, {b, 1}};
  Eigen::Isometry3d near_b = b;
  near_b.translation().x() += 0.5;  // 3.5 from a, 0.5 from b: both within 4
  const InstanceMatch m = match_instances(add_s, {near_b, a}, truth, 4.0);
  EXPECT_EQ(m.match, (std::vector<int>{1, 0}));
  EXPECT_DOUBLE_EQ(m.recall(), 1.0);
  EXPECT_DOUBLE_EQ(m.precision(), 1.0);
  EXPECT_EQ(match_instances(add_s, {}, {}, 1.0).recall(), 1.0);  // an empty scene, nothing found
}

}  // namespace
}  // namespace align3d
