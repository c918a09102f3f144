// Plane fitting and rectification. Oracles: points sampled on a known plane; synth::make_plate's
// true upward normal; rotation_to_z checked by what it does to n (R·n = +Z, det R = +1).
#include "align3d/plane/plane.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/plane/rectify.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::expect_proper_rotation;
using test::line_angle_deg;
using test::random_unit;

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return rad_to_deg(std::atan2(a.cross(b).norm(), a.dot(b)));
}

const Eigen::Vector3d kNormal = Eigen::Vector3d(0.2, -0.35, 0.9).normalized();

std::vector<Eigen::Vector3d> plane_points(const Eigen::Vector3d& point, const Eigen::Vector3d& n,
                                          int count, double sigma, Random& rng) {
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    const double a = rng.uniform(-50, 50), b = rng.uniform(-40, 40), e = rng.normal();
    points.push_back(point + a * u + b * v + sigma * e * n);
  }
  return points;
}

TEST(PlaneFit, RecoversATiltedPlaneExactly) {
  Random rng(601);
  const Eigen::Vector3d on_plane(10, -20, 35);
  const auto points = plane_points(on_plane, kNormal, 500, 0.0, rng);
  const Plane plane = fit_plane(points);
  EXPECT_NEAR(plane.normal.norm(), 1.0, 1e-12);
  EXPECT_LT(std::min((plane.normal - kNormal).norm(), (plane.normal + kNormal).norm()), 1e-6);
  EXPECT_NEAR(kNormal.dot(plane.point - on_plane), 0.0, 1e-9);  // the centroid is on the plane
  for (const auto& p : points) EXPECT_NEAR(plane.signed_distance(p), 0.0, 1e-9);
}

TEST(PlaneFit, UsesOnlyTheListedIndices) {
  Random rng(602);
  auto points = plane_points(Eigen::Vector3d::Zero(), kNormal, 200, 0.0, rng);
  std::vector<std::size_t> indices(points.size());
  for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = i;
  // Far-off points that are not listed must not matter.
  for (int i = 0; i < 50; ++i) points.push_back(Eigen::Vector3d(rng.uniform(-9, 9), 100, 7 * i));
  const Plane plane = fit_plane(points, &indices);
  EXPECT_LT(line_angle_deg(plane.normal, kNormal), 1e-6);
}

TEST(PlaneFit, ThrowsDataErrorWithoutAPlane) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 2, 3}};
  EXPECT_THROW(fit_plane(two), DataError);
  std::vector<Eigen::Vector3d> collinear;
  for (int i = 0; i < 20; ++i) collinear.push_back(Eigen::Vector3d(1, 2, 3) + 0.37 * i * kNormal);
  EXPECT_THROW(fit_plane(collinear), DataError);
  const std::vector<Eigen::Vector3d> coincident(10, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_THROW(fit_plane(coincident), DataError);
  const std::vector<std::size_t> two_indices = {0, 5};
  EXPECT_THROW(fit_plane(collinear, &two_indices), DataError);
  try {
    fit_plane(collinear);
  } catch (const DataError& e) {
    EXPECT_EQ(e.code(), ExitCode::kData);
  }
}

TEST(PlaneRansac, FindsThePlaneUnderThirtyPercentClutter) {
  // A 100 × 80 mm plate tilted 7°, σ = 0.05 mm, with a 30 × 30 × 30 mm box standing on it holding
  // 30 % of the points. From ~2800 plate points the normal is determined to about
  // σ / (√N · 25 mm) ~ 4e-5 rad = 0.002°; 0.05° leaves room for the box's base edge.
  synth::PlateSettings settings;
  settings.clutter_fraction = 0.3;
  const synth::Plate plate = synth::make_plate(settings);
  const RansacPlaneResult result = ransac_plane(plate.cloud.positions);
  EXPECT_LT(line_angle_deg(result.plane.normal, plate.true_normal), 0.05);
  // Inliers: ascending, nearly all plate points (the first plate_points of the cloud), little box.
  EXPECT_TRUE(std::is_sorted(result.inliers.begin(), result.inliers.end()));
  std::size_t on_plate = 0;
  for (std::size_t i : result.inliers) on_plate += i < plate.plate_points;
  EXPECT_GT(on_plate, plate.plate_points * 95 / 100);
  EXPECT_LT(result.inliers.size() - on_plate, plate.plate_points / 50);
  // The fitted point lies on the true plate plane (which passes through the tilted plate centre).
  const Eigen::Vector3d centre(0, 0, settings.height);
  EXPECT_NEAR(plate.true_normal.dot(result.plane.point - centre), 0.0, 0.05);
}

