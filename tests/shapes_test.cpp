// Analytic shapes (synth/shapes.hpp). Oracles: hits placed on a face in the shape's own frame and
// moved by a pose, the circle and sphere closed forms, exposed areas of overlapping solids.
#include "align3d/synth/shapes.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "align3d/se3.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d::synth {
namespace {

using test::kPi;

Eigen::Isometry3d some_pose() {
  return rigid_transform(37, Eigen::Vector3d(1, -2, 0.5), Eigen::Vector3d(12, -7, 30));
}

// A ray built in the shape's local frame (from `from` towards `to`), expressed in the world.
Ray local_ray(const Eigen::Isometry3d& pose, const Eigen::Vector3d& from,
              const Eigen::Vector3d& to) {
  return {pose * from, pose.linear() * (to - from)};
}

void expect_hit(const std::optional<Hit>& h, const Eigen::Vector3d& point,
                const Eigen::Vector3d& normal, double t) {
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t, t, 1e-12);
  EXPECT_LT((h->point - point).norm(), 1e-12);
  EXPECT_LT((h->normal - normal).norm(), 1e-12);
}

TEST(Shapes, RayHitsAKnownFaceOfAPosedBox) {
  const Eigen::Isometry3d T = some_pose();
  const Box box{T, {3, 2, 1}};
  // Towards the +y face at local (1, 2, 0.5), from 5 beyond it along +y: t = 1 with d = to − from.
  expect_hit(intersect(box, local_ray(T, {1, 7, 0.5}, {1, 2, 0.5})), T * Eigen::Vector3d(1, 2, 0.5),
             T.linear().col(1), 1.0);
  // Obliquely onto the −z face at local (−2, 0.5, −1).
  const Eigen::Vector3d target(-2, 0.5, -1), from = target + Eigen::Vector3d(0.5, -0.3, -2);
  expect_hit(intersect(box, local_ray(T, from, target)), T * target, -T.linear().col(2), 1.0);
  // Past the corner: misses.
  EXPECT_FALSE(intersect(box, local_ray(T, {3.001, 7, 0}, {3.001, 2, 0})));
  // A ray lying just above the +z face's plane misses; one just below enters through the x face.
  EXPECT_FALSE(intersect(box, local_ray(T, {-9, 0, 1 + 1e-9}, {-8, 0, 1 + 1e-9})));
  expect_hit(intersect(box, local_ray(T, {-9, 0, 1 - 1e-9}, {-8, 0, 1 - 1e-9})),
             T * Eigen::Vector3d(-3, 0, 1 - 1e-9), -T.linear().col(0), 6.0);
}

TEST(Shapes, RayFromInsideASolidExitsWithTheOutwardNormal) {
  const Eigen::Isometry3d T = some_pose();
  expect_hit(intersect(Box{T, {3, 2, 1}}, local_ray(T, {0, 0, 0}, {0, 0, 0.5})),
             T * Eigen::Vector3d(0, 0, 1), T.linear().col(2), 2.0);
  expect_hit(intersect(Sphere{{1, 2, 3}, 2}, Ray{{1, 2, 3}, {0, -1, 0}}), {1, 0, 3}, {0, -1, 0},
             2.0);
  expect_hit(intersect(Cylinder{T, 2, 3}, local_ray(T, {0, 0, 0}, {1, 0, 0})),
             T * Eigen::Vector3d(2, 0, 0), T.linear().col(0), 2.0);
}

TEST(Shapes, SphereHitTangentAndMiss) {
  const Sphere unit{{0, 0, 0}, 1};
  // The ray y = 0.6 meets x² + y² = 1 at x = −0.8, from x = −5: t = 4.2.
  expect_hit(intersect(unit, Ray{{-5, 0.6, 0}, {1, 0, 0}}), {-0.8, 0.6, 0}, {-0.8, 0.6, 0}, 4.2);
  // Direction of length 2: t halves.
  expect_hit(intersect(unit, Ray{{-5, 0.6, 0}, {2, 0, 0}}), {-0.8, 0.6, 0}, {-0.8, 0.6, 0}, 2.1);
  // Tangent (y = 1): touches at (0, 1, 0), the normal perpendicular to the ray.
  expect_hit(intersect(unit, Ray{{-5, 1, 0}, {1, 0, 0}}), {0, 1, 0}, {0, 1, 0}, 5.0);
  EXPECT_FALSE(intersect(unit, Ray{{-5, 1 + 1e-9, 0}, {1, 0, 0}}));
  // Behind the origin: no hit for t > 0; t_min and t_max select between the two crossings.
  EXPECT_FALSE(intersect(unit, Ray{{5, 0, 0}, {1, 0, 0}}));
  expect_hit(intersect(unit, Ray{{-5, 0, 0}, {1, 0, 0}}, 4.5), {1, 0, 0}, {1, 0, 0}, 6.0);
  EXPECT_FALSE(intersect(unit, Ray{{-5, 0, 0}, {1, 0, 0}}, 0, 3.9));
}

