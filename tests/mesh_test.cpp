// The triangle mesh (mesh.hpp): cleaning (welding, dropping, re-winding), topology counts and even
// surface sampling, on prisms whose geometry is known in closed form.
#include "align3d/mesh.hpp"

#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>

#include "align3d/error.hpp"
#include "align3d/synth/bin_picking.hpp"
#include "detail/random.hpp"
#include "mesh_test_util.hpp"

namespace align3d {
namespace {

TEST(Mesh, AreaVolumeAndDiagonalOfABox) {
  const TriangleMesh box = test::box_mesh({0, 0, 0}, {3, 2, 1});
  EXPECT_NEAR(surface_area(box), 2 * (6 + 3 + 2), 1e-12);
  EXPECT_NEAR(analyse_topology(box).signed_volume, 6, 1e-12);
  EXPECT_NEAR(bounding_box_diagonal(box), std::sqrt(14.0), 1e-12);
  const MeshTopology t = analyse_topology(box);
  EXPECT_TRUE(t.closed());
  EXPECT_EQ(t.vertices, 8u);
  EXPECT_EQ(t.triangles, 12u);
  EXPECT_EQ(t.inconsistent_edges, 0u);
  EXPECT_EQ(t.components, 1u);
}

TEST(Mesh, CleanWeldsAnStlSoupIntoAClosedSolid) {
  const TriangleMesh soup = test::unwelded(test::l_block());
  EXPECT_EQ(analyse_topology(soup).boundary_edges, 3 * soup.triangles.size());
  MeshRepair r;
  const TriangleMesh clean = clean_mesh(soup, &r);
  EXPECT_EQ(clean.vertices.size(), 12u);
  EXPECT_EQ(r.welded_vertices, soup.vertices.size() - 12);
  EXPECT_EQ(r.flipped_triangles, 0u);
  const MeshTopology t = analyse_topology(clean);
  EXPECT_TRUE(t.closed());
  EXPECT_EQ(t.inconsistent_edges, 0u);
  EXPECT_NEAR(t.signed_volume, 3, 1e-12);  // the L: three unit squares, height 1
}

// Welding (mesh.cpp, weld) against a brute-force oracle: 27 000 facets, each with its own three
// corners (81 000 vertices), half the zeros written as −0, and 500 unused vertices first,
// identical to used ones. The welded vertices are numbered in order of first use, each the
// coordinates of its first corner.
TEST(Mesh, WeldNumbersIdenticalVerticesByFirstUse) {
  TriangleMesh grid;  // a height field over 150 × 90 quads, wound consistently: nothing to repair
  auto corner = [](int i, int j, bool negative_zero) {
    const double x = i == 0 && negative_zero ? -0.0 : i, y = j == 0 && negative_zero ? -0.0 : j;
    return Eigen::Vector3d(x, y, 0.01 * ((i * 7 + j * 3) % 11));
  };
  for (int i = 0; i < 150; ++i)
    for (int j = 0; j < 90; ++j)
      for (const auto& tri : {std::array<std::array<int, 2>, 3>{{{0, 0}, {1, 0}, {1, 1}}},
                              std::array<std::array<int, 2>, 3>{{{0, 0}, {1, 1}, {0, 1}}}}) {
        std::array<std::uint32_t, 3> f;
        for (int k = 0; k < 3; ++k) {
          f[k] = static_cast<std::uint32_t>(grid.vertices.size());
          grid.vertices.push_back(corner(i + tri[k][0], j + tri[k][1], (i + j + k) % 2 == 0));
        }
        grid.triangles.push_back(f);
      }
  TriangleMesh soup;
  for (int k = 0; k < 500; ++k) soup.vertices.push_back(grid.vertices[(k * 977) % 81000]);
  soup.vertices.insert(soup.vertices.end(), grid.vertices.begin(), grid.vertices.end());
  for (auto f : grid.triangles) soup.triangles.push_back({f[0] + 500, f[1] + 500, f[2] + 500});

  std::map<std::array<double, 3>, std::uint32_t> first;  // -0 == +0 as doubles: one key
  TriangleMesh expected;
  for (const auto& f : soup.triangles) {
    std::array<std::uint32_t, 3> g;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d& p = soup.vertices[f[k]];
      const auto [at, added] =
          first.try_emplace({p.x(), p.y(), p.z()}, static_cast<std::uint32_t>(first.size()));
      if (added) expected.vertices.push_back(p);
      g[k] = at->second;
    }
    expected.triangles.push_back(g);
  }
  for (int threads : {1, 2, 3}) {
    MeshRepair r;
    const TriangleMesh welded = clean_mesh(soup, &r, nullptr, threads);
    EXPECT_EQ(r.welded_vertices, 81000 - expected.vertices.size());
    EXPECT_EQ(r.dropped_triangles + r.flipped_triangles, 0u);
    ASSERT_EQ(welded.vertices.size(), expected.vertices.size());
    EXPECT_EQ(welded.triangles, expected.triangles);
    auto bits = [](const Eigen::Vector3d& p) {  // the sign of a zero included
      return std::array<std::uint64_t, 3>{std::bit_cast<std::uint64_t>(p.x()),
                                          std::bit_cast<std::uint64_t>(p.y()),
                                          std::bit_cast<std::uint64_t>(p.z())};
    };
    for (std::size_t v = 0; v < welded.vertices.size(); ++v)
      ASSERT_EQ(bits(welded.vertices[v]), bits(expected.vertices[v])) << "vertex " << v;
  }
}

TEST(Mesh, CleanRewindsFlippedTrianglesAndTurnsAnInsideOutSolidOutward) {
  TriangleMesh m = test::l_block();
  for (std::size_t t : {1u, 5u, 9u}) std::swap(m.triangles[t][0], m.triangles[t][1]);
  EXPECT_GT(analyse_topology(m).inconsistent_edges, 0u);
  MeshRepair r;
  TriangleMesh clean = clean_mesh(m, &r);
  EXPECT_EQ(r.flipped_triangles, 3u);
  EXPECT_GT(r.inconsistent_edges, 0u);
  EXPECT_EQ(analyse_topology(clean).inconsistent_edges, 0u);
  EXPECT_NEAR(analyse_topology(clean).signed_volume, 3, 1e-12);

  for (auto& t : m.triangles) std::swap(t[1], t[2]);  // everything inside out (3 now right)
  clean = clean_mesh(m, &r);
  EXPECT_EQ(r.flipped_triangles, 3u);
  EXPECT_EQ(r.inverted_components, 1u);
  EXPECT_NEAR(analyse_topology(clean).signed_volume, 3, 1e-12);
}

// clean_mesh hands back the adjacency it found before re-winding, kept in step with the flips:
// it must be what analyse_adjacency finds on the cleaned mesh afresh.
TEST(Mesh, CleanReturnsTheAdjacencyOfTheCleanedMesh) {
  TriangleMesh m = test::unwelded(test::l_block());
  for (std::size_t t : {1u, 5u, 9u}) std::swap(m.triangles[t][0], m.triangles[t][1]);
  m.triangles.push_back(m.triangles[2]);                         // a duplicate, dropped
  TriangleMesh inverted = test::box_mesh({5, 0, 0}, {6, 1, 1});  // closed, turned outward
  for (auto& t : inverted.triangles) std::swap(t[1], t[2]);
  TriangleMesh open = test::box_mesh({8, 0, 0}, {9, 1, 1});  // open: kept as it is
  open.triangles.pop_back();
  for (const TriangleMesh* piece : {&inverted, &open}) {
    const auto base = static_cast<std::uint32_t>(m.vertices.size());
    m.vertices.insert(m.vertices.end(), piece->vertices.begin(), piece->vertices.end());
    for (auto t : piece->triangles) m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
  MeshRepair r;
  MeshAdjacency got;
  const TriangleMesh clean = clean_mesh(m, &r, &got);
  EXPECT_EQ(r.flipped_triangles, 3u);
  EXPECT_EQ(r.inverted_components, 1u);
  const MeshAdjacency want = analyse_adjacency(clean);
  EXPECT_EQ(got.neighbours, want.neighbours);
  EXPECT_EQ(got.topology.vertices, want.topology.vertices);
  EXPECT_EQ(got.topology.triangles, want.topology.triangles);
  EXPECT_EQ(got.topology.boundary_edges, want.topology.boundary_edges);
  EXPECT_EQ(got.topology.non_manifold_edges, want.topology.non_manifold_edges);
  EXPECT_EQ(got.topology.inconsistent_edges, want.topology.inconsistent_edges);
  EXPECT_EQ(got.topology.components, want.topology.components);
  EXPECT_NEAR(got.topology.signed_volume, want.topology.signed_volume, 1e-12);
  EXPECT_EQ(want.topology.components, 3u);
  EXPECT_EQ(want.topology.inconsistent_edges, 0u);
  EXPECT_GT(want.topology.boundary_edges, 0u);
}

TEST(Mesh, CleanDropsDegenerateAndDuplicateTriangles) {
  TriangleMesh m = test::box_mesh({0, 0, 0}, {1, 1, 1});
  m.triangles.push_back({0, 0, 1});       // repeated corner
  m.vertices.emplace_back(0.5, 0, 0);     // on the edge 0-1
  m.triangles.push_back({0, 1, 8});       // collinear corners
  m.triangles.push_back(m.triangles[0]);  // duplicate
  m.triangles.push_back({m.triangles[1][0], m.triangles[1][2], m.triangles[1][1]});  // reversed
  MeshRepair r;
  const TriangleMesh clean = clean_mesh(m, &r);
  EXPECT_EQ(r.dropped_triangles, 4u);
  EXPECT_EQ(clean.triangles.size(), 12u);
  EXPECT_EQ(clean.vertices.size(), 8u);  // the vertex only a dropped triangle used is gone
  EXPECT_TRUE(analyse_topology(clean).closed());
}

TEST(Mesh, TopologyCountsOpenAndNonManifoldEdgesAndPieces) {
  TriangleMesh open = test::box_mesh({0, 0, 0}, {1, 1, 1});
  open.triangles.erase(open.triangles.begin(), open.triangles.begin() + 2);  // the caps' first
  const MeshTopology t = analyse_topology(open);
  EXPECT_FALSE(t.closed());
  EXPECT_EQ(t.boundary_edges, 6u);  // two triangles gone from two caps: 3 open edges each

  TriangleMesh fin = test::box_mesh({0, 0, 0}, {1, 1, 1});
  fin.vertices.emplace_back(0.5, -1, 0.5);
  fin.triangles.push_back({0, 1, 8});  // a third triangle on the bottom front edge 0-1
  EXPECT_EQ(analyse_topology(fin).non_manifold_edges, 1u);

  TriangleMesh two = test::box_mesh({0, 0, 0}, {1, 1, 1});
  const TriangleMesh other = test::box_mesh({3, 0, 0}, {4, 1, 1});
  for (auto t : other.triangles) {
    for (auto& i : t) i += 8;
    two.triangles.push_back(t);
  }
  two.vertices.insert(two.vertices.end(), other.vertices.begin(), other.vertices.end());
  EXPECT_EQ(analyse_topology(two).components, 2u);
}

TEST(Mesh, EdgeNeighboursAreMutual) {
  const TriangleMesh m = test::l_block();
  const auto nb = edge_neighbours(m);
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t o = nb[t][k];
      ASSERT_NE(o, UINT32_MAX);
      const auto& ot = m.triangles[o];
      EXPECT_TRUE(std::count(nb[o].begin(), nb[o].end(), t) == 1);
      // the shared edge's two corners are corners of the neighbour
      EXPECT_NE(std::find(ot.begin(), ot.end(), m.triangles[t][k]), ot.end());
      EXPECT_NE(std::find(ot.begin(), ot.end(), m.triangles[t][(k + 1) % 3]), ot.end());
    }
}

// analyse_adjacency walks each vertex's triangles; the oracle here is a std::map from every
// undirected edge to the (triangle, slot) pairs using it, on a sphere made irregular on purpose:
// holes (boundary edges), flipped triangles (inconsistent edges), fins (non-manifold edges), a
// detached piece and a triangle with a repeated corner.
TEST(Mesh, AdjacencyAgreesWithAnEdgeMapOnAnIrregularMesh) {
  TriangleMesh m = synth::sphere_mesh(3, 12);
  Random rng(5);
  std::vector<std::array<std::uint32_t, 3>> kept;
  for (auto t : m.triangles) {
    if (rng.uniform() < 0.05) continue;              // a hole
    if (rng.uniform() < 0.1) std::swap(t[1], t[2]);  // a flipped triangle
    kept.push_back(t);
  }
  for (int f = 0; f < 5; ++f) {  // fins on existing edges
    const auto& t = kept[static_cast<std::size_t>(rng.uniform(0, 1) * kept.size())];
    m.vertices.push_back(m.vertices[t[0]] + Eigen::Vector3d(0, 0, 1));
    kept.push_back({t[0], t[1], static_cast<std::uint32_t>(m.vertices.size() - 1)});
  }
  const auto base = static_cast<std::uint32_t>(m.vertices.size());
  for (int k = 0; k < 4; ++k) m.vertices.emplace_back(10 + k % 2, 10 + k / 2, 0);
  kept.push_back({base, base + 1, base + 2});  // a detached piece of two triangles
  kept.push_back({base + 1, base + 3, base + 2});
  kept.push_back({0, 0, 1});  // a repeated corner
  m.triangles = kept;

  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::pair<std::uint32_t, int>>>
      edges;
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = m.triangles[t][k], b = m.triangles[t][(k + 1) % 3];
      if (a != b) edges[{std::min(a, b), std::max(a, b)}].push_back({t, k});
    }
  MeshTopology truth;
  std::vector<std::array<std::uint32_t, 3>> neighbours(m.triangles.size(),
                                                       {UINT32_MAX, UINT32_MAX, UINT32_MAX});
  std::vector<std::uint32_t> piece(m.triangles.size());
  std::iota(piece.begin(), piece.end(), 0u);
  std::function<std::uint32_t(std::uint32_t)> root = [&](std::uint32_t x) {
    return piece[x] == x ? x : root(piece[x]);
  };
  for (const auto& [edge, uses] : edges) {
    if (uses.size() == 1) ++truth.boundary_edges;
    if (uses.size() > 2) ++truth.non_manifold_edges;
    if (uses.size() != 2) continue;
    const auto [t, k] = uses[0];
    const auto [o, j] = uses[1];
    neighbours[t][k] = o;
    neighbours[o][j] = t;
    // Same direction along the edge: the windings disagree.
    if (m.triangles[t][k] == m.triangles[o][j]) ++truth.inconsistent_edges;
    piece[root(t)] = root(o);
  }
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t) truth.components += root(t) == t ? 1 : 0;
  truth.boundary_edges += 1;  // the repeated corner's degenerate edge counts as open

  const MeshAdjacency got = analyse_adjacency(m);
  EXPECT_GT(truth.boundary_edges, 10u);
  EXPECT_GT(truth.inconsistent_edges, 10u);
  EXPECT_GE(truth.non_manifold_edges, 5u);
  EXPECT_EQ(got.topology.boundary_edges, truth.boundary_edges);
  EXPECT_EQ(got.topology.non_manifold_edges, truth.non_manifold_edges);
  EXPECT_EQ(got.topology.inconsistent_edges, truth.inconsistent_edges);
  EXPECT_EQ(got.topology.components, truth.components);
  EXPECT_EQ(got.neighbours, neighbours);
  EXPECT_EQ(edge_neighbours(m), neighbours);
  EXPECT_EQ(analyse_topology(m).components, truth.components);
}

