// se3.hpp and the point-to-plane factor. Oracles: the cross product for skew; the matrix
// exponential's power series and Eigen's AngleAxis for so3_exp; rotations built with a known angle
// for rotation_angle; central finite differences for the Jacobian; dense JᵀWJ, JᵀWr for the sums.
#include "align3d/se3.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "align3d/icp/factors.hpp"
#include "align3d/icp/kernels.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::kPi;
using test::random_unit;
using test::random_vector;

// exp(S) = Σ Sᵏ/k!, summed until the terms vanish (|ω| <= π keeps the series well behaved).
Eigen::Matrix3d exp_series(const Eigen::Matrix3d& S) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Identity(), term = Eigen::Matrix3d::Identity();
  for (int k = 1; k < 60; ++k) {
    term = term * S / static_cast<double>(k);
    sum += term;
  }
  return sum;
}

TEST(Se3, SkewTimesVectorIsTheCrossProduct) {
  Random rng(301);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d w = random_vector(rng, -5, 5), v = random_vector(rng, -5, 5);
    EXPECT_LT((skew(w) * v - w.cross(v)).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_EQ(skew(w).transpose(), -skew(w));
  }
}

TEST(Se3, So3ExpMatchesAngleAxisAndThePowerSeries) {
  Random rng(302);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d axis = random_unit(rng);
    // Angles from 1e-9 rad to π, log-uniform so small angles are well represented.
    const double angle = std::exp(rng.uniform(std::log(1e-9), std::log(kPi)));
    const Eigen::Vector3d w = angle * axis;
    const Eigen::Matrix3d R = so3_exp(w);
    const Eigen::Matrix3d want = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    EXPECT_LT((R - want).cwiseAbs().maxCoeff(), 1e-14) << "angle " << angle;
    EXPECT_LT((R - exp_series(skew(w))).cwiseAbs().maxCoeff(), 1e-13) << "angle " << angle;
    EXPECT_LT((R * w - w).norm(), 1e-14 * (1 + angle));  // the axis is fixed
    EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
  }
  EXPECT_EQ(so3_exp(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d tiny = so3_exp(Eigen::Vector3d(1e-310, 0, 0));  // denormal: no NaN
  EXPECT_TRUE(tiny.allFinite());
  EXPECT_LT((tiny - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-300);
}

TEST(Se3, Se3ExpIsRotationAboutTheOriginThenTranslation) {
  Random rng(303);
  Vector6d twist;
  twist << random_vector(rng, -1, 1), random_vector(rng, -10, 10);
  const Eigen::Isometry3d T = se3_exp(twist);
  const Eigen::Vector3d p = random_vector(rng, -3, 3);
  EXPECT_LT((T * p - (so3_exp(twist.head<3>()) * p + twist.tail<3>())).norm(), 1e-13);
}

// se3_log inverts se3_exp for rotations below π, and gives the zero twist for the identity.
TEST(Se3, Se3LogInvertsSe3Exp) {
  Random rng(304);
  for (int k = 0; k < 20; ++k) {
    Vector6d twist;
    twist << random_vector(rng, -1.5, 1.5), random_vector(rng, -10, 10);
    EXPECT_LT((se3_log(se3_exp(twist)) - twist).norm(), 1e-12) << twist.transpose();
  }
  EXPECT_EQ(se3_log(Eigen::Isometry3d::Identity()), Vector6d::Zero());
}

TEST(Se3, RotationAngleIsAccurateNearZeroHalfPiAndPi) {
  // Rotations built from a known angle; the atan2 form keeps the angle to ~1e-15 absolute
  // everywhere (acos loses half the digits near 0 and π).
  Random rng(304);
  const double angles[] = {0.0,     1e-15,          1e-12, 1e-8,       1e-4,       0.3,
                           kPi / 2, kPi / 2 + 1e-9, 2.0,   kPi - 1e-4, kPi - 1e-8, kPi - 1e-12,
                           kPi};
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d axis = random_unit(rng);
    for (const double angle : angles) {
      const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
      const double got = rotation_angle(R);
      ASSERT_FALSE(std::isnan(got)) << "angle " << angle;
      EXPECT_GE(got, 0.0);
      EXPECT_LE(got, kPi);
      EXPECT_NEAR(got, angle, 2e-15 + 1e-12 * angle) << "angle " << angle;
    }
  }
}

TEST(Se3, RotationAngleHasNoNaNForSlightlyNonOrthonormalInput) {
  // Rounding can push tr(R) past 3 or below −1; acos would return NaN there.
  const double up = 1 + 4e-16;
  EXPECT_EQ(rotation_angle(up * Eigen::Matrix3d::Identity()), 0.0);
  const Eigen::Matrix3d half_turn = Eigen::Vector3d(up, -up, -up).asDiagonal();
  EXPECT_NEAR(rotation_angle(half_turn), kPi, 1e-15);
}

TEST(Se3, DegreeRadianConversionsRoundTrip) {
  EXPECT_DOUBLE_EQ(deg_to_rad(180), kPi);
  EXPECT_DOUBLE_EQ(rad_to_deg(kPi / 2), 90.0);
  EXPECT_DOUBLE_EQ(rad_to_deg(deg_to_rad(37.5)), 37.5);
}

TEST(Se3, PointToPlaneJacobianMatchesFiniteDifferences) {
  // r(ξ) = (exp(ω)·p + v − q)·n with ξ = (ω, v); central differences with step h have truncation
  // error O(h²·|p|) ~ 1e-11 and rounding error ~1e-16·|p|/h ~ 1e-10 for |p| <= 10.
  Random rng(305);
  const double h = 1e-6;
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::Vector3d p = random_vector(rng, -10, 10);
    const Eigen::Vector3d q = p + random_vector(rng, -1, 1);
    const Eigen::Vector3d n = random_unit(rng);
    auto r = [&](const Vector6d& xi) {
      const Eigen::Vector3d moved = so3_exp(xi.head<3>()) * p + xi.tail<3>();
      return PointToPlaneFactor::residual(moved, q, n);
    };
    EXPECT_DOUBLE_EQ(r(Vector6d::Zero()), (p - q).dot(n));
    const Vector6d J = PointToPlaneFactor::jacobian(p, n);
    for (int k = 0; k < 6; ++k) {
      Vector6d step = Vector6d::Zero();
      step(k) = h;
      const double numeric = (r(step) - r(-step)) / (2 * h);
      EXPECT_NEAR(J(k), numeric, 1e-8) << "trial " << trial << ", component " << k;
    }
  }
}