TEST(Shapes, CylinderCapSideAndEdges) {
  const Eigen::Isometry3d T = some_pose();
  const Cylinder cyl{T, 2, 3};
  // The top cap at local (0.5, 0.5, 3), from 7 above.
  expect_hit(intersect(cyl, local_ray(T, {0.5, 0.5, 10}, {0.5, 0.5, 9})),
             T * Eigen::Vector3d(0.5, 0.5, 3), T.linear().col(2), 7.0);
  // The bottom cap from below.
  expect_hit(intersect(cyl, local_ray(T, {-1, 0, -8}, {-1, 0, -7})), T * Eigen::Vector3d(-1, 0, -3),
             -T.linear().col(2), 5.0);
  // The side along −x at local y = 1: x = √(4 − 1) = √3, normal (√3/2, 1/2, 0).
  const double s3 = std::sqrt(3.0);
  expect_hit(intersect(cyl, local_ray(T, {10, 1, 2.5}, {9, 1, 2.5})),
             T * Eigen::Vector3d(s3, 1, 2.5), T.linear() * Eigen::Vector3d(s3 / 2, 0.5, 0),
             10 - s3);
  // Just above the cap's plane the horizontal ray misses; parallel to the axis outside: misses.
  EXPECT_FALSE(intersect(cyl, local_ray(T, {10, 1, 3 + 1e-9}, {9, 1, 3 + 1e-9})));
  EXPECT_FALSE(intersect(cyl, local_ray(T, {2.001, 0, 10}, {2.001, 0, 9})));
  // Tangent to the side (y = 2) touches at (0, 2, 0) (no pose: a rotated ray's rounding would
  // decide between touching and missing).
  expect_hit(intersect(Cylinder{Eigen::Isometry3d::Identity(), 2, 3}, Ray{{10, 2, 0}, {-1, 0, 0}}),
             {0, 2, 0}, {0, 1, 0}, 10.0);
}

TEST(Shapes, SheetsHitFromEitherSideWithTheirStatedNormal) {
  const Eigen::Isometry3d T = some_pose();
  const Rectangle rect{T, {4, 1}};
  expect_hit(intersect(rect, local_ray(T, {3, -0.5, 2}, {3, -0.5, 1})),
             T * Eigen::Vector3d(3, -0.5, 0), T.linear().col(2), 2.0);
  expect_hit(intersect(rect, local_ray(T, {3, -0.5, -2}, {3, -0.5, -1})),
             T * Eigen::Vector3d(3, -0.5, 0), T.linear().col(2), 2.0);
  EXPECT_FALSE(intersect(rect, local_ray(T, {3, -1.01, 2}, {3, -1.01, 1})));
  // In the sheet's plane (no pose: a rotated ray would leave the plane by rounding).
  EXPECT_FALSE(
      intersect(Rectangle{Eigen::Isometry3d::Identity(), {4, 1}}, Ray{{-9, 0, 0}, {1, 0, 0}}));
  // The plane n·(p − p0) = 0 with n = (0, 0.6, 0.8) through (0, 0, 5), from the origin along +z:
  // 0.8·t = 0.8·5, t = 5.
  const Plane plane{{0, 0.6, 0.8}, {0, 0, 5}};
  expect_hit(intersect(plane, Ray{{0, 0, 0}, {0, 0, 1}}), {0, 0, 5}, {0, 0.6, 0.8}, 5.0);
  EXPECT_FALSE(intersect(plane, Ray{{0, 0, 0}, {1, 0, 0}}));
}

