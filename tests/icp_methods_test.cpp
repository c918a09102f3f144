// GICP and symmetric ICP (factors.hpp), robust kernels in the loop (kernels.hpp) and the pose
// covariance (solver.hpp): Jacobians against finite differences, recovery of known transforms, and
// the covariance's calibration by Monte Carlo over noise realisations.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <functional>

#include "align3d/icp/factors.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/depth_scenes.hpp"
#include "detail/random.hpp"

namespace align3d {
namespace {

Eigen::Vector3d random_vector(Random& rng) { return {rng.normal(), rng.normal(), rng.normal()}; }

// The exact function the symmetric factor linearises (Rusinkiewicz 2019, eq. 7 divided by cos θ):
// g(ã, t̃) = ((R p − R⁻¹ q) / cos θ + t̃)·n, R the rotation by θ = atan|ã| about ã/|ã|.
double symmetric_exact(const Vector6d& x, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                       const Eigen::Vector3d& n) {
  const Eigen::Vector3d a = x.head<3>();
  const double theta = std::atan(a.norm());
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (a.norm() > 0) R = Eigen::AngleAxisd(theta, a.normalized()).toRotationMatrix();
  return ((R * p - R.transpose() * q) / std::cos(theta) + x.tail<3>()).dot(n);
}

TEST(SymmetricFactor, JacobianMatchesFiniteDifferences) {
  Random rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d p = 10 * random_vector(rng), q = p + random_vector(rng);
    const Eigen::Vector3d n = random_vector(rng).normalized() + random_vector(rng).normalized();
    const Vector6d J = SymmetricFactor::jacobian(p, q, n);
    EXPECT_NEAR(SymmetricFactor::residual(p, q, n), symmetric_exact(Vector6d::Zero(), p, q, n),
                1e-12);
    for (int k = 0; k < 6; ++k) {
      const double h = 1e-6;
      Vector6d e = Vector6d::Zero();
      e(k) = h;
      const double fd = (symmetric_exact(e, p, q, n) - symmetric_exact(-e, p, q, n)) / (2 * h);
      EXPECT_NEAR(J(k), fd, 1e-6 * (1 + std::abs(fd))) << "unknown " << k;
    }
  }
}

// The update applies what the objective describes: the source turned by θ, shifted by t, turned by
// θ again (p ← R(R p + t), t = t̃ cos θ), so (U·p − q)·(R n) = cos θ · g(ã, t̃) exactly.
TEST(SymmetricFactor, UpdateMovesTheSourceAsTheObjectiveSays) {
  Random rng(4);
  for (int trial = 0; trial < 20; ++trial) {
    Vector6d x;
    x << 0.3 * random_vector(rng), 2 * random_vector(rng);
    const Eigen::Vector3d p = 10 * random_vector(rng), q = 10 * random_vector(rng);
    const Eigen::Vector3d n = random_vector(rng);
    const double theta = std::atan(x.head<3>().norm());
    const Eigen::Matrix3d R = Eigen::AngleAxisd(theta, x.head<3>().normalized()).toRotationMatrix();
    const Eigen::Isometry3d U = symmetric_update(x);
    EXPECT_NEAR((U * p - q).dot(R * n), std::cos(theta) * symmetric_exact(x, p, q, n), 1e-9);
    EXPECT_NEAR(rotation_angle(U.linear()), 2 * theta, 1e-9);  // the full turn is 2θ
  }
  EXPECT_TRUE(symmetric_update(Vector6d::Zero()).isApprox(Eigen::Isometry3d::Identity()));
}

// GICP: cost c(ξ) = eᵀ M e, e = exp(ξ)·x − q, M fixed. Its gradient is 2 Jᵀ M e; where e = 0 its
// Hessian is the Gauss-Newton 2 Jᵀ M J.
double gicp_cost(const Vector6d& xi, const Eigen::Vector3d& x, const Eigen::Vector3d& q,
                 const Eigen::Matrix3d& M) {
  const Eigen::Vector3d e = se3_exp(xi) * x - q;
  return e.dot(M * e);
}

TEST(GicpFactor, GradientAndHessianMatchFiniteDifferences) {
  Random rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d x = 10 * random_vector(rng);
    const Eigen::Matrix3d M =
        GicpFactor::weight(random_vector(rng).normalized(), random_vector(rng).normalized());
    const Eigen::Matrix<double, 3, 6> J = GicpFactor::jacobian(x);
    const double h = 1e-6;
    const Eigen::Vector3d q = x + random_vector(rng);
    const Vector6d gradient = 2 * J.transpose() * M * (x - q);
    for (int k = 0; k < 6; ++k) {
      Vector6d e = Vector6d::Zero();
      e(k) = h;
      const double fd = (gicp_cost(e, x, q, M) - gicp_cost(-e, x, q, M)) / (2 * h);
      EXPECT_NEAR(gradient(k), fd, 1e-5 * (1 + std::abs(fd)));
    }
    const Matrix6d hessian = 2 * J.transpose() * M * J;  // at q = x
    const double hh = 1e-4;
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) {
        Vector6d ea = Vector6d::Zero(), eb = Vector6d::Zero();
        ea(a) = hh;
        eb(b) = hh;
        const double fd = (gicp_cost(ea + eb, x, x, M) - gicp_cost(ea - eb, x, x, M) -
                           gicp_cost(eb - ea, x, x, M) + gicp_cost(-ea - eb, x, x, M)) /
                          (4 * hh * hh);
        EXPECT_NEAR(hessian(a, b), fd, 1e-3 * (1 + std::abs(fd))) << a << "," << b;
      }
  }
  // The plane regularisation: eigenvalues (ε, 1, 1) with the normal the ε direction.
  const Eigen::Vector3d n = Eigen::Vector3d(1, 2, 2) / 3;
  EXPECT_NEAR(n.dot(GicpFactor::covariance(n) * n), GicpFactor::kEpsilon, 1e-15);
  EXPECT_TRUE(GicpFactor::covariance(Eigen::Vector3d::Zero()).isIdentity());
}

