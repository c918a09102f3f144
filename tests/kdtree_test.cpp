// KdTree. Oracle: a brute-force scan over all points, with the squared distance summed in the same
// order as nanoflann's L2_Simple_Adaptor (dx² + dy² + dz²), so equal distances compare exactly.
#include "align3d/kdtree.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "detail/float_round.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

using test::kInf;

double sq_dist(const Eigen::Vector3d& query, const Eigen::Vector3d& p) {
  double sum = 0;
  for (int d = 0; d < 3; ++d) {
    const double diff = query[d] - p[d];
    sum += diff * diff;
  }
  return sum;
}

std::vector<double> brute_sorted_sq_distances(const std::vector<Eigen::Vector3d>& points,
                                              const Eigen::Vector3d& query) {
  std::vector<double> d;
  d.reserve(points.size());
  for (const auto& p : points) d.push_back(sq_dist(query, p));
  std::sort(d.begin(), d.end());
  return d;
}

std::vector<Eigen::Vector3d> random_points(std::size_t n, Random& rng) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double x = rng.uniform(-1, 1), y = rng.uniform(-1, 1), z = rng.uniform(-1, 1);
    points.emplace_back(x, y, z);
  }
  return points;
}

// Queries: points of the cloud themselves (distance 0 ties with duplicates) and random points in a
// box a little larger than the cloud's.
std::vector<Eigen::Vector3d> queries_for(const std::vector<Eigen::Vector3d>& points, Random& rng) {
  std::vector<Eigen::Vector3d> queries;
  for (std::size_t i = 0; i < std::min<std::size_t>(points.size(), 20); ++i)
    queries.push_back(points[rng.below(points.size())]);
  for (int i = 0; i < 60; ++i) {
    const double x = rng.uniform(-1.5, 1.5), y = rng.uniform(-1.5, 1.5), z = rng.uniform(-1.5, 1.5);
    queries.emplace_back(x, y, z);
  }
  return queries;
}

// Checks nearest, knn (several k, including k > N) and radius for every query against brute force.
void check_against_brute_force(const std::vector<Eigen::Vector3d>& points, Random& rng) {
  const KdTree tree(points);
  ASSERT_EQ(tree.size(), points.size());
  const std::size_t n = points.size();
  std::vector<Neighbor> found;
  for (const auto& query : queries_for(points, rng)) {
    const std::vector<double> brute = brute_sorted_sq_distances(points, query);

    Neighbor nb;
    ASSERT_TRUE(tree.nearest(query, nb));
    ASSERT_LT(nb.index, n);
    EXPECT_EQ(nb.sq_distance, brute[0]);
    EXPECT_EQ(sq_dist(query, points[nb.index]), nb.sq_distance);

    for (std::size_t k :
         {std::size_t{1}, std::size_t{2}, std::size_t{7}, std::size_t{20}, n, n + 5}) {
      tree.knn(query, k, found);
      ASSERT_EQ(found.size(), std::min(k, n)) << "k = " << k;
      std::set<std::size_t> distinct;
      for (std::size_t i = 0; i < found.size(); ++i) {
        ASSERT_LT(found[i].index, n);
        distinct.insert(found[i].index);
        // The i-th reported distance is the i-th smallest, and it is the distance of that index.
        EXPECT_EQ(found[i].sq_distance, brute[i]) << "k = " << k << ", rank " << i;
        EXPECT_EQ(sq_dist(query, points[found[i].index]), found[i].sq_distance);
      }
      EXPECT_EQ(distinct.size(), found.size()) << "an index reported twice";

      // knn_unsorted: the same distances once sorted, each that of its index, no index twice.
      tree.knn_unsorted(query, k, found);
      ASSERT_EQ(found.size(), std::min(k, n)) << "k = " << k;
      std::vector<double> sorted;
      distinct.clear();
      for (const auto& m : found) {
        ASSERT_LT(m.index, n);
        distinct.insert(m.index);
        EXPECT_EQ(sq_dist(query, points[m.index]), m.sq_distance);
        sorted.push_back(m.sq_distance);
      }
      EXPECT_EQ(distinct.size(), found.size()) << "an index reported twice";
      std::sort(sorted.begin(), sorted.end());
      for (std::size_t i = 0; i < sorted.size(); ++i)
        EXPECT_EQ(sorted[i], brute[i]) << "unsorted, k = " << k << ", rank " << i;
    }

    // Radii between the 0th and ~30th smallest distance. A radius with a point exactly on it is
    // skipped here (that boundary has its own test, RadiusIncludesPointsExactlyOnTheRadius).
    for (double sq_r : {brute[0] * 0.5, brute[std::min<std::size_t>(n - 1, 3)] * 1.0001,
                        brute[std::min<std::size_t>(n - 1, 30)] * 0.9999, 10.0}) {
      if (std::binary_search(brute.begin(), brute.end(), sq_r)) continue;
      tree.radius(query, sq_r, found);
      std::set<std::size_t> expected;
      for (std::size_t i = 0; i < n; ++i)
        if (sq_dist(query, points[i]) <= sq_r) expected.insert(i);
      std::set<std::size_t> got;
      for (std::size_t i = 0; i < found.size(); ++i) {
        got.insert(found[i].index);
        if (i > 0) {
          EXPECT_LE(found[i - 1].sq_distance, found[i].sq_distance) << "not sorted";
        }
      }
      EXPECT_EQ(got.size(), found.size()) << "an index reported twice";
      EXPECT_EQ(got, expected) << "sq_radius = " << sq_r;
      // radius_unsorted: the same set, each with its own distance.
      tree.radius_unsorted(query, sq_r, found);
      got.clear();
      for (const auto& m : found) {
        got.insert(m.index);
        EXPECT_EQ(sq_dist(query, points[m.index]), m.sq_distance);
      }
      EXPECT_EQ(got.size(), found.size()) << "unsorted: an index reported twice";
      EXPECT_EQ(got, expected) << "unsorted, sq_radius = " << sq_r;
    }
  }
}

