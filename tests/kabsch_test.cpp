// Kabsch / Umeyama. Oracles: exact recovery of a known rigid transform from noise-free pairs; the
// unique proper rotation for a mirrored planar configuration; local optimality (no nearby rotation
// does better); a 0/1-weighted problem equals the subset problem; the polar decomposition
// M = R·S (S symmetric positive definite) for nearest_rotation.
#include "align3d/kabsch.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include "align3d/se3.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

// Uniform on SO(3): a normalised 4-vector of independent Gaussians is uniform on S³.
Eigen::Matrix3d random_rotation(Random& rng) {
  const double w = rng.normal(), x = rng.normal(), y = rng.normal(), z = rng.normal();
  return Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
}

using test::random_vector;

std::vector<Eigen::Vector3d> random_points(std::size_t n, Random& rng,
                                           const Eigen::Vector3d& offset, double half_size) {
  std::vector<Eigen::Vector3d> points;
  for (std::size_t i = 0; i < n; ++i)
    points.push_back(offset + random_vector(rng, -half_size, half_size));
  return points;
}

std::vector<Eigen::Vector3d> moved_by(const Eigen::Isometry3d& T,
                                      const std::vector<Eigen::Vector3d>& p) {
  std::vector<Eigen::Vector3d> q;
  for (const auto& x : p) q.push_back(T * x);
  return q;
}

double cost(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
            const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& q) {
  double sum = 0;
  for (std::size_t i = 0; i < p.size(); ++i) sum += (R * p[i] + t - q[i]).squaredNorm();
  return sum;
}

using test::expect_proper_rotation;

TEST(Kabsch, RecoversRandomRigidTransformsExactly) {
  Random rng(201);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = random_rotation(rng);
    T.translation() = random_vector(rng, -10, 10);
    const auto p = random_points(3 + rng.below(60), rng, Eigen::Vector3d::Zero(), 1.0);
    const auto q = moved_by(T, p);
    const Eigen::Isometry3d est = kabsch(p, q);
    // Noise-free data: only rounding (~1e-15 on unit-size coordinates) separates est from T.
    EXPECT_LT((est.linear() - T.linear()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
    EXPECT_LT((est.translation() - T.translation()).cwiseAbs().maxCoeff(), 1e-9)
        << "trial " << trial;
    expect_proper_rotation(est.linear());
  }
}

TEST(Kabsch, RecoversTransformsOfDataFarFromTheOrigin) {
  // Points within ±10 of an offset of 1e4 on every axis. Coordinates ~1e4 carry rounding of
  // ~1e-12, so the rotation comes out exact to ~1e-13 and mapped points to ~1e-11. The translation
  // t = q̄ − R·p̄ inherits the rotation's error times the lever arm |p̄| ~ 1.7e4: measured 1.5e-9
  // here (3.6e-10 even when p and q are centred on their own means), so it is bounded relative to
  // |p̄|, at 1e-12·|p̄| ~ 1.7e-8.
  Random rng(202);
  const Eigen::Vector3d offset(1e4, -1e4, 1e4);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = random_rotation(rng);
    T.translation() = random_vector(rng, -5, 5);
    const auto p = random_points(100, rng, offset, 10.0);
    const auto q = moved_by(T, p);
    const Eigen::Isometry3d est = kabsch(p, q);
    EXPECT_LT((est.linear() - T.linear()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
    EXPECT_LT((est.translation() - T.translation()).cwiseAbs().maxCoeff(), 1e-12 * offset.norm())
        << "trial " << trial;
    for (std::size_t i = 0; i < p.size(); ++i) EXPECT_LT((est * p[i] - q[i]).norm(), 1e-9);
    expect_proper_rotation(est.linear());
  }
}

TEST(Kabsch, MirroredPlanarPointsGiveTheProperRotationNotTheReflection) {
  // p lies in the plane z = 0 and q is p mirrored in x (x → −x). H = Σ p qᵀ has rank 2 and the
  // unguarded V·Uᵀ is the mirror diag(−1, 1, 1) (det −1). The only proper rotation that maps this
  // p onto q is diag(−1, 1, −1) (a half turn about y), and it does so exactly. Both clouds are then
  // moved by random rigid transforms A and B, so the answer is T = B·diag(−1, 1, −1)·A⁻¹.
  Random rng(203);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<Eigen::Vector3d> p_plane, q_plane;
    for (int i = 0; i < 30; ++i) {
      const double x = rng.uniform(-1, 1), y = rng.uniform(-1, 1);
      p_plane.emplace_back(x, y, 0);
      q_plane.emplace_back(-x, y, 0);
    }
    // The configuration does provoke a reflection in the unguarded solution.
    Eigen::Vector3d p_bar = Eigen::Vector3d::Zero(), q_bar = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < p_plane.size(); ++i) {
      p_bar += p_plane[i] / 30.0;
      q_bar += q_plane[i] / 30.0;
    }
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < p_plane.size(); ++i)
      H += (p_plane[i] - p_bar) * (q_plane[i] - q_bar).transpose();
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    ASSERT_LT((svd.matrixV() * svd.matrixU().transpose()).determinant(), 0) << "trial " << trial;

    Eigen::Isometry3d A = Eigen::Isometry3d::Identity(), B = Eigen::Isometry3d::Identity();
    A.linear() = random_rotation(rng);
    A.translation() = random_vector(rng, -3, 3);
    B.linear() = random_rotation(rng);
    B.translation() = random_vector(rng, -3, 3);
    Eigen::Isometry3d half_turn = Eigen::Isometry3d::Identity();
    half_turn.linear() = Eigen::Vector3d(-1, 1, -1).asDiagonal();
    const Eigen::Isometry3d expected = B * half_turn * A.inverse();

    for (const bool moved : {false, true}) {
      const auto p = moved ? moved_by(A, p_plane) : p_plane;
      const auto q = moved ? moved_by(B, q_plane) : q_plane;
      const Eigen::Isometry3d want = moved ? expected : half_turn;
      const Eigen::Isometry3d est = kabsch(p, q);
      expect_proper_rotation(est.linear());
      EXPECT_LT((est.linear() - want.linear()).cwiseAbs().maxCoeff(), 1e-9) << "trial " << trial;
      EXPECT_LT((est.translation() - want.translation()).cwiseAbs().maxCoeff(), 1e-9);
      for (std::size_t i = 0; i < p.size(); ++i) EXPECT_LT((est * p[i] - q[i]).norm(), 1e-9);
    }
  }
}

