// Exact mesh queries (mesh_index.hpp) against independent oracles: closest points against a brute
// force over every triangle that works by projection and segment distances (not Ericson's
// regions), signs against the closed-form inside test of an L-shaped block (its concave edge and
// saddle corners included), rays against a brute-force intersection of every triangle.
#include "align3d/mesh_index.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "align3d/error.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/synth/bin_picking.hpp"
#include "detail/random.hpp"
#include "mesh_test_util.hpp"

namespace align3d {
namespace {

double sq_segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                           const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).squaredNorm();
}

// The squared distance from p to triangle abc: to the plane when p projects inside (barycentric
// coordinates by areas), otherwise to the nearest of the three edges.
double sq_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const Eigen::Vector3d q = p - n * ((p - a).dot(n) / n.squaredNorm());
  const double wa = (b - q).cross(c - q).dot(n), wb = (c - q).cross(a - q).dot(n),
               wc = (a - q).cross(b - q).dot(n);
  if (wa >= 0 && wb >= 0 && wc >= 0) return (p - q).squaredNorm();
  return std::min(
      {sq_segment_distance(p, a, b), sq_segment_distance(p, b, c), sq_segment_distance(p, c, a)});
}

double brute_sq_distance(const TriangleMesh& m, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles)
    best = std::min(best,
                    sq_triangle_distance(p, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]));
  return best;
}

// 400 random triangles of random sizes in a 10-unit cube: a soup with overlaps and slivers.
TriangleMesh random_soup(Random& rng) {
  TriangleMesh m;
  for (std::uint32_t t = 0; t < 400; ++t) {
    const Eigen::Vector3d c(rng.uniform(0, 10), rng.uniform(0, 10), rng.uniform(0, 10));
    const double size = std::pow(10.0, rng.uniform(-2, 0.3));
    for (int k = 0; k < 3; ++k)
      m.vertices.push_back(
          c + size * Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
    m.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
  }
  return m;
}

TEST(MeshIndex, ClosestPointMatchesBruteForceOnATriangleSoup) {
  Random rng(7);
  const TriangleMesh soup = random_soup(rng);
  const MeshIndex index(soup);
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d q(rng.uniform(-3, 13), rng.uniform(-3, 13), rng.uniform(-3, 13));
    SurfacePoint p;
    ASSERT_TRUE(index.closest(q, p));
    const double truth = brute_sq_distance(index.mesh(), q);
    EXPECT_NEAR(p.sq_distance, truth, 1e-9 * (1 + truth)) << i;
    EXPECT_NEAR((q - p.point).squaredNorm(), p.sq_distance, 1e-9 * (1 + truth));
    // The point lies on the triangle it names.
    const auto& t = index.mesh().triangles[p.triangle];
    EXPECT_LT(sq_triangle_distance(p.point, index.mesh().vertices[t[0]],
                                   index.mesh().vertices[t[1]], index.mesh().vertices[t[2]]),
              1e-18 * (1 + truth));
  }
}

TEST(MeshIndex, LimitAndBatchAnswerAsSingleQueriesWhateverTheThreads) {
  Random rng(8);
  const MeshIndex index(random_soup(rng));
  std::vector<Eigen::Vector3d> q(5000);
  for (auto& p : q) p = {rng.uniform(-1, 11), rng.uniform(-1, 11), rng.uniform(-1, 11)};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  T.pretranslate(Eigen::Vector3d(0.5, -0.2, 0.1));
  const double bound = 0.4;
  std::vector<SurfacePoint> one, two;
  index.closest_points(q, T, bound, 1, one);
  index.closest_points(q, T, bound, 2, two);
  std::size_t found = 0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    SurfacePoint single;
    const bool ok = index.closest(T * q[i], single, bound * bound);
    ASSERT_EQ(one[i].found(), ok) << i;
    EXPECT_EQ(one[i].triangle, two[i].triangle);
    EXPECT_EQ(one[i].point, two[i].point);
    if (!ok) continue;
    ++found;
    EXPECT_EQ(one[i].triangle, single.triangle);
    EXPECT_EQ(one[i].sq_distance, single.sq_distance);
    EXPECT_EQ(one[i].feature, single.feature);
  }
  EXPECT_GT(found, 500u);
  EXPECT_LT(found, q.size());
}