// Counting candidates on every m-th point (score_points) picks the plane counting on all does:
// under 30 % clutter the normals agree to the refit's accuracy and the inliers are the same
// points but for a few at the band's edge.
TEST(PlaneRansac, ScoringOnASubsetFindsTheSamePlane) {
  synth::PlateSettings settings;
  settings.clutter_fraction = 0.3;
  const synth::Plate plate = synth::make_plate(settings);
  RansacPlaneSettings rs;
  const RansacPlaneResult all = ransac_plane(plate.cloud.positions, rs);
  rs.score_points = 300;
  ASSERT_GT(plate.cloud.size(), 3 * rs.score_points);
  const RansacPlaneResult some = ransac_plane(plate.cloud.positions, rs);
  EXPECT_LT(line_angle_deg(some.plane.normal, plate.true_normal), 0.05);
  EXPECT_LT(line_angle_deg(some.plane.normal, all.plane.normal), 0.05);
  std::vector<std::size_t> common;
  std::set_intersection(all.inliers.begin(), all.inliers.end(), some.inliers.begin(),
                        some.inliers.end(), std::back_inserter(common));
  EXPECT_GT(common.size(), all.inliers.size() * 98 / 100);
  EXPECT_LT(some.inliers.size(), all.inliers.size() * 102 / 100);
  // A cloud with no plane still has none when counted on a subset.
  Random rng(3);
  std::vector<Eigen::Vector3d> sphere;
  for (int i = 0; i < 3000; ++i)
    sphere.push_back(40 * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized());
  EXPECT_THROW(ransac_plane(sphere, rs), DataError);
}

TEST(PlaneRansac, SameSeedSameResult) {
  synth::PlateSettings settings;
  settings.clutter_fraction = 0.3;
  const synth::Plate plate = synth::make_plate(settings);
  RansacPlaneSettings rs;
  rs.seed = 77;
  const RansacPlaneResult a = ransac_plane(plate.cloud.positions, rs);
  const RansacPlaneResult b = ransac_plane(plate.cloud.positions, rs);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_TRUE((a.plane.normal.array() == b.plane.normal.array()).all());
  EXPECT_TRUE((a.plane.point.array() == b.plane.point.array()).all());
}

TEST(PlaneRansac, ThrowsDataErrorWithoutAPlane) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 2, 3}};
  EXPECT_THROW(ransac_plane(two), DataError);
  const std::vector<Eigen::Vector3d> coincident(10, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_THROW(ransac_plane(coincident), DataError);
  std::vector<Eigen::Vector3d> collinear;
  for (int i = 0; i < 20; ++i) collinear.push_back(Eigen::Vector3d(1, 2, 3) + 0.37 * i * kNormal);
  EXPECT_THROW(ransac_plane(collinear), DataError);
}

// Volumes define no plane: a uniform cube and a sphere give slabs holding ~2 % of the points.
TEST(PlaneRansac, ThrowsDataErrorForABlobOrASphere) {
  Random rng(12);
  std::vector<Eigen::Vector3d> cube, sphere;
  for (int i = 0; i < 3000; ++i) {
    cube.push_back({rng.uniform(0, 50), rng.uniform(0, 50), rng.uniform(0, 50)});
    const Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
    sphere.push_back(40 * d.normalized());
  }
  for (const auto* cloud : {&cube, &sphere}) {
    try {
      ransac_plane(*cloud);
      ADD_FAILURE() << "no DataError";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("no plane"), std::string::npos) << e.what();
    }
  }
  for (const auto* cloud : {&cube, &sphere}) EXPECT_THROW(fit_plane(*cloud), DataError);
  // A plate holding a quarter of the points, the rest a blob above it, still has its plane.
  std::vector<Eigen::Vector3d> mixed(cube.begin(), cube.begin() + 2250);
  for (auto& p : mixed) p.z() += 10;
  for (int i = 0; i < 750; ++i) mixed.push_back({rng.uniform(0, 50), rng.uniform(0, 50), 0});
  EXPECT_NEAR(std::abs(ransac_plane(mixed).plane.normal.z()), 1.0, 1e-9);
}