TEST(KdTree, AgreesWithBruteForceOnOnePoint) {
  Random rng(101);
  check_against_brute_force(random_points(1, rng), rng);
}

TEST(KdTree, AgreesWithBruteForceOnTwoPoints) {
  Random rng(102);
  check_against_brute_force(random_points(2, rng), rng);
}

TEST(KdTree, AgreesWithBruteForceOnThousandPoints) {
  Random rng(103);
  check_against_brute_force(random_points(1000, rng), rng);
}

TEST(KdTree, AgreesWithBruteForceWithDuplicatePoints) {
  // 150 distinct points, each present 4 times, shuffled: many exact ties in every query.
  Random rng(104);
  const std::vector<Eigen::Vector3d> distinct = random_points(150, rng);
  std::vector<Eigen::Vector3d> points;
  for (int copy = 0; copy < 4; ++copy)
    points.insert(points.end(), distinct.begin(), distinct.end());
  for (std::size_t i = points.size() - 1; i > 0; --i)
    std::swap(points[i], points[rng.below(i + 1)]);
  check_against_brute_force(points, rng);
}

TEST(KdTree, AgreesWithBruteForceWhenAllPointsCoincide) {
  Random rng(105);
  const std::vector<Eigen::Vector3d> points(40, Eigen::Vector3d(0.25, -0.5, 0.75));
  check_against_brute_force(points, rng);
}

TEST(KdTree, BoundedNearestIsFalseExactlyWhenNothingIsStrictlyInsideTheBound) {
  Random rng(106);
  const std::vector<Eigen::Vector3d> points = random_points(500, rng);
  const KdTree tree(points);
  for (const auto& query : queries_for(points, rng)) {
    const std::vector<double> brute = brute_sorted_sq_distances(points, query);
    // Bounds below, exactly at, and above the nearest squared distance, plus a second-nearest one.
    for (double bound : {0.0, brute[0] * 0.999, brute[0], brute[0] * 1.001, brute[1], kInf}) {
      const bool expected = brute[0] < bound;  // the documented exclusive bound
      Neighbor nb;
      const bool got = tree.nearest(query, nb, bound);
      ASSERT_EQ(got, expected) << "bound " << bound << ", nearest " << brute[0];
      if (got) {
        EXPECT_EQ(nb.sq_distance, brute[0]);
        EXPECT_EQ(sq_dist(query, points[nb.index]), brute[0]);
      }
    }
  }
}