// Scan points lie within a fraction of a triangle of the surface, where the candidate grid
// answers: points on and around a tilted, finely tessellated sphere and cylinder (no face along
// an axis, so every separating axis of the grid's listing matters), each against the brute force;
// the ordered batch with a sink answers as the stored batch does.
TEST(MeshIndex, NearSurfaceQueriesMatchBruteForceOnTiltedFineMeshes) {
  Eigen::Isometry3d tilt = Eigen::Isometry3d::Identity();
  tilt.rotate(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 0.5).normalized()));
  tilt.pretranslate(Eigen::Vector3d(3.3, -1.2, 0.4));
  for (const TriangleMesh& shape : {synth::sphere_mesh(4, 40), synth::cylinder_mesh(2, 5, 64)}) {
    const TriangleMesh mesh = transformed(shape, tilt);
    const MeshIndex index(mesh, 2);
    const double edge = std::sqrt(surface_area(mesh) / static_cast<double>(mesh.triangles.size()));
    Random rng(11);
    const PointCloud samples = sample_surface(mesh, 1500, 3);
    std::vector<Eigen::Vector3d> q;
    for (std::size_t i = 0; i < samples.size(); ++i)
      q.push_back(
          samples.positions[i] +  // half of them within the grid's reach, about
          (i % 2 ? rng.uniform(-0.6, 0.6) : rng.uniform(-0.08, 0.08)) * edge * samples.normals[i] +
          (i % 2 ? 0.05 : 0.01) * edge * Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()));
    std::vector<SurfacePoint> stored;
    index.closest_points(q, Eigen::Isometry3d::Identity(), INFINITY, 2, stored);
    std::vector<SurfacePoint> sunk(q.size());
    std::vector<Eigen::Vector3d> seen(q.size());
    index.closest_points(q, spatial_order(q), Eigen::Isometry3d::Identity(), INFINITY, 2,
                         [&](std::size_t i, const Eigen::Vector3d& at, const SurfacePoint& p) {
                           sunk[i] = p;
                           seen[i] = at;
                         });
    std::vector<SurfacePoint> chosen(q.size());  // the order chosen by the index
    index.closest_points(
        q, Eigen::Isometry3d::Identity(), INFINITY, 2,
        [&](std::size_t i, const Eigen::Vector3d&, const SurfacePoint& p) { chosen[i] = p; });
    for (std::size_t i = 0; i < q.size(); ++i) {
      const double truth = brute_sq_distance(index.mesh(), q[i]);
      ASSERT_NEAR(stored[i].sq_distance, truth, 1e-12 * (1 + truth)) << i;
      EXPECT_EQ(sunk[i].sq_distance, stored[i].sq_distance) << i;
      EXPECT_EQ(sunk[i].triangle, stored[i].triangle) << i;
      EXPECT_EQ(chosen[i].sq_distance, stored[i].sq_distance) << i;
      EXPECT_EQ(chosen[i].triangle, stored[i].triangle) << i;
      EXPECT_EQ(seen[i], q[i]);
    }
  }
  const MeshIndex index(synth::sphere_mesh(1, 8));
  EXPECT_THROW(
      index.closest_points({Eigen::Vector3d::Zero()}, {}, Eigen::Isometry3d::Identity(), 1, 1,
                           [](std::size_t, const Eigen::Vector3d&, const SurfacePoint&) {}),
      std::invalid_argument);
}

// A scanner's raster (rows of points a fraction of a triangle apart) is coherent in its own order
// and searched in it; the same points shuffled are not, and are sorted first: the answers are the
// same bits either way, and the brute force's.
TEST(MeshIndex, RasterOrderIsSearchedAsGivenAndShuffledPointsAreSorted) {
  const MeshIndex index(synth::sphere_mesh(4, 40), 2);
  const double edge =
      std::sqrt(surface_area(index.mesh()) / static_cast<double>(index.mesh().triangles.size()));
  std::vector<Eigen::Vector3d> raster;  // rows of latitude, 0.2 edge apart along a row
  const double step = 0.2 * edge / 4.02;
  for (double lat = -1.4; lat < 1.4; lat += 0.1)
    for (double lon = 0; lon < 2 * M_PI; lon += step / std::cos(lat))
      raster.push_back(4.02 * Eigen::Vector3d(std::cos(lat) * std::cos(lon),
                                              std::cos(lat) * std::sin(lon), std::sin(lat)));
  std::vector<Eigen::Vector3d> shuffled = raster;
  Random rng(13);
  for (std::size_t i = shuffled.size() - 1; i > 0; --i)
    std::swap(shuffled[i],
              shuffled[static_cast<std::size_t>(rng.uniform(0, 1) * (i + 1)) % (i + 1)]);
  EXPECT_TRUE(index.coherent_order(raster));
  EXPECT_FALSE(index.coherent_order(shuffled));
  std::vector<Eigen::Vector3d> with_nan = raster;
  for (std::size_t i = 0; i < with_nan.size(); i += 2) with_nan[i].x() = std::nan("");
  EXPECT_FALSE(index.coherent_order(with_nan));  // half the steps undefined
  EXPECT_TRUE(index.coherent_order({Eigen::Vector3d::Zero()}));
  for (const auto* points : {&raster, &shuffled}) {
    std::vector<SurfacePoint> chosen(points->size()), stored;
    index.closest_points(*points, Eigen::Isometry3d::Identity(), INFINITY, 2, stored);
    index.closest_points(
        *points, Eigen::Isometry3d::Identity(), INFINITY, 2,
        [&](std::size_t i, const Eigen::Vector3d&, const SurfacePoint& p) { chosen[i] = p; });
    for (std::size_t i = 0; i < points->size(); ++i) {
      ASSERT_EQ(chosen[i].sq_distance, stored[i].sq_distance) << i;
      ASSERT_EQ(chosen[i].triangle, stored[i].triangle) << i;
      if (i % 97 == 0) {
        const double truth = brute_sq_distance(index.mesh(), (*points)[i]);
        ASSERT_NEAR(chosen[i].sq_distance, truth, 1e-12 * (1 + truth)) << i;
      }
    }
  }
}