TEST(PlaneRotationToZ, MapsRandomNormalsToPlusZ) {
  Random rng(603);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d n = random_unit(rng);
    const Eigen::Matrix3d R = rotation_to_z(n);
    expect_proper_rotation(R);
    EXPECT_LT((R * n - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
    // Shortest arc: the rotation angle is the angle between n and +Z, and n × z is fixed.
    EXPECT_NEAR(rotation_angle(R), std::acos(std::clamp(n.z(), -1.0, 1.0)), 1e-9);
    const Eigen::Vector3d axis = n.cross(Eigen::Vector3d::UnitZ());
    EXPECT_LT((R * axis - axis).norm(), 1e-12);
  }
  // Not-normalised input is normalised first.
  EXPECT_LT((rotation_to_z(3.0 * kNormal) * kNormal - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

TEST(PlaneRotationToZ, PlusZIsIdentityAndMinusZIsAProperHalfTurn) {
  EXPECT_EQ(rotation_to_z(Eigen::Vector3d::UnitZ()), Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d R = rotation_to_z(-Eigen::Vector3d::UnitZ());
  expect_proper_rotation(R);
  EXPECT_LT((R * -Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  // Nearly −Z (the Rodrigues branch with a tiny axis) is also a proper rotation onto +Z.
  const Eigen::Vector3d almost = Eigen::Vector3d(1e-9, -2e-9, -1).normalized();
  const Eigen::Matrix3d R2 = rotation_to_z(almost);
  expect_proper_rotation(R2);
  EXPECT_LT((R2 * almost - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
}

TEST(PlaneRectify, LevelsATiltedPlateOntoZeroWithoutFlippingIt) {
  // σ = 0.05 mm: rectified plate points lie within 5σ = 0.25 mm of z = 0 (4000 Gaussian samples
  // exceed 5σ with probability ~2e-3), and the refit tilt is rounding only.
  synth::PlateSettings settings;
  const synth::Plate plate = synth::make_plate(settings);
  RectifySettings lsq;
  lsq.robust = false;  // the chapter's fit, on every point
  const RectifyResult r = rectify(plate.cloud, lsq);
  EXPECT_TRUE(r.warnings.empty());  // a plate alone is flat to its noise
  EXPECT_LT(r.tilt_after_deg, 1e-3);
  EXPECT_NEAR(r.tilt_before_deg, settings.tilt_deg, 0.05);
  EXPECT_EQ(r.inliers, plate.cloud.size());
  expect_proper_rotation(r.T_level_cloud.linear());
  // Not flipped: the plate's true upward normal ends up along +Z.
  EXPECT_LT(angle_deg(r.T_level_cloud.linear() * plate.true_normal, Eigen::Vector3d::UnitZ()),
            0.05);
  EXPECT_GT(r.normal.dot(plate.true_normal), 0.0);
  double worst = 0;
  for (const auto& p : plate.cloud.positions)
    worst = std::max(worst, std::abs((r.T_level_cloud * p).z()));
  EXPECT_LT(worst, 5 * settings.noise_sigma);
  // Flatness is the peak-to-valley of Gaussian noise over 4000 points: ~7σ.
  EXPECT_GT(r.flatness, 4 * settings.noise_sigma);
  EXPECT_LT(r.flatness, 10 * settings.noise_sigma);
}

TEST(PlaneRectify, PlateFacingDownStaysRightSideUpByDefaultAndHonoursUp) {
  // A plate tilted by 170° faces down; with no part and no `up`, the sensor's side (+Z) is up, so
  // the fitted normal is −true_normal. With `up` = true_normal the plate's own top goes to +Z.
  synth::PlateSettings settings;
  settings.tilt_deg = 170;
  const synth::Plate plate = synth::make_plate(settings);
  ASSERT_LT(plate.true_normal.z(), 0);
  RectifySettings rs;
  RectifyResult r = rectify(plate.cloud, rs);
  EXPECT_GE(r.normal.z(), 0);
  EXPECT_LT(angle_deg(r.normal, -plate.true_normal), 0.05);
  EXPECT_LT(r.tilt_after_deg, 1e-3);

  rs.up = plate.true_normal;
  r = rectify(plate.cloud, rs);
  EXPECT_LT(angle_deg(r.normal, plate.true_normal), 0.05);
  EXPECT_LT(angle_deg(r.T_level_cloud.linear() * plate.true_normal, Eigen::Vector3d::UnitZ()),
            0.05);
  expect_proper_rotation(r.T_level_cloud.linear());
  EXPECT_LT(r.tilt_after_deg, 1e-3);
  for (const auto& p : plate.cloud.positions)
    ASSERT_LT(std::abs((r.T_level_cloud * p).z()), 5 * settings.noise_sigma);

  // An upright plate with `up` pointing down is turned over, as asked.
  const synth::Plate upright = synth::make_plate(synth::PlateSettings{});
  rs.up = -Eigen::Vector3d::UnitZ();
  r = rectify(upright.cloud, rs);
  EXPECT_LT(angle_deg(r.normal, -upright.true_normal), 0.05);
  EXPECT_LT(angle_deg(r.T_level_cloud.linear() * -upright.true_normal, Eigen::Vector3d::UnitZ()),
            0.05);
  rs.up = Eigen::Vector3d::Zero();
  EXPECT_THROW(rectify(upright.cloud, rs), std::invalid_argument);  // a programming error
}

TEST(PlaneRectify, PartOnThePlateDecidesUpEvenWhenTheNormalLeansDown) {
  // Tilted 92°: the plate's true up normal has z = cos 92° < 0, so the +Z rule alone would flip
  // it; the box standing on the plate (20 % of the points) is on the true-up side and wins.
  synth::PlateSettings settings;
  settings.tilt_deg = 92;
  settings.clutter_fraction = 0.2;
  const synth::Plate plate = synth::make_plate(settings);
  ASSERT_LT(plate.true_normal.z(), 0);
  RectifySettings rs;
  rs.robust = true;
  const RectifyResult r = rectify(plate.cloud, rs);
  EXPECT_LT(angle_deg(r.normal, plate.true_normal), 0.05);
  EXPECT_LT(angle_deg(r.T_level_cloud.linear() * plate.true_normal, Eigen::Vector3d::UnitZ()),
            0.05);
  EXPECT_LT(r.tilt_after_deg, 1e-3);
  EXPECT_NEAR(r.tilt_before_deg, 92.0, 0.05);
  // The part ends up above the plate: its points at z up to its 30 mm height, none below −5σ.
  double lowest = 0, highest = 0;
  for (const auto& p : plate.cloud.positions) {
    const double z = (r.T_level_cloud * p).z();
    lowest = std::min(lowest, z);
    highest = std::max(highest, z);
  }
  EXPECT_GT(lowest, -5 * settings.noise_sigma);
  EXPECT_NEAR(highest, 30.0, 0.5);
  // The plate's own points are at z ≈ 0.
  for (std::size_t i = 0; i < plate.plate_points; ++i)
    ASSERT_LT(std::abs((r.T_level_cloud * plate.cloud.positions[i]).z()), 5 * settings.noise_sigma);
}

// A least-squares plane through a plate and the part on it (20 % of the points, 30 mm tall) is
// not a plane the points lie on: the fit warns. The robust default finds the plate and does not.
TEST(PlaneRectify, WarnsWhenTheFittedPointsAreNotFlat) {
  synth::PlateSettings settings;
  settings.clutter_fraction = 0.2;
  const synth::Plate plate = synth::make_plate(settings);
  RectifySettings lsq;
  lsq.robust = false;
  const RectifyResult plain = rectify(plate.cloud, lsq);
  ASSERT_EQ(plain.warnings.size(), 1u);
  EXPECT_EQ(plain.warnings[0].code, "not_flat");
  EXPECT_GT(plain.rms, 10 * settings.noise_sigma);  // the part, 30 mm tall, is in the fit
  EXPECT_NEAR(plain.noise, settings.noise_sigma, 0.5 * settings.noise_sigma);
  const RectifyResult robust = rectify(plate.cloud);
  EXPECT_TRUE(robust.warnings.empty()) << robust.warnings[0].message;
  EXPECT_LT(angle_deg(robust.normal, plate.true_normal), 0.05);
  EXPECT_LT(robust.rms, 2 * settings.noise_sigma);
}

// A floor seen past the plate's edge (2 % of the points, 20 mm below, outside the plate's
// footprint) is not a part standing on the plate: it must not flip the plate over.
TEST(PlaneRectify, FloorPastThePlateEdgeDoesNotFlipIt) {
  const synth::Plate plate = synth::make_plate(synth::PlateSettings{});
  PointCloud cloud = plate.cloud;
  Random rng(3);
  for (int i = 0; i < 80; ++i)
    cloud.positions.emplace_back(rng.uniform(60, 80), rng.uniform(-40, 40), 0.0);
  for (bool robust : {false, true}) {
    RectifySettings s;
    s.robust = robust;
    const RectifyResult r = rectify(cloud, s);
    EXPECT_GT(r.T_level_cloud.linear().row(2).dot(plate.true_normal), 0.99) << robust;
  }
}

TEST(PlaneRectify, ThrowsDataErrorWithoutAPlane) {
  PointCloud line;
  for (int i = 0; i < 20; ++i) line.positions.push_back(0.5 * i * kNormal);
  EXPECT_THROW(rectify(line), DataError);
  PointCloud two;
  two.positions = {{0, 0, 0}, {1, 1, 1}};
  EXPECT_THROW(rectify(two), DataError);
}

}  // namespace
}  // namespace align3d