TEST(KdTree, BoundedNearestOnExactGridDistances) {
  // Integer coordinates make every squared distance exact, so the boundary case is unambiguous.
  const std::vector<Eigen::Vector3d> points = {{1, 0, 0}, {0, 2, 0}, {0, 0, -3}};
  const KdTree tree(points);
  Neighbor nb;
  EXPECT_FALSE(tree.nearest(Eigen::Vector3d::Zero(), nb, 1.0));  // exclusive: distance² = 1 is out
  ASSERT_TRUE(tree.nearest(Eigen::Vector3d::Zero(), nb, std::nextafter(1.0, 2.0)));
  EXPECT_EQ(nb.index, 0u);
  EXPECT_EQ(nb.sq_distance, 1.0);
  ASSERT_TRUE(tree.nearest(Eigen::Vector3d(0, 0, -2), nb, 1.5));
  EXPECT_EQ(nb.index, 2u);
  EXPECT_EQ(nb.sq_distance, 1.0);
}

// nearest_two: the same point as nearest() (on a grid of exact ties too, where the tie is broken
// by the search's order), and the second smallest squared distance by brute force, or the bound
// when no other point lies strictly within it; with and without a bound.
TEST(KdTree, NearestTwoGivesTheNearestPointAndTheNextDistance) {
  Random rng(17);
  std::vector<Eigen::Vector3d> points = random_points(2000, rng);
  for (int x = 0; x < 6; ++x)
    for (int y = 0; y < 6; ++y)
      for (int z = 0; z < 3; ++z) points.emplace_back(2 + x, y, z);  // integer grid: exact ties
  points.push_back(points[5]);                                       // a duplicate
  const KdTree tree(points);
  std::vector<Eigen::Vector3d> queries = queries_for(points, rng);
  for (int k = 0; k < 200; ++k)  // grid midpoints: several points at exactly the same distance
    queries.emplace_back(2.5 + k % 5, 0.5 * (k % 11), 0.5 * (k % 5));
  int ties = 0;
  for (const double bound : {kInf, 0.01, 0.3})
    for (const Eigen::Vector3d& q : queries) {
      const std::vector<double> d = brute_sorted_sq_distances(points, q);
      Neighbor one, two;
      double sq_second = -1;
      const bool found = tree.nearest(q, one, bound);
      ASSERT_EQ(tree.nearest_two(q, two, sq_second, bound), found);
      const double expected_second = d[1] < bound ? d[1] : bound;
      EXPECT_EQ(sq_second, expected_second) << q.transpose() << " bound " << bound;
      if (!found) continue;
      EXPECT_EQ(two.index, one.index) << q.transpose() << " bound " << bound;
      EXPECT_EQ(two.sq_distance, d[0]);
      ties += d[1] == d[0];
    }
  EXPECT_GT(ties, 100);  // the tie-breaking was exercised
}

TEST(KdTree, RadiusIncludesPointsExactlyOnTheRadius) {
  // kdtree.hpp documents radius() as "squared distance <= sq_radius". On an integer grid the six
  // axis neighbours of the origin are at squared distance exactly 1, so with sq_radius = 1 the
  // result must hold the origin and those six (7 points), not only the origin.
  std::vector<Eigen::Vector3d> points;
  for (int x = -2; x <= 2; ++x)
    for (int y = -2; y <= 2; ++y)
      for (int z = -2; z <= 2; ++z) points.emplace_back(x, y, z);
  const KdTree tree(points);
  std::vector<Neighbor> found;
  tree.radius(Eigen::Vector3d::Zero(), 1.0, found);
  std::size_t expected = 0;
  for (const auto& p : points) expected += sq_dist(Eigen::Vector3d::Zero(), p) <= 1.0;
  ASSERT_EQ(expected, 7u);
  EXPECT_EQ(found.size(), expected) << "points at squared distance == sq_radius are left out";
  for (const auto& nb : found) EXPECT_LE(nb.sq_distance, 1.0);
}

