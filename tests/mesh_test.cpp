// The triangle mesh (mesh.hpp): cleaning (welding, dropping, re-winding), topology counts and even
// surface sampling, on prisms whose geometry is known in closed form.
#include "align3d/mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "align3d/error.hpp"
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