// The hierarchy's subtrees are built in parallel: an index built on one thread and one built on
// two answer every query with the same bits.
TEST(MeshIndex, BuiltOnAnyNumberOfThreadsItAnswersTheSame) {
  const TriangleMesh mesh = synth::sphere_mesh(4, 30);
  const MeshIndex one(mesh, 1), two(mesh, 2);
  EXPECT_EQ(one.memory_bytes(), two.memory_bytes());
  Random rng(12);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d q(rng.uniform(-6, 6), rng.uniform(-6, 6), rng.uniform(-6, 6));
    SurfacePoint a, b;
    ASSERT_TRUE(one.closest(q, a));
    ASSERT_TRUE(two.closest(q, b));
    EXPECT_EQ(a.triangle, b.triangle);
    EXPECT_EQ(a.point, b.point);
    RayHit ra, rb;
    const Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
    ASSERT_EQ(one.intersect(q, d, ra), two.intersect(q, d, rb));
    EXPECT_EQ(ra.triangle, rb.triangle);
    EXPECT_EQ(ra.t, rb.t);
  }
}

// The side of every point near the L block: the inside test of its closed form. Points are taken
// around every corner and edge (the concave edge, the saddle corners at its ends) at distances from
// 1e-6 to 0.3, in random directions, and at random in and around the block.
TEST(MeshIndex, SignIsRightAtEveryEdgeAndCornerOfAConcaveBlock) {
  const TriangleMesh l = test::l_block();
  const MeshIndex index(l);
  Random rng(9);
  std::vector<Eigen::Vector3d> probes;
  const auto& v = l.vertices;
  for (const auto& t : l.triangles)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d a = v[t[k]], b = v[t[(k + 1) % 3]];
      for (const Eigen::Vector3d& centre : {a, Eigen::Vector3d(0.5 * (a + b))})
        for (int d = 0; d < 40; ++d) {
          Eigen::Vector3d dir(rng.normal(), rng.normal(), rng.normal());
          probes.push_back(centre + std::pow(10.0, rng.uniform(-6, -0.5)) * dir.normalized());
        }
    }
  for (int i = 0; i < 4000; ++i)
    probes.emplace_back(rng.uniform(-0.5, 2.5), rng.uniform(-0.5, 2.5), rng.uniform(-0.5, 1.5));
  int checked = 0;
  for (const Eigen::Vector3d& q : probes) {
    SurfacePoint p;
    ASSERT_TRUE(index.closest(q, p));
    const double d = index.signed_distance(q, p);
    if (std::abs(d) < 1e-9) continue;  // on the surface: either side
    ++checked;
    EXPECT_EQ(d < 0, test::l_block_contains(q))
        << q.transpose() << " d " << d << " feature " << to_string(p.feature);
    EXPECT_NEAR(d * d, brute_sq_distance(l, q), 1e-12);
  }
  EXPECT_GT(checked, 8500);  // of 8800
}

TEST(MeshIndex, SignSurvivesASoupWithMixedWindings) {
  TriangleMesh m = test::unwelded(test::l_block());
  for (std::size_t t = 0; t < m.triangles.size(); t += 3)
    std::swap(m.triangles[t][1], m.triangles[t][2]);
  const MeshIndex index(m);
  EXPECT_GT(index.repair().flipped_triangles, 0u);
  EXPECT_TRUE(index.topology().closed());
  EXPECT_EQ(index.topology().inconsistent_edges, 0u);
  Random rng(10);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d q(rng.uniform(-0.5, 2.5), rng.uniform(-0.5, 2.5), rng.uniform(-0.5, 1.5));
    SurfacePoint p;
    ASSERT_TRUE(index.closest(q, p));
    const double d = index.signed_distance(q, p);
    if (std::abs(d) > 1e-9) {
      EXPECT_EQ(d < 0, test::l_block_contains(q)) << q.transpose();
    }
  }
}