TEST(KdTree, EmptyTreeFindsNothing) {
  const std::vector<Eigen::Vector3d> points;
  const KdTree tree(points);
  EXPECT_EQ(tree.size(), 0u);
  Neighbor nb;
  EXPECT_FALSE(tree.nearest(Eigen::Vector3d::Zero(), nb));
  std::vector<Neighbor> found(3);  // stale content must be cleared
  tree.knn(Eigen::Vector3d::Zero(), 5, found);
  EXPECT_TRUE(found.empty());
  found.resize(3);
  tree.knn_unsorted(Eigen::Vector3d::Zero(), 5, found);
  EXPECT_TRUE(found.empty());
  found.resize(3);
  tree.radius(Eigen::Vector3d::Zero(), 100.0, found);
  EXPECT_TRUE(found.empty());
}

TEST(KdTree, KnnWithKLargerThanSizeReturnsAllPointsSorted) {
  Random rng(107);
  const std::vector<Eigen::Vector3d> points = random_points(9, rng);
  const KdTree tree(points);
  std::vector<Neighbor> found;
  const Eigen::Vector3d query(0.1, 0.2, 0.3);
  tree.knn(query, 1000, found);
  ASSERT_EQ(found.size(), points.size());
  std::set<std::size_t> indices;
  for (const auto& nb : found) indices.insert(nb.index);
  EXPECT_EQ(indices.size(), points.size());
  const std::vector<double> brute = brute_sorted_sq_distances(points, query);
  for (std::size_t i = 0; i < found.size(); ++i) EXPECT_EQ(found[i].sq_distance, brute[i]);
  tree.knn(query, 0, found);
  EXPECT_TRUE(found.empty());
}

TEST(KdTree, ConcurrentQueriesGiveTheSameAnswers) {
  // The header allows concurrent const queries (knn/radius use thread_local scratch space).
  Random rng(108);
  const std::vector<Eigen::Vector3d> points = random_points(2000, rng);
  const KdTree tree(points);
  const std::vector<Eigen::Vector3d> queries = random_points(400, rng);
  std::vector<std::vector<Neighbor>> serial(queries.size()), parallel(queries.size());
  for (std::size_t i = 0; i < queries.size(); ++i) tree.knn(queries[i], 8, serial[i]);
  // Two threads of our own, taking alternate queries, so that both surely run.
  auto half = [&](std::size_t first) {
    for (std::size_t i = first; i < queries.size(); i += 2) tree.knn(queries[i], 8, parallel[i]);
  };
  std::thread other(half, 1);
  half(0);
  other.join();
  for (std::size_t i = 0; i < queries.size(); ++i) {
    ASSERT_EQ(serial[i].size(), parallel[i].size());
    for (std::size_t j = 0; j < serial[i].size(); ++j) {
      EXPECT_EQ(serial[i][j].index, parallel[i][j].index);
      EXPECT_EQ(serial[i][j].sq_distance, parallel[i][j].sq_distance);
    }
  }
}

TEST(KdTree, ParallelBuildGivesTheSameTreeAsSerial) {
  // Above 2 048 points the top levels and then the subtrees are built in parallel (more subtrees
  // for more threads); the tree, and so every answer, must not depend on the thread count, and
  // must still be exact.
  Random rng(109);
  const std::vector<Eigen::Vector3d> points = random_points(150000, rng);
  const KdTree serial(points, 1), parallel(points, 2);
  for (int threads : {2, 3, 8}) {
    const KdTree other(points, threads);
    EXPECT_EQ(other.leaf_order(), serial.leaf_order()) << threads << " threads";
  }
  std::vector<Neighbor> a, b;
  for (int q = 0; q < 40; ++q) {
    const Eigen::Vector3d query(rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2),
                                rng.uniform(-1.2, 1.2));
    serial.knn(query, 12, a);
    parallel.knn(query, 12, b);
    ASSERT_EQ(a.size(), 12u);
    ASSERT_EQ(b.size(), 12u);
    std::vector<double> brute;
    for (const auto& p : points) brute.push_back(sq_dist(query, p));
    std::partial_sort(brute.begin(), brute.begin() + 12, brute.end());
    for (std::size_t j = 0; j < 12; ++j) {
      EXPECT_EQ(a[j].index, b[j].index);
      EXPECT_EQ(a[j].sq_distance, brute[j]);
      EXPECT_EQ(b[j].sq_distance, brute[j]);
    }
  }
}