TEST(Kabsch, PointReflectedCloudGivesTheBestProperRotation) {
  // q = −p (a point reflection, det −1) of a generic 3D cloud: no rotation fits, the result must
  // still be a rotation and no nearby rotation may have a lower cost (local optimality).
  Random rng(204);
  const auto p = random_points(40, rng, Eigen::Vector3d::Zero(), 1.0);
  std::vector<Eigen::Vector3d> q;
  for (const auto& x : p) q.push_back(-x);
  const Eigen::Isometry3d est = kabsch(p, q);
  expect_proper_rotation(est.linear());
  const double best = cost(est.linear(), est.translation(), p, q);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d w = random_vector(rng, -1, 1).normalized() * rng.uniform(1e-4, 0.3);
    const Eigen::Matrix3d R = so3_exp(w) * est.linear();
    // For fixed R the best t is q̄ − R·p̄; compare against that.
    Eigen::Vector3d p_bar = Eigen::Vector3d::Zero(), q_bar = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < p.size(); ++j) {
      p_bar += p[j];
      q_bar += q[j];
    }
    p_bar /= static_cast<double>(p.size());
    q_bar /= static_cast<double>(p.size());
    EXPECT_GE(cost(R, q_bar - R * p_bar, p, q), best - 1e-12) << "a nearby rotation is better";
  }
}