TEST(Shapes, CastRayReturnsTheNearestHitOfTheUnion) {
  const std::vector<Shape> shapes = {
      Box{rigid_transform(0, Eigen::Vector3d::UnitZ(), {0, 0, 10}), {5, 5, 1}},
      Sphere{{0, 0, 4}, 2}, Plane{{0, 0, 1}, {0, 0, 20}}};
  const Ray up{{0, 0, 0}, {0, 0, 1}};
  auto h = cast_ray(shapes, up);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shape, 1);  // the sphere's near side at z = 2, before the box at z = 9
  EXPECT_DOUBLE_EQ(h->t, 2.0);
  h = cast_ray(shapes, up, 6.5);  // past the sphere: the box
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shape, 0);
  EXPECT_DOUBLE_EQ(h->t, 9.0);
  h = cast_ray(shapes, up, 12);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->shape, 2);
  EXPECT_FALSE(cast_ray(shapes, Ray{{0, 0, 0}, {0, 0, -1}}));
}

TEST(Shapes, DistancesToTheSurfaceMatchClosedForms) {
  const Eigen::Isometry3d T = some_pose();
  const Box box{T, {3, 2, 1}};
  EXPECT_NEAR(surface_distance(box, T * Eigen::Vector3d(5, 5, 1)), std::hypot(2, 3), 1e-12);
  EXPECT_NEAR(surface_distance(box, T * Eigen::Vector3d(0.5, 0, 0.2)), 0.8, 1e-12);  // inside
  EXPECT_TRUE(contains(box, T * Eigen::Vector3d(0.5, 0, 0.2)));
  EXPECT_FALSE(contains(box, T * Eigen::Vector3d(0.5, 0, 1.2)));
  const Cylinder cyl{T, 2, 3};
  EXPECT_NEAR(surface_distance(cyl, T * Eigen::Vector3d(3, 4, 0)), 3.0, 1e-12);  // ρ = 5
  EXPECT_NEAR(surface_distance(cyl, T * Eigen::Vector3d(0, 5, 7)), 5.0,
              1e-12);  // (3, 4) off the rim
  EXPECT_NEAR(surface_distance(cyl, T * Eigen::Vector3d(0, 0.5, 2.5)), 0.5, 1e-12);  // inside, cap
  const Sphere sphere{{1, 1, 1}, 2};
  EXPECT_NEAR(surface_distance(sphere, {1, 1, 7}), 4.0, 1e-12);
  EXPECT_NEAR(surface_distance(sphere, {1, 1, 1.5}), 1.5, 1e-12);
  const Rectangle rect{T, {4, 1}};
  EXPECT_NEAR(surface_distance(rect, T * Eigen::Vector3d(7, 0, 4)), 5.0, 1e-12);
  EXPECT_NEAR(surface_distance(rect, T * Eigen::Vector3d(1, 0, -2)), 2.0, 1e-12);
  EXPECT_FALSE(contains(rect, T * Eigen::Vector3d(1, 0, 0)));
}

TEST(Shapes, BoundingBoxesAreTight) {
  const Eigen::Isometry3d T = some_pose();
  const std::vector<Shape> shapes = {Box{T, {3, 2, 1}}, Cylinder{T, 2, 3}, Sphere{{1, 2, 3}, 2},
                                     Rectangle{T, {4, 1}}, Ellipsoid{T, {3, 2, 1}}};
  for (const Shape& shape : shapes) {
    const Eigen::AlignedBox3d box = bounding_box(shape);
    const PointCloud samples = sample_surface({shape}, 40000, 3);
    Eigen::AlignedBox3d seen;
    for (const auto& p : samples.positions) seen.extend(p);
    // Every sample inside; the extremes are reached to within a sampling gap.
    EXPECT_TRUE(box.contains(seen)) << shape.index();
    EXPECT_LT((box.min() - seen.min()).cwiseAbs().maxCoeff(), 0.15) << shape.index();
    EXPECT_LT((box.max() - seen.max()).cwiseAbs().maxCoeff(), 0.15) << shape.index();
  }
}

TEST(Shapes, TransformedShapesMoveRigidly) {
  const Eigen::Isometry3d T = some_pose();
  const Eigen::Isometry3d M = rigid_transform(-70, Eigen::Vector3d(0.2, 1, 1), {3, 4, -5});
  const std::vector<Shape> shapes = {Box{T, {3, 2, 1}},       Cylinder{T, 2, 3},
                                     Sphere{{1, 2, 3}, 2},    Rectangle{T, {4, 1}},
                                     Ellipsoid{T, {3, 2, 1}}, Plane{{0, 0.6, 0.8}, {0, 0, 5}}};
  const Eigen::Vector3d p(2, -1, 4);
  for (const Shape& s : shapes)
    EXPECT_NEAR(surface_distance(transformed(s, M), M * p), surface_distance(s, p), 1e-12)
        << s.index();
}