// Noisy samples of a surface: an undulating height field over 200 × 150 (well conditioned: its
// bumps fix all six directions), or a cylinder (its axial shift and spin are free).
using Draw = std::function<Eigen::Vector3d(Random&)>;
Eigen::Vector3d bumpy(Random& rng) {
  const double x = rng.uniform(-100, 100), y = rng.uniform(-75, 75);
  return {x, y, 12 * std::sin(x / 17) * std::cos(y / 23) + 6 * std::cos((x + 2 * y) / 31)};
}
Eigen::Vector3d cylinder(Random& rng) {
  const double phi = rng.uniform(0, deg_to_rad(360));
  return {30 * std::cos(phi), 30 * std::sin(phi), rng.uniform(-100, 100)};
}
PointCloud noisy_sample(int n, Random& rng, double sigma, const Draw& draw) {
  PointCloud c;
  for (int i = 0; i < n; ++i) c.positions.push_back(draw(rng) + sigma * random_vector(rng));
  return c;
}

class Methods : public ::testing::TestWithParam<IcpMethod> {};

// From 10° and 8 % of the diagonal off, every method reaches the truth (the identity: source and
// target sample one surface) to within the noise's effect on the pose.
TEST_P(Methods, RecoverAKnownTransform) {
  Random rng(11);
  const PointCloud target = noisy_sample(20000, rng, 0.1, bumpy);
  const PointCloud source = noisy_sample(12000, rng, 0.1, bumpy);
  RefineSettings s;
  s.method = GetParam();
  const Eigen::Isometry3d init = rigid_transform(10, {1, -2, 3}, {12, -9, 5});
  const RefineResult r = refine(source, target, init, s);
  EXPECT_TRUE(r.icp.converged) << to_string(r.icp.stop_reason);
  const PoseError e = pose_error(r.icp.T_target_source, Eigen::Isometry3d::Identity());
  EXPECT_LT(e.rotation_deg, 0.02);
  EXPECT_LT(e.translation, 0.02);
  // The plane distance of two σ = 0.1 samplings, ≈ σ√2 (point-to-point's final stage measures to
  // the target's tangent planes: icp.hpp, tangent_planes).
  EXPECT_NEAR(r.icp.rms, 0.1 * std::sqrt(2.0), 0.03);
}