TEST(Kabsch, ZeroOneWeightsEqualTheSubsetSolution) {
  // Noisy pairs so that the solution depends on which pairs are used.
  Random rng(205);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = random_rotation(rng);
  T.translation() = random_vector(rng, -2, 2);
  const auto p = random_points(80, rng, Eigen::Vector3d(3, 1, -2), 1.0);
  std::vector<Eigen::Vector3d> q = moved_by(T, p);
  for (auto& x : q) x += 0.05 * random_vector(rng, -1, 1);
  std::vector<double> weights;
  std::vector<Eigen::Vector3d> p_sub, q_sub;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const bool keep = rng.uniform() < 0.5;
    weights.push_back(keep ? 1.0 : 0.0);
    if (keep) {
      p_sub.push_back(p[i]);
      q_sub.push_back(q[i]);
    }
  }
  const Eigen::Isometry3d weighted = kabsch(p, q, weights);
  const Eigen::Isometry3d subset = kabsch(p_sub, q_sub);
  const Eigen::Isometry3d all = kabsch(p, q);
  EXPECT_LT((weighted.matrix() - subset.matrix()).cwiseAbs().maxCoeff(), 1e-12);
  // ... and the weights matter: the unweighted solution differs.
  EXPECT_GT((weighted.matrix() - all.matrix()).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(Kabsch, IntegerWeightsEqualRepeatedPairs) {
  Random rng(206);
  const auto p = random_points(30, rng, Eigen::Vector3d::Zero(), 1.0);
  std::vector<Eigen::Vector3d> q;
  for (const auto& x : p) q.push_back(x + 0.1 * random_vector(rng, -1, 1));  // no exact solution
  std::vector<double> weights;
  std::vector<Eigen::Vector3d> p_rep, q_rep;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto times = 1 + rng.below(3);
    weights.push_back(static_cast<double>(times));
    for (std::uint64_t k = 0; k < times; ++k) {
      p_rep.push_back(p[i]);
      q_rep.push_back(q[i]);
    }
  }
  EXPECT_LT((kabsch(p, q, weights).matrix() - kabsch(p_rep, q_rep).matrix()).cwiseAbs().maxCoeff(),
            1e-12);
}

TEST(Kabsch, AccumulatorOfTwoHalvesEqualsTheWhole) {
  Random rng(207);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = random_rotation(rng);
  T.translation() = random_vector(rng, -1, 1);
  const auto p = random_points(101, rng, Eigen::Vector3d::Zero(), 1.0);
  auto q = moved_by(T, p);
  for (auto& x : q) x += 0.01 * random_vector(rng, -1, 1);
  KabschAccumulator whole, first, second;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double w = rng.uniform(0.5, 2.0);
    whole.add(p[i], q[i], w);
    (i < 50 ? first : second).add(p[i], q[i], w);
  }
  KabschAccumulator joined = first;
  joined += second;
  // Only the summation order differs: agreement to rounding (sums are O(100)).
  EXPECT_NEAR(joined.sum_w, whole.sum_w, 1e-12);
  EXPECT_LT((joined.sum_p - whole.sum_p).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((joined.sum_q - whole.sum_q).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((joined.sum_pq - whole.sum_pq).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((solve_kabsch(joined).matrix() - solve_kabsch(whole).matrix()).cwiseAbs().maxCoeff(),
            1e-12);
}

TEST(Kabsch, RejectsInvalidInput) {
  KabschAccumulator empty;
  EXPECT_THROW(solve_kabsch(empty), std::invalid_argument);
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  const std::vector<Eigen::Vector3d> three = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(kabsch(two, three), std::invalid_argument);
  EXPECT_THROW(kabsch({}, {}), std::invalid_argument);
  EXPECT_THROW(kabsch(three, three, {1.0, 1.0}), std::invalid_argument);
  EXPECT_THROW(kabsch(three, three, {0.0, 0.0, 0.0}), std::invalid_argument);  // total weight 0
}

TEST(Kabsch, NearestRotationUndoesASymmetricPerturbation) {
  // Polar decomposition: for M = R·S with S symmetric positive definite, R is the nearest rotation.
  Random rng(208);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Matrix3d R = random_rotation(rng);
    Eigen::Matrix3d E;
    for (int i = 0; i < 9; ++i) E(i / 3, i % 3) = rng.uniform(-1, 1);
    const double eps = trial < 25 ? 1e-6 : 0.2;
    const Eigen::Matrix3d S = Eigen::Matrix3d::Identity() + eps * (E + E.transpose()) / 2;
    const Eigen::Matrix3d N = nearest_rotation(R * S);
    expect_proper_rotation(N);
    EXPECT_LT((N - R).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
  }
}

TEST(Kabsch, NearestRotationOfANearReflectionIsProper) {
  // R·diag(1, 1, −ε) has det < 0; its nearest rotation is R (flip the smallest singular value).
  Random rng(209);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d R = random_rotation(rng);
    const Eigen::Matrix3d N = nearest_rotation(R * Eigen::Vector3d(1, 1, -0.1).asDiagonal());
    expect_proper_rotation(N);
    EXPECT_LT((N - R).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
    EXPECT_LT((nearest_rotation(R) - R).cwiseAbs().maxCoeff(), 1e-14);
  }
}

}  // namespace
}  // namespace align3d