// The union's samples lie on its outer surface, with outward normals, uniform by area. Oracle: a
// unit sphere and a cylinder (r 0.5, z 0..2) on its top. Exposed: the sphere minus its cap above
// z = √0.75 (area 2π(1 − √0.75)); the cylinder's side above z = √0.75 and its top disk.
TEST(Shapes, SamplesCoverTheOuterSurfaceOfAUnionUniformly) {
  const std::vector<Shape> shapes = {
      Sphere{{0, 0, 0}, 1},
      Cylinder{rigid_transform(0, Eigen::Vector3d::UnitZ(), {0, 0, 1}), 0.5, 1}};
  const int n = 40000;
  const PointCloud cloud = sample_surface(shapes, n, 5);
  ASSERT_EQ(cloud.size(), static_cast<std::size_t>(n));
  ASSERT_TRUE(cloud.has_normals());
  int on_sphere = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.positions[i];
    const Eigen::Vector3d& nrm = cloud.normals[i];
    const double d0 = surface_distance(shapes[0], p), d1 = surface_distance(shapes[1], p);
    ASSERT_LT(std::min(d0, d1), 1e-12);
    // Inside neither part (the part it lies on only by rounding).
    ASSERT_FALSE((d0 > 1e-12 && contains(shapes[0], p)) || (d1 > 1e-12 && contains(shapes[1], p)));
    ASSERT_NEAR(nrm.norm(), 1.0, 1e-12);
    // Outward: a step along the normal leaves the union, a step against it enters it.
    ASSERT_FALSE(contains(shapes[0], p + 1e-9 * nrm) || contains(shapes[1], p + 1e-9 * nrm));
    ASSERT_TRUE(contains(shapes[0], p - 1e-9 * nrm) || contains(shapes[1], p - 1e-9 * nrm));
    on_sphere += d0 < 1e-12;
  }
  const double z = std::sqrt(0.75);
  const double sphere = 4 * kPi - 2 * kPi * (1 - z);
  const double cylinder = 2 * kPi * 0.5 * (2 - z) + kPi * 0.25;
  const double share = sphere / (sphere + cylinder);
  const double sd = std::sqrt(share * (1 - share) / n);  // binomial
  EXPECT_NEAR(on_sphere / static_cast<double>(n), share, 4 * sd);
}

// Ellipsoid hits: along a local axis the vertex, with that axis as the normal; any other ray's hit
// lies on the surface Σ (x_i / a_i)² = 1 with the normalised gradient (x_i / a_i²) as its normal.
TEST(Shapes, EllipsoidHitsLieOnItsSurfaceWithItsGradientAsNormal) {
  const Eigen::Isometry3d T = some_pose();
  const Ellipsoid e{T, {3, 2, 1}};
  expect_hit(intersect(e, local_ray(T, {10, 0, 0}, {9, 0, 0})), T * Eigen::Vector3d(3, 0, 0),
             T.linear().col(0), 7);
  expect_hit(intersect(e, local_ray(T, {0, 0, -5}, {0, 0, -4})), T * Eigen::Vector3d(0, 0, -1),
             -T.linear().col(2), 4);
  EXPECT_FALSE(intersect(e, local_ray(T, {0, 2.01, -5}, {0, 2.01, -4})).has_value());
  Random rng(4);
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d from(rng.uniform(-9, 9), rng.uniform(-9, 9), rng.uniform(-9, 9));
    const Eigen::Vector3d to(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-0.5, 0.5));
    const std::optional<Hit> h = intersect(e, local_ray(T, from, to));
    ASSERT_TRUE(h.has_value());  // aimed inside
    const Eigen::Vector3d l = T.inverse() * h->point;
    EXPECT_NEAR(l.cwiseQuotient(e.half_axes).squaredNorm(), 1.0, 1e-12);
    const Eigen::Vector3d g = T.linear() * Eigen::Vector3d(l.x() / 9, l.y() / 4, l.z());
    EXPECT_LT((h->normal - g.normalized()).norm(), 1e-12);
  }
}