// The normalised estimation error squared ξᵀ Σ⁻¹ ξ averaged over noise realisations, ξ the pose
// error (the truth is the identity), on the directions not in `free` (unit 6-vectors, physical
// units); its expected value is their count.
struct Calibration {
  double mean_nees = 0;
  int dimensions = 0;
  Matrix6d last_covariance = Matrix6d::Zero();
  std::size_t last_weak_directions = 0;
};
Calibration calibrate(IcpMethod method, const Draw& draw, const std::vector<Vector6d>& free,
                      int runs) {
  Eigen::Matrix<double, 6, Eigen::Dynamic> basis(6, 0);
  {  // an orthonormal basis of the complement of `free`
    Matrix6d P = Matrix6d::Identity();
    for (const Vector6d& f : free) P -= f * f.transpose();
    const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(P);
    for (int i = 0; i < 6; ++i)
      if (eig.eigenvalues()(i) > 0.5) {
        basis.conservativeResize(6, basis.cols() + 1);
        basis.col(basis.cols() - 1) = eig.eigenvectors().col(i);
      }
  }
  Calibration c;
  c.dimensions = static_cast<int>(basis.cols());
  for (int k = 0; k < runs; ++k) {
    Random rng(100 + static_cast<std::uint64_t>(k));
    const PointCloud target = noisy_sample(20000, rng, 0.1, draw);
    const PointCloud source = noisy_sample(12000, rng, 0.1, draw);
    RefineSettings s;
    s.method = method;
    s.covariance = true;
    const RefineResult r = refine(source, target, Eigen::Isometry3d::Identity(), s);
    const Eigen::VectorXd xi = basis.transpose() * se3_log(r.icp.T_target_source);
    const Eigen::MatrixXd cov = basis.transpose() * r.icp.covariance * basis;
    c.mean_nees += xi.dot(cov.ldlt().solve(xi)) / runs;
    c.last_covariance = r.icp.covariance;
    c.last_weak_directions = r.icp.degenerate_directions.size();
  }
  return c;
}

// Calibrated: over 40 noise realisations the NEES averages within [0.5, 2] × its expected value 6.
// Point-to-point too, whose final stage pairs with the target's tangent planes (icp.hpp,
// tangent_planes): paired sample to sample, its error on two independent samplings is a bias from
// the pairing (the nearest sample is not the same surface point), which no residual-based
// covariance covers (measured: NEES 34 × expected).
class Calibrated : public Methods {};

TEST_P(Calibrated, OnAWellConditionedSurface) {
  const Calibration c = calibrate(GetParam(), bumpy, {}, 40);
  RecordProperty("mean_nees", std::to_string(c.mean_nees));
  std::printf("%s: mean NEES %.2f (expected 6)\n", to_string(GetParam()), c.mean_nees);
  EXPECT_EQ(c.dimensions, 6);
  EXPECT_GT(c.mean_nees, 0.5 * 6) << to_string(GetParam());
  EXPECT_LT(c.mean_nees, 2.0 * 6) << to_string(GetParam());
}