TEST(Mesh, CheckNamesTheProblem) {
  TriangleMesh m = test::box_mesh({0, 0, 0}, {1, 1, 1});
  EXPECT_NO_THROW(check_mesh(m, "cad"));
  m.triangles.push_back({0, 1, 99});
  try {
    check_mesh(m, "cad");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "cad");
    EXPECT_NE(std::string(e.what()).find("vertex 99"), std::string::npos);
  }
  m.triangles.pop_back();
  m.vertices[2].x() = std::nan("");
  EXPECT_THROW(check_mesh(m, "cad"), DataError);
  EXPECT_THROW(check_mesh(TriangleMesh{}, "cad"), DataError);
}

TEST(Mesh, SamplesSpreadByAreaOnTheTrianglesWithTheirNormals) {
  const TriangleMesh m = test::box_mesh({0, 0, 0}, {4, 2, 1});
  const std::size_t count = 7000;
  const PointCloud s = sample_surface(m, count, 5);
  ASSERT_EQ(s.size(), count);
  ASSERT_TRUE(s.has_normals());
  // Each sample lies on a face of the box, with that face's outward normal.
  std::vector<double> per_face(6, 0);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3d& p = s.positions[i];
    const Eigen::Vector3d& n = s.normals[i];
    const Eigen::Vector3d hi(4, 2, 1);
    int axis = -1;
    for (int k = 0; k < 3; ++k)
      if (std::abs(std::abs(n[k]) - 1) < 1e-12) axis = k;
    ASSERT_GE(axis, 0);
    const double plane = n[axis] > 0 ? hi[axis] : 0;
    EXPECT_NEAR(p[axis], plane, 1e-12);
    EXPECT_TRUE((p.array() >= -1e-12).all() && (p.array() <= hi.array() + 1e-12).all());
    per_face[2 * axis + (n[axis] > 0)] += 1;
  }
  // Systematic sampling: each face (two triangles) gets its share of the count within 2 points.
  const double total = surface_area(m);
  const double areas[3] = {2 * 1, 4 * 1, 4 * 2};  // faces normal to x, y, z
  for (int f = 0; f < 6; ++f)
    EXPECT_NEAR(per_face[f], count * areas[f / 2] / total, 2.0) << "face " << f;
  // Deterministic for a seed, different for another.
  EXPECT_EQ(sample_surface(m, count, 5).positions, s.positions);
  EXPECT_NE(sample_surface(m, count, 6).positions, s.positions);
}

}  // namespace
}  // namespace align3d