// The distance (no closed form) against brute force over a fine grid of the surface, inside and
// outside; on an axis outside, the vertex; at the centre, the shortest semi-axis.
TEST(Shapes, EllipsoidDistanceMatchesBruteForce) {
  const Eigen::Isometry3d T = some_pose();
  const Ellipsoid e{T, {3, 2, 1}};
  EXPECT_NEAR(surface_distance(e, T * Eigen::Vector3d(0, -7, 0)), 5.0, 1e-12);
  EXPECT_NEAR(surface_distance(e, T * Eigen::Vector3d(0, 0, 0)), 1.0, 1e-12);
  std::vector<Eigen::Vector3d> grid;
  const int n = 1500;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double th = kPi * i / n, ph = kPi * j / n;
      grid.emplace_back(3 * std::sin(th) * std::cos(ph), 2 * std::sin(th) * std::sin(ph),
                        std::cos(th));
    }
  Random rng(8);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d q(rng.uniform(-5, 5), rng.uniform(-4, 4), rng.uniform(-3, 3));
    double best = kInfinity;
    for (const Eigen::Vector3d& g : grid) best = std::min(best, (g - q).squaredNorm());
    // The grid's gaps are at most 3π/1500 ≈ 0.006 apart: the brute force is above the truth by
    // less than the square of half a gap over the distance, and never below it.
    EXPECT_LT(surface_distance(e, T * q), std::sqrt(best) + 1e-12) << q.transpose();
    EXPECT_GT(surface_distance(e, T * q), std::sqrt(best) - 1e-4) << q.transpose();
    EXPECT_EQ(contains(e, T * q), q.cwiseQuotient(e.half_axes).squaredNorm() < 1);
  }
}

// The area against the spheroids' closed forms, and the samples uniform by area: the share above
// z = c/2 on a prolate spheroid against that zone's area, integrated here (Simpson) from the
// surface of revolution's profile r(z) = a·√(1 − z²/c²): dA = 2π·√(r² + (r·r')²) dz.
TEST(Shapes, EllipsoidAreaAndSamplingMatchTheSpheroids) {
  const double a = 1, c = 2;
  const double ep = std::sqrt(1 - a * a / (c * c));
  const double prolate = 2 * kPi * a * a * (1 + c / (a * ep) * std::asin(ep));
  EXPECT_NEAR(surface_area(Ellipsoid{some_pose(), {a, a, c}}), prolate, 1e-6 * prolate);
  const double eo = std::sqrt(1 - a * a / (c * c));  // oblate: semi-axes c, c, a
  const double oblate = 2 * kPi * c * c * (1 + (1 - eo * eo) / eo * std::atanh(eo));
  EXPECT_NEAR(surface_area(Ellipsoid{some_pose(), {c, c, a}}), oblate, 1e-6 * oblate);

  auto zone = [&](double z0, double z1) {
    const int m = 200000;
    const double h = (z1 - z0) / m;
    auto f = [&](double z) {
      const double r2 = a * a * (1 - z * z / (c * c)), rr = a * a * z / (c * c);  // r·r'
      return 2 * kPi * std::sqrt(std::max(0.0, r2) + rr * rr);
    };
    double sum = f(z0) + f(z1);
    for (int i = 1; i < m; ++i) sum += (i % 2 ? 4 : 2) * f(z0 + i * h);
    return sum * h / 3;
  };
  const Ellipsoid e{rigid_transform(0, Eigen::Vector3d::UnitZ()), {a, a, c}};
  const int n = 40000;
  const PointCloud cloud = sample_surface({e}, n, 6);
  int high = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.positions[i];
    ASSERT_NEAR(p.cwiseQuotient(e.half_axes).squaredNorm(), 1.0, 1e-12);
    const Eigen::Vector3d g(p.x() / (a * a), p.y() / (a * a), p.z() / (c * c));
    ASSERT_LT((cloud.normals[i] - g.normalized()).norm(), 1e-12);
    high += p.z() > c / 2;
  }
  const double share = zone(c / 2, c) / zone(-c, c);
  EXPECT_NEAR(zone(-c, c), prolate, 1e-6 * prolate);  // the quadrature is sound
  EXPECT_NEAR(high / static_cast<double>(n), share, 4 * std::sqrt(share * (1 - share) / n));
}

TEST(Shapes, SamplingIsDeterministicAndRejectsPlanes) {
  const std::vector<Shape> shapes = {Box{some_pose(), {3, 2, 1}}, Sphere{{1, 2, 3}, 2}};
  const PointCloud a = sample_surface(shapes, 1000, 9), b = sample_surface(shapes, 1000, 9);
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_NE(sample_surface(shapes, 1000, 10).positions, a.positions);
  EXPECT_THROW(sample_surface({Plane{}}, 10, 1), std::invalid_argument);
  EXPECT_THROW(sample_surface({Sphere{{0, 0, 0}, 1}}, -1, 1), std::invalid_argument);
}

}  // namespace
}  // namespace align3d::synth