TEST(Se3, LinearSystemAccumulationEqualsDenseProducts) {
  Random rng(306);
  const int n = 200;
  Eigen::MatrixXd J(n, 6);
  Eigen::VectorXd r(n), w(n);
  LinearSystem6 system, first, second;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p = random_vector(rng, -5, 5), q = random_vector(rng, -5, 5);
    const Eigen::Vector3d normal = random_unit(rng);
    const Vector6d Ji = PointToPlaneFactor::jacobian(p, normal);
    const double ri = PointToPlaneFactor::residual(p, q, normal);
    const double wi = rng.uniform(0, 2);
    J.row(i) = Ji.transpose();
    r(i) = ri;
    w(i) = wi;
    system.add(Ji, ri, wi);
    (i % 3 == 0 ? first : second).add(Ji, ri, wi);
  }
  const Eigen::MatrixXd H = J.transpose() * w.asDiagonal() * J;
  const Eigen::VectorXd b = J.transpose() * w.asDiagonal() * r;
  const double sq_error = r.dot(w.asDiagonal() * r);
  // Sums of 200 terms of size <= ~50: agreement to ~1e-12 relative.
  const double scale = H.cwiseAbs().maxCoeff();
  EXPECT_LT((system.H - H).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_LT((system.b - b).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_NEAR(system.sq_error, sq_error, 1e-12 * sq_error);
  EXPECT_NEAR(system.sum_w, w.sum(), 1e-12 * w.sum());
  EXPECT_LT((system.H - system.H.transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale);

  LinearSystem6 joined = first;
  joined += second;
  EXPECT_LT((joined.H - H).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_LT((joined.b - b).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_NEAR(joined.sq_error, sq_error, 1e-12 * sq_error);
  EXPECT_NEAR(joined.sum_w, w.sum(), 1e-12 * w.sum());
}

TEST(Se3, GaussNewtonStepRecoversASmallMotionOnPlanarPairs) {
  // Pairs with q = exp(ξ)·p and random normals: one solve of H·x = −b gives, to first order,
  // the motion that brings p onto the planes, i.e. x ≈ ξ, with error O(|ξ|²) ~ 1e-6.
  Random rng(307);
  Vector6d xi;
  xi << 1e-3 * random_unit(rng), 1e-3 * random_unit(rng);
  LinearSystem6 system;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p = random_vector(rng, -1, 1);
    const Eigen::Vector3d q = se3_exp(xi) * p;
    const Eigen::Vector3d n = random_unit(rng);
    system.add(PointToPlaneFactor::jacobian(p, n), PointToPlaneFactor::residual(p, q, n), 1.0);
  }
  const Vector6d x = system.H.ldlt().solve(-system.b);
  EXPECT_LT((x - xi).cwiseAbs().maxCoeff(), 1e-5);
}

// Ad(T) carries a left perturbation across T: T·exp(ξ)·T⁻¹ = exp(Ad(T)·ξ) to first order in ξ (the
// residual is O(|ξ|²)), and a covariance with it.
TEST(Se3, AdjointConjugatesAPerturbation) {
  const Eigen::Isometry3d T = rigid_transform(37, {1, -2, 0.5}, {40, -25, 12});
  Vector6d xi;
  xi << 0.3, -0.2, 0.1, 0.5, 0.4, -0.7;
  for (double h : {1e-3, 1e-4}) {
    const Eigen::Isometry3d lhs = T * se3_exp(h * xi) * T.inverse();
    const Eigen::Isometry3d rhs = se3_exp(h * (adjoint(T) * xi));
    EXPECT_LT((lhs.matrix() - rhs.matrix()).norm(), 100 * h * h) << h;
    EXPECT_GT((lhs.matrix() - Eigen::Isometry3d::Identity().matrix()).norm(), h * 0.1);
  }
}

// Each kernel's weight is ρ'(d)/d (kernels.hpp): checked against a central difference of ρ, at
// residuals on both sides of the scale and of both signs, and ρ is even, zero at 0 and rising.
TEST(Kernels, WeightIsTheDerivativeOfRhoOverD) {
  const double c = 0.7;
  for (RobustKernel k : kAllKernels) {
    SCOPED_TRACE(to_string(k));
    EXPECT_EQ(kernel_rho(k, 0.0, c), 0.0);
    EXPECT_EQ(kernel_weight(k, 0.0, c), 1.0);  // every kernel is least squares near 0
    double previous = 0;
    for (double d : {0.01, 0.1, 0.35, 0.69, 0.71, 1.0, 2.0, 5.0}) {
      const double h = 1e-6;
      const double derivative = (kernel_rho(k, d + h, c) - kernel_rho(k, d - h, c)) / (2 * h);
      EXPECT_NEAR(kernel_weight(k, d, c), derivative / d, 1e-6);
      EXPECT_EQ(kernel_weight(k, -d, c), kernel_weight(k, d, c));
      EXPECT_EQ(kernel_rho(k, -d, c), kernel_rho(k, d, c));
      EXPECT_GE(kernel_rho(k, d, c), previous);
      previous = kernel_rho(k, d, c);
    }
  }
}

// Closed forms at chosen points, and scale <= 0 is plain least squares.
TEST(Kernels, ClosedForms) {
  EXPECT_DOUBLE_EQ(kernel_weight(RobustKernel::kGemanMcClure, 2.0, 2.0), 0.25);   // (1 + 1)^−2
  EXPECT_DOUBLE_EQ(kernel_weight(RobustKernel::kGemanMcClure, -6.0, 2.0), 0.01);  // (1 + 9)^−2
  EXPECT_DOUBLE_EQ(kernel_weight(RobustKernel::kHuber, 4.0, 2.0), 0.5);           // c / |d|
  EXPECT_DOUBLE_EQ(kernel_weight(RobustKernel::kCauchy, 2.0, 2.0), 0.5);          // 1 / (1 + 1)
  EXPECT_DOUBLE_EQ(kernel_weight(RobustKernel::kTukey, 1.0, 2.0), 0.5625);        // (1 − ¼)²
  EXPECT_EQ(kernel_weight(RobustKernel::kTukey, 2.5, 2.0), 0.0);                  // beyond c: 0
  EXPECT_DOUBLE_EQ(kernel_weight(RobustKernel::kWelsch, 2.0, 2.0), std::exp(-1.0));
  EXPECT_DOUBLE_EQ(kernel_rho(RobustKernel::kTukey, 9.0, 3.0), 1.5);  // c²/6 beyond c
  for (RobustKernel k : kAllKernels) {
    EXPECT_EQ(kernel_weight(k, 123.0, 0.0), 1.0);
    EXPECT_EQ(kernel_weight(k, 123.0, -1.0), 1.0);
    EXPECT_EQ(kernel_from_string(to_string(k)), k);
  }
  EXPECT_EQ(kernel_from_string("gm"), std::nullopt);
}

}  // namespace
}  // namespace align3d