TEST(KdTree, NanQueriesFindNothing) {
  Random rng(110);
  const KdTree tree(random_points(100, rng));
  const Eigen::Vector3d nan_query(0, std::numeric_limits<double>::quiet_NaN(), 0);
  Neighbor nb;
  EXPECT_FALSE(tree.nearest(nan_query, nb));
  std::vector<Neighbor> found(3);
  tree.knn(nan_query, 5, found);
  EXPECT_TRUE(found.empty());
  found.resize(3);
  tree.knn_unsorted(nan_query, 5, found);
  EXPECT_TRUE(found.empty());
  tree.radius(nan_query, 1.0, found);
  EXPECT_TRUE(found.empty());
}

TEST(KdTree, RejectsNonFinitePoints) {
  std::vector<Eigen::Vector3d> points(10, Eigen::Vector3d(1, 2, 3));
  points[7].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(KdTree{points}, std::invalid_argument);
  points[7].y() = kInf;
  EXPECT_THROW(KdTree{points}, std::invalid_argument);
}

TEST(KdTree, KeepsItsOwnCopyOfThePoints) {
  Random rng(77);
  std::vector<Eigen::Vector3d> points(500);
  for (auto& p : points) p = {rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)};
  const std::vector<Eigen::Vector3d> kept = points;
  const KdTree tree(points);
  for (auto& p : points) p.setConstant(1e9);  // the caller reuses its buffer
  points.clear();
  for (int q = 0; q < 50; ++q) {
    const Eigen::Vector3d query(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    Neighbor nb;
    ASSERT_TRUE(tree.nearest(query, nb));
    double best = std::numeric_limits<double>::infinity();
    for (const auto& p : kept) best = std::min(best, (p - query).squaredNorm());
    EXPECT_EQ(nb.sq_distance, best);
    EXPECT_EQ((kept[nb.index] - query).squaredNorm(), best);
  }
}

// The float bounds of the kd-tree's and the mesh hierarchy's boxes: the nearest float on the
// right side of v, v itself when it is a float; beyond float's range, ±FLT_MAX or ±inf.
TEST(FloatRound, GivesTheNearestFloatOnEachSide) {
  Random rng(79);
  std::vector<double> values = {0.0, -0.0, 1.0, 0.1, -0.1, 1e-45, 3.5e38, -3.5e38, 1e300, -1e300};
  for (int k = 0; k < 2000; ++k)
    values.push_back(rng.uniform(-1, 1) * std::pow(10, rng.uniform(-30, 30)));
  for (double v : values) {
    const float lo = detail::round_down(v), hi = detail::round_up(v);
    EXPECT_LE(static_cast<double>(lo), v) << v;
    EXPECT_GE(static_cast<double>(hi), v) << v;
    if (static_cast<double>(static_cast<float>(v)) == v) {
      EXPECT_EQ(lo, static_cast<float>(v));
      EXPECT_EQ(hi, static_cast<float>(v));
    } else {  // adjacent floats around v
      EXPECT_EQ(std::nextafter(lo, std::numeric_limits<float>::infinity()), hi) << v;
    }
  }
  EXPECT_EQ(detail::round_down(1e300), std::numeric_limits<float>::max());
  EXPECT_EQ(detail::round_up(1e300), std::numeric_limits<float>::infinity());
}

// 60 000 points: several chunks of spatial_order's first pass; most lie in a small cluster, so
// that its buckets are large (sorted by counting) while the scattered rest leaves small ones
// (sorted whole); and 300 duplicates.
std::vector<Eigen::Vector3d> clustered_points() {
  Random rng(78);
  std::vector<Eigen::Vector3d> points(60000);
  for (std::size_t i = 0; i < points.size(); ++i)
    points[i] =
        i % 8 == 0
            ? Eigen::Vector3d(rng.uniform(-5, 5), rng.uniform(0, 2), rng.uniform(10, 11))
            : Eigen::Vector3d(rng.uniform(1, 1.3), rng.uniform(0.5, 0.6), rng.uniform(10.2, 10.25));
  for (int k = 0; k < 300; ++k) points.push_back(points[17 + 7 * k]);
  return points;
}