TEST(MeshIndex, PseudoNormalsOfACube) {
  const MeshIndex index(test::box_mesh({0, 0, 0}, {1, 1, 1}));
  SurfacePoint corner, edge, face;
  ASSERT_TRUE(index.closest({2, 2, 2}, corner));
  EXPECT_TRUE(index.pseudo_normal(corner).isApprox(Eigen::Vector3d(1, 1, 1).normalized(), 1e-12));
  ASSERT_TRUE(index.closest({2, 0.5, 2}, edge));
  EXPECT_TRUE(index.pseudo_normal(edge).isApprox(Eigen::Vector3d(1, 0, 1).normalized(), 1e-12));
  ASSERT_TRUE(index.closest({0.3, 0.4, 5}, face));
  EXPECT_EQ(face.feature, MeshFeature::kFace);
  EXPECT_TRUE(index.pseudo_normal(face).isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_NEAR(index.signed_distance({0.3, 0.4, 5}, face), 4, 1e-12);
  SurfacePoint inside;
  ASSERT_TRUE(index.closest({0.5, 0.5, 0.9}, inside));
  EXPECT_NEAR(index.signed_distance({0.5, 0.5, 0.9}, inside), -0.1, 1e-12);
}

TEST(MeshIndex, RaysHitTheFirstTriangleAsBruteForceSays) {
  Random rng(11);
  const MeshIndex index(random_soup(rng));
  const TriangleMesh& m = index.mesh();
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d o(rng.uniform(-5, 15), rng.uniform(-5, 15), rng.uniform(-5, 15));
    const Eigen::Vector3d d =
        Eigen::Vector3d(5, 5, 5) - o + 3 * Eigen::Vector3d(rng.normal(), rng.normal(), 0);
    double truth = std::numeric_limits<double>::infinity();
    for (const auto& t : m.triangles) {  // plane hit, then the inside test by signed areas
      const Eigen::Vector3d a = m.vertices[t[0]], b = m.vertices[t[1]], c = m.vertices[t[2]];
      const Eigen::Vector3d n = (b - a).cross(c - a);
      const double s = (a - o).dot(n) / d.dot(n);
      if (!(s > 0)) continue;
      const Eigen::Vector3d x = o + s * d;
      const double wa = (b - x).cross(c - x).dot(n), wb = (c - x).cross(a - x).dot(n),
                   wc = (a - x).cross(b - x).dot(n);
      if (wa >= 0 && wb >= 0 && wc >= 0) truth = std::min(truth, s);
    }
    RayHit hit;
    const bool ok = index.intersect(o, d, hit);
    ASSERT_EQ(ok, std::isfinite(truth)) << i;
    if (!ok) continue;
    ++hits;
    EXPECT_NEAR(hit.t, truth, 1e-9 * truth);
    const auto& t = m.triangles[hit.triangle];
    const Eigen::Vector3d x = (1 - hit.u - hit.v) * m.vertices[t[0]] + hit.u * m.vertices[t[1]] +
                              hit.v * m.vertices[t[2]];
    EXPECT_LT((x - (o + hit.t * d)).norm(), 1e-9);
  }
  EXPECT_GT(hits, 200);
}

TEST(MeshIndex, RayRangeAndAxisParallelRays) {
  const MeshIndex index(test::box_mesh({0, 0, 0}, {1, 1, 1}));
  RayHit hit;
  ASSERT_TRUE(index.intersect({0.5, 0.5, 5}, {0, 0, -1}, hit));
  EXPECT_NEAR(hit.t, 4, 1e-12);
  ASSERT_TRUE(index.intersect({0.5, 0.5, 5}, {0, 0, -1}, hit, 4.5));  // the far side
  EXPECT_NEAR(hit.t, 5, 1e-12);
  EXPECT_FALSE(index.intersect({0.5, 0.5, 5}, {0, 0, -1}, hit, 0, 3.9));
  EXPECT_FALSE(index.intersect({2, 0.5, 5}, {0, 0, -1}, hit));
  ASSERT_TRUE(index.intersect({0.5, 0.5, 0.5}, {1, 0, 0}, hit));  // from inside
  EXPECT_NEAR(hit.t, 0.5, 1e-12);
}

TEST(MeshIndex, RefusesMeshesWithNothingToMeasure) {
  EXPECT_THROW(MeshIndex(TriangleMesh{}), DataError);
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.triangles = {{0, 1, 2}, {0, 0, 1}};
  try {
    MeshIndex index(flat, 0, "cad.stl");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "cad.stl");
    EXPECT_NE(std::string(e.what()).find("degenerate"), std::string::npos);
  }
}

}  // namespace
}  // namespace align3d