// A cylinder leaves its axial shift and its spin free: the loop reports both (degeneracy.hpp) and
// does not move along them, the covariance grows along them (≥ 10⁴ × the variance of the same kind
// across the axis), and on the four held directions the NEES averages within [0.5, 2] × 4.
TEST_P(Calibrated, AndGrowsAlongTheFreeDirectionsOfACylinder) {
  Vector6d spin = Vector6d::Zero(), shift = Vector6d::Zero();
  spin(2) = 1;
  shift(5) = 1;
  const Calibration c = calibrate(GetParam(), cylinder, {spin, shift}, 40);
  EXPECT_EQ(c.dimensions, 4);
  std::printf("%s: mean NEES %.2f (expected 4)\n", to_string(GetParam()), c.mean_nees);
  EXPECT_GT(c.mean_nees, 0.5 * 4) << to_string(GetParam());
  EXPECT_LT(c.mean_nees, 2.0 * 4) << to_string(GetParam());
  // In units of length (rotations × the cylinder's half length), the covariance's two largest
  // principal directions lie in the free plane (spin, shift) and dwarf the rest.
  Vector6d units;
  units << 100, 100, 100, 1, 1, 1;
  const Matrix6d S = units.asDiagonal() * c.last_covariance * units.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(S);
  const Vector6d values = eig.eigenvalues();
  EXPECT_GT(values(4), 100 * values(3));
  for (int i = 4; i < 6; ++i) {
    const Vector6d v = eig.eigenvectors().col(i);
    EXPECT_GT(v(2) * v(2) + v(5) * v(5), 0.9) << v.transpose();
  }
  // Point-to-point too: onto tangent planes it reports point-to-plane's (icp.hpp,
  // degenerate_directions).
  EXPECT_EQ(c.last_weak_directions, 2u);
}

// Range scans: two views 40° apart rendered by ray casting (a depth camera's noise along each line
// of sight, samples on its pixel grid, holes), 20 noise realisations, refine() with its defaults
// from 1° off; the test object and the animal. The NEES averages within [0.5, 2] × 6 for every
// method. Point-to-plane's and point-to-point's covariance carries the tangent planes' model error
// (IcpResult::model_error): without it their poses' bias (about one σ, the same at a quarter of the
// noise) left the NEES at 20 and 22 on the test object, 11 and 17 on the animal; their NEES about
// the mean error (the noise's part alone) stays within the bounds too.
struct RangeScanCase {
  IcpMethod method;
  const char* object;
};

class RangeScans : public ::testing::TestWithParam<RangeScanCase> {};

// Two rendered views of `object` 40° apart, `k`-th noise realisation (`noise` × the sensor's).
synth::ObjectViews two_views(const std::string& object, int k, double noise = 1.0,
                             double azimuth_jitter = 0) {
  synth::ObjectViewsSettings vs;
  vs.seed = 100 + static_cast<std::uint64_t>(k);
  vs.object = object;
  vs.azimuth_deg = {30 + azimuth_jitter * std::sin(1.7 * k),
                    70 + azimuth_jitter * std::cos(2.3 * k)};
  vs.sensor.noise_a *= noise;
  vs.sensor.noise_b *= noise;
  return synth::make_object_views(vs);
}

TEST_P(RangeScans, CovarianceOfTwoRenderedViews) {
  constexpr int kRuns = 20;
  std::vector<Vector6d> errors;
  std::vector<Matrix6d> covariances;
  for (int k = 0; k < kRuns; ++k) {
    const synth::ObjectViews v = two_views(GetParam().object, k);
    const Eigen::Isometry3d truth = v.T_camera_object[0] * v.T_camera_object[1].inverse();
    RefineSettings s;
    s.method = GetParam().method;
    s.covariance = true;
    s.model_error = true;
    const Eigen::Isometry3d start =
        rigid_transform(1.0, Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(1, 0, 0)) * truth;
    const RefineResult r = refine(v.views[1].valid_points(), v.views[0].valid_points(), start, s);
    errors.push_back(se3_log(r.icp.T_target_source * truth.inverse()));
    covariances.push_back(r.icp.covariance);
  }
  Vector6d mean = Vector6d::Zero();
  for (const Vector6d& e : errors) mean += e / kRuns;
  double nees = 0, random_part = 0;
  for (int k = 0; k < kRuns; ++k) {
    const Eigen::LDLT<Matrix6d> inverse(covariances[k]);
    nees += errors[k].dot(inverse.solve(errors[k])) / kRuns;
    const Vector6d d = errors[k] - mean;
    random_part += d.dot(inverse.solve(d)) / (kRuns - 1);
  }
  std::printf("%s, %s: mean NEES %.2f, about the mean error %.2f (expected 6)\n", GetParam().object,
              to_string(GetParam().method), nees, random_part);
  EXPECT_GT(nees, 0.5 * 6);
  EXPECT_LT(nees, 2.0 * 6);
  EXPECT_GT(random_part, 0.5 * 6);
  EXPECT_LT(random_part, 2.0 * 6);
}