// Oracle: the Morton key built bit by bit, and a stable sort by it.
TEST(SpatialOrder, IsTheStableSortByInterleavedGridCoordinates) {
  const std::vector<Eigen::Vector3d> points = clustered_points();
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  auto key = [&](const Eigen::Vector3d& p) {
    std::uint32_t k = 0;
    for (int axis = 0; axis < 3; ++axis) {
      const double scaled = (p[axis] - box.min()[axis]) * 1023.0 / box.sizes()[axis];
      const auto cell = static_cast<std::uint32_t>(std::clamp(scaled, 0.0, 1023.0));
      for (int bit = 0; bit < 10; ++bit) k |= ((cell >> bit) & 1u) << (3 * bit + axis);
    }
    return k;
  };
  std::vector<std::uint32_t> expected(points.size());
  for (std::size_t i = 0; i < expected.size(); ++i) expected[i] = static_cast<std::uint32_t>(i);
  std::stable_sort(expected.begin(), expected.end(), [&](std::uint32_t a, std::uint32_t b) {
    return key(points[a]) < key(points[b]);
  });
  EXPECT_EQ(spatial_order(points), expected);
  EXPECT_EQ(spatial_order(points, 2), expected);  // two threads
  EXPECT_EQ(spatial_order(points, 3), expected);
}

// Points with a NaN or infinite coordinate leave the box and the others' order alone.
TEST(SpatialOrder, NonFinitePointsDoNotMoveTheOthers) {
  const std::vector<Eigen::Vector3d> finite = clustered_points();
  const std::vector<std::uint32_t> expected = spatial_order(finite);  // checked by the oracle
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<Eigen::Vector3d> odd = {{std::nan(""), 0, 0}, {1, inf, 2}, {-inf, 0, inf}};
  std::vector<Eigen::Vector3d> points;
  std::vector<std::uint32_t> finite_index;  // for each of `points`, its place in `finite` or -1
  for (std::size_t i = 0; i < finite.size(); ++i) {
    if (i % 5000 == 0) {
      points.push_back(odd[i / 5000 % odd.size()]);
      finite_index.push_back(0xffffffffu);
    }
    points.push_back(finite[i]);
    finite_index.push_back(static_cast<std::uint32_t>(i));
  }
  for (int threads : {1, 2}) {
    const std::vector<std::uint32_t> order = spatial_order(points, threads);
    std::vector<std::uint32_t> kept;
    for (std::uint32_t i : order)
      if (finite_index[i] != 0xffffffffu) kept.push_back(finite_index[i]);
    EXPECT_EQ(order.size(), points.size());
    EXPECT_EQ(kept, expected);
  }
  EXPECT_EQ(spatial_order(odd).size(), 3u);  // no finite point at all
}

TEST(SpatialOrder, HandlesEmptyFlatAndSinglePointInputs) {
  EXPECT_TRUE(spatial_order({}).empty());
  EXPECT_EQ(spatial_order({Eigen::Vector3d(1, 2, 3)}), std::vector<std::uint32_t>{0});
  // Non-finite coordinates do not break it (the order stays a permutation).
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::uint32_t> odd = spatial_order(
      {{0, 0, 0}, {nan, 1, 2}, {1, 1, 1}, {std::numeric_limits<double>::infinity(), 0, 0}});
  std::sort(odd.begin(), odd.end());
  EXPECT_EQ(odd, (std::vector<std::uint32_t>{0, 1, 2, 3}));
  // All points on the plane z = 4: the flat axis has zero extent.
  const std::vector<Eigen::Vector3d> flat = {{1, 1, 4}, {0, 0, 4}, {1, 0, 4}, {0, 1, 4}};
  EXPECT_EQ(spatial_order(flat), (std::vector<std::uint32_t>{1, 2, 3, 0}));
}

}  // namespace
}  // namespace align3d