// The model error points from point-to-plane's pose toward the truth: without noise (8 renders,
// azimuths moved by up to 3° so that the pixel grids differ), the pose moved by it lies closer to
// the truth than the pose returned, in rotation and in translation. Zero for GICP and symmetric.
TEST(ModelError, PointsFromPointToPlanesPoseTowardTheTruth) {
  for (const char* object : {"part", "animal"}) {
    double before_r = 0, before_t = 0, after_r = 0, after_t = 0;
    for (int k = 0; k < 8; ++k) {
      const synth::ObjectViews v = two_views(object, k, 0.0, 3.0);
      const Eigen::Isometry3d truth = v.T_camera_object[0] * v.T_camera_object[1].inverse();
      const PointCloud source = v.views[1].valid_points(), target = v.views[0].valid_points();
      RefineSettings with_covariance;
      with_covariance.covariance = true;
      with_covariance.model_error = true;
      const RefineResult r = refine(source, target, truth, with_covariance);
      const Vector6d e = se3_log(r.icp.T_target_source * truth.inverse());
      const Vector6d moved = e + r.icp.model_error;
      before_r += e.head<3>().squaredNorm(), before_t += e.tail<3>().squaredNorm();
      after_r += moved.head<3>().squaredNorm(), after_t += moved.tail<3>().squaredNorm();
      if (k == 0) {
        for (IcpMethod m : {IcpMethod::kGicp, IcpMethod::kSymmetric}) {
          RefineSettings s = with_covariance;
          s.method = m;
          EXPECT_TRUE(refine(source, target, truth, s).icp.model_error.isZero()) << to_string(m);
        }
      }
    }
    std::printf("%s: rotation error %.2g → %.2g rad, translation %.2g → %.2g (rms)\n", object,
                std::sqrt(before_r / 8), std::sqrt(after_r / 8), std::sqrt(before_t / 8),
                std::sqrt(after_t / 8));
    EXPECT_LT(after_r, before_r) << object;
    EXPECT_LT(after_t, before_t) << object;
  }
}

std::string method_name(const ::testing::TestParamInfo<IcpMethod>& info) {
  std::string name = to_string(info.param);
  for (char& ch : name)
    if (ch == '-') ch = '_';
  return name;
}
INSTANTIATE_TEST_SUITE_P(Icp, Methods, ::testing::ValuesIn(kAllIcpMethods), method_name);
INSTANTIATE_TEST_SUITE_P(Covariance, Calibrated, ::testing::ValuesIn(kAllIcpMethods), method_name);
std::vector<RangeScanCase> range_scan_cases() {
  std::vector<RangeScanCase> cases;
  for (const char* object : {"part", "animal"})
    for (IcpMethod m : kAllIcpMethods) cases.push_back({m, object});
  return cases;
}
INSTANTIATE_TEST_SUITE_P(
    Covariance, RangeScans, ::testing::ValuesIn(range_scan_cases()),
    [](const ::testing::TestParamInfo<RangeScanCase>& info) {
      return info.param.object + std::string("_") + method_name({info.param.method, info.index});
    });

}  // namespace
}  // namespace align3d
