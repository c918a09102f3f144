// The machined part and its as-built scan (synth/part.hpp). Oracles: edge counts by brute force,
// the volume and area of the polygonal solid computed here from its dimensions, ray parity against
// the triangles, and (with MeshIndex) the signed distances of the scan against the true deviation.
#include "align3d/synth/part.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <utility>

#include "align3d/cli.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/mesh.hpp"
#include "align3d/mesh_index.hpp"
#include "test_util.hpp"

namespace align3d::synth {
namespace {

using test::kPi;

// Every undirected edge used exactly twice, once in each direction: closed, manifold and
// consistently wound (the brute-force count, independent of analyse_topology).
void expect_closed_and_consistent(const TriangleMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  std::size_t bad = 0;
  for (const auto& [edge, count] : directed) {
    const auto back = directed.find({edge.second, edge.first});
    bad += count != 1 || back == directed.end() || back->second != 1;
  }
  EXPECT_EQ(bad, 0u);
  std::set<std::array<double, 3>> unique;
  for (const Eigen::Vector3d& v : mesh.vertices) unique.insert({v.x(), v.y(), v.z()});
  EXPECT_EQ(unique.size(), mesh.vertices.size()) << "duplicate vertices";
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]],
                          &c = mesh.vertices[t[2]];
    ASSERT_GT((b - a).cross(c - a).norm(), 1e-9) << "a degenerate triangle";
  }
}

double mesh_volume(const TriangleMesh& mesh) {  // divergence theorem: Σ a·(b × c) / 6
  double v = 0;
  for (const auto& t : mesh.triangles)
    v += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]])) / 6;
  return v;
}

double mesh_area(const TriangleMesh& mesh) {
  double a = 0;
  for (const auto& t : mesh.triangles)
    a += (mesh.vertices[t[1]] - mesh.vertices[t[0]])
             .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]])
             .norm() /
         2;
  return a;
}

// The regular n-gon inscribed in a circle of radius r: area and perimeter.
double ngon_area(int n, double r) { return n / 2.0 * r * r * std::sin(2 * kPi / n); }
double ngon_perimeter(int n, double r) { return 2 * n * r * std::sin(kPi / n); }

bool hole_in_pocket(const PartSettings& s, const PartHole& h) {
  return h.centre.x() - h.radius > s.pocket_min.x() && h.centre.x() + h.radius < s.pocket_max.x() &&
         h.centre.y() - h.radius > s.pocket_min.y() && h.centre.y() + h.radius < s.pocket_max.y();
}

// The polygonal solid's volume from its dimensions: the block below the chamfer, the chamfer band
// as a prismatoid (h/6 · (A_bottom + 4·A_middle + A_top), exact for it), minus the pocket and the
// holes' prisms below the faces they open on, plus the boss.
double analytic_volume(const PartSettings& s) {
  const double L = s.block.x(), W = s.block.y(), H = s.block.z(), c = s.chamfer;
  const int n = s.circle_segments;
  double v = L * W * (H - c) + c / 6 * (L * W + 4 * (L - c) * (W - c) + (L - 2 * c) * (W - 2 * c));
  const Eigen::Vector2d pocket = s.pocket_max - s.pocket_min;
  v -= pocket.x() * pocket.y() * s.pocket_depth;
  for (const PartHole& h : s.holes)
    v -= ngon_area(n, h.radius) * (hole_in_pocket(s, h) ? H - s.pocket_depth : H);
  return v + ngon_area(n, s.boss_radius) * s.boss_height;
}

// Face by face: base, walls, chamfers (trapezoids of slant c√2), top, pocket walls and floor, hole
// sides, boss side and top.
double analytic_area(const PartSettings& s) {
  const double L = s.block.x(), W = s.block.y(), H = s.block.z(), c = s.chamfer;
  const int n = s.circle_segments;
  const Eigen::Vector2d pocket = s.pocket_max - s.pocket_min;
  const double boss = ngon_area(n, s.boss_radius), pocket_area = pocket.x() * pocket.y();
  double a = L * W + 2 * (L + W) * (H - c) + (2 * L - 2 * c + 2 * W - 2 * c) * c * std::sqrt(2.0);
  a += (L - 2 * c) * (W - 2 * c) - pocket_area - boss;                // top
  a += 2 * (pocket.x() + pocket.y()) * s.pocket_depth + pocket_area;  // pocket
  for (const PartHole& h : s.holes) {
    const double depth = hole_in_pocket(s, h) ? H - s.pocket_depth : H;
    a += ngon_perimeter(n, h.radius) * depth - 2 * ngon_area(n, h.radius);  // side, two openings
  }
  return a + ngon_perimeter(n, s.boss_radius) * s.boss_height + boss;
}

// Möller–Trumbore: whether the ray o + t·d, t > 0, crosses triangle abc.
bool ray_crosses(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& a,
                 const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a, p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-15) return false;
  const Eigen::Vector3d s = o - a;
  const double u = s.dot(p) / det;
  if (u < 0 || u > 1) return false;
  const Eigen::Vector3d q = s.cross(e1);
  const double v = d.dot(q) / det;
  if (v < 0 || u + v > 1) return false;
  return e2.dot(q) / det > 0;
}

bool parity_inside(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = Eigen::Vector3d(0.3141, 0.2718, 0.9113).normalized();  // generic
  int crossings = 0;
  for (const auto& t : mesh.triangles)
    crossings += ray_crosses(p, d, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  return crossings % 2 == 1;
}

TEST(PartMesh, IsClosedManifoldAndConsistentlyWoundForAnySegmentCount) {
  for (int segments : {8, 13, 64, 200}) {
    SCOPED_TRACE(segments);
    PartSettings s;
    s.circle_segments = segments;
    expect_closed_and_consistent(PartModel(s).mesh());
  }
}

TEST(PartMesh, NaturalTessellationHasAboutAThousandTriangles) {
  const TriangleMesh mesh = PartModel().mesh();
  EXPECT_GT(mesh.triangles.size(), 800u);
  EXPECT_LT(mesh.triangles.size(), 2000u);
  // Euler: a closed surface of genus g has V − E + F = 2 − 2g; the part has two through-holes.
  const std::size_t V = mesh.vertices.size(), F = mesh.triangles.size(), E = 3 * F / 2;
  EXPECT_EQ(static_cast<long>(V) - static_cast<long>(E) + static_cast<long>(F), 2 - 2 * 2);
}

TEST(PartMesh, VolumeAndAreaAreThoseOfThePolygonalSolid) {
  for (int segments : {8, 13, 64, 200}) {
    SCOPED_TRACE(segments);
    PartSettings s;
    s.circle_segments = segments;
    const TriangleMesh mesh = PartModel(s).mesh();
    EXPECT_NEAR(mesh_volume(mesh), analytic_volume(s), 1e-9 * analytic_volume(s));
    EXPECT_NEAR(mesh_area(mesh), analytic_area(s), 1e-9 * analytic_area(s));
  }
}

TEST(PartMesh, OtherGeometriesStayClean) {
  PartSettings s;
  s.block = {150, 100, 30};
  s.chamfer = 2.5;
  s.pocket_min = {10, -30};
  s.pocket_max = {60, 20};
  s.pocket_depth = 12.5;
  s.holes = {{{35, -5}, 8}, {{-50, 30}, 4}, {{-50, -30}, 4}, {{50, 35}, 3}};
  s.boss_centre = {-20, 0};
  s.boss_radius = 20;
  s.circle_segments = 48;
  const TriangleMesh mesh = PartModel(s).mesh();
  expect_closed_and_consistent(mesh);
  EXPECT_NEAR(mesh_volume(mesh), analytic_volume(s), 1e-9 * analytic_volume(s));
  EXPECT_NEAR(mesh_area(mesh), analytic_area(s), 1e-9 * analytic_area(s));
}

// Random valid geometries (invalid draws are rejected by PartModel and skipped): the ear clipper
// and the hole bridging meet holes in every relative position, some sharing a row or column.
TEST(PartMesh, RandomGeometriesStayClean) {
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> x(-55, 55), y(-35, 35), radius(1.5, 9), unit(0, 1);
  int built = 0;
  for (int attempt = 0; attempt < 400 && built < 60; ++attempt) {
    PartSettings s;
    s.circle_segments = 8 + static_cast<int>(unit(rng) * 90);
    s.pocket_min = {x(rng) * 0.8, y(rng) * 0.8};
    s.pocket_max = s.pocket_min + Eigen::Vector2d(10 + 30 * unit(rng), 10 + 30 * unit(rng));
    s.boss_centre = {x(rng), y(rng)};
    s.boss_radius = radius(rng);
    s.holes.clear();
    const int holes = static_cast<int>(unit(rng) * 6);
    for (int h = 0; h < holes; ++h) {
      Eigen::Vector2d c(x(rng), y(rng));
      if (h % 2 == 1) c.y() = s.holes.back().centre.y();  // a row: rays through other holes
      s.holes.push_back({c, radius(rng)});
    }
    if (unit(rng) < 0.5) {  // a hole through the pocket floor
      const Eigen::Vector2d centre = (s.pocket_min + s.pocket_max) / 2;
      s.holes.push_back(
          {centre, std::min(4.0, (s.pocket_max - s.pocket_min).minCoeff() / 2 - 1.5)});
    }
    try {
      PartModel{s};
    } catch (const std::invalid_argument&) {
      continue;
    }
    SCOPED_TRACE(attempt);
    const TriangleMesh mesh = PartModel(s).mesh();
    expect_closed_and_consistent(mesh);
    EXPECT_NEAR(mesh_volume(mesh), analytic_volume(s), 1e-9 * analytic_volume(s));
    EXPECT_NEAR(mesh_area(mesh), analytic_area(s), 1e-9 * analytic_area(s));
    ++built;
  }
  EXPECT_GE(built, 30);
}

TEST(PartMesh, SubdivisionReachesTheTargetAndKeepsTheSurface) {
  const PartModel part;
  const TriangleMesh natural = part.mesh();
  const TriangleMesh fine = part.mesh(30000);
  std::size_t expected = natural.triangles.size();
  while (expected < 30000) expected *= 4;
  EXPECT_EQ(fine.triangles.size(), expected);
  expect_closed_and_consistent(fine);
  EXPECT_NEAR(mesh_volume(fine), analytic_volume(part.settings()), 1e-9 * mesh_volume(natural));
  EXPECT_NEAR(mesh_area(fine), analytic_area(part.settings()), 1e-9 * mesh_area(natural));
  EXPECT_EQ(part.mesh(10).triangles.size(), natural.triangles.size());
}

TEST(PartMesh, IsDeterministic) {
  const TriangleMesh a = PartModel().mesh(), b = PartModel().mesh();
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  EXPECT_EQ(a.triangles, b.triangles);
  for (std::size_t i = 0; i < a.vertices.size(); ++i) EXPECT_EQ(a.vertices[i], b.vertices[i]);
}

TEST(PartContains, AgreesWithRayParityOnRandomPoints) {
  const PartModel part;
  const TriangleMesh mesh = part.mesh();
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> x(-63, 63), y(-43, 43), z(-3, 58), jitter(-0.05, 0.05);
  std::uniform_int_distribution<std::size_t> pick(0, mesh.triangles.size() - 1);
  std::uniform_real_distribution<double> unit(0, 1);
  std::size_t inside = 0, disagree = 0;
  for (int i = 0; i < 6000; ++i) {
    Eigen::Vector3d p(x(rng), y(rng), z(rng));
    if (i % 2) {  // every other point within 0.05 mm of a random spot of the surface
      const auto& t = mesh.triangles[pick(rng)];
      double u = unit(rng), v = unit(rng);
      if (u + v > 1) u = 1 - u, v = 1 - v;
      p = mesh.vertices[t[0]] + u * (mesh.vertices[t[1]] - mesh.vertices[t[0]]) +
          v * (mesh.vertices[t[2]] - mesh.vertices[t[0]]) +
          Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    }
    const bool in = part.contains(p);
    inside += in;
    disagree += in != parity_inside(mesh, p);
  }
  EXPECT_EQ(disagree, 0u);
  EXPECT_GT(inside, 1500u);  // both answers are well represented
  EXPECT_LT(inside, 4500u);
}

TEST(PartContains, FeaturesLieOnTheSurface) {
  const PartModel part;
  const auto features = part.features();
  std::set<PartFeatureKind> kinds;
  for (const PartFeature& f : features) {
    SCOPED_TRACE(f.name);
    kinds.insert(f.kind);
    EXPECT_FALSE(part.contains(f.point));
    int in = 0, out = 0;  // points 1e-3 around it fall on both sides
    for (int k = 0; k < 27; ++k) {
      const Eigen::Vector3d d(k % 3 - 1.0, (k / 3) % 3 - 1.0, k / 9 - 1.0);
      if (d.isZero()) continue;
      (part.contains(f.point + 1e-3 * d.normalized()) ? in : out)++;
    }
    EXPECT_GT(in, 0);
    EXPECT_GT(out, 0);
  }
  EXPECT_EQ(kinds.size(), 10u);  // every kind
}

TEST(PartSettingsTest, RejectsUncleanGeometry) {
  auto bad = [](auto change) {
    PartSettings s;
    change(s);
    EXPECT_THROW(PartModel{s}, std::invalid_argument);
  };
  bad([](PartSettings& s) { s.circle_segments = 5; });
  bad([](PartSettings& s) { s.chamfer = 0; });
  bad([](PartSettings& s) { s.pocket_depth = 40; });
  bad([](PartSettings& s) { s.pocket_min.x() = -56; });             // into the chamfer
  bad([](PartSettings& s) { s.holes.push_back({{-5, 0}, 3}); });    // across the pocket wall
  bad([](PartSettings& s) { s.holes.push_back({{30, 15}, 3}); });   // under the boss
  bad([](PartSettings& s) { s.holes.push_back({{35, -12}, 3}); });  // too close to hole 1
  bad([](PartSettings& s) { s.boss_centre = {-20, 0}; });           // in the pocket
  EXPECT_NO_THROW(PartModel{});
}

// ---- With MeshIndex
// ------------------------------------------------------------------------------

TEST(PartMesh, CleanMeshFindsNothingToRepair) {
  const PartModel part;
  const TriangleMesh mesh = part.mesh();
  MeshRepair repair;
  const TriangleMesh cleaned = clean_mesh(mesh, &repair);
  EXPECT_EQ(repair.welded_vertices, 0u);
  EXPECT_EQ(repair.dropped_triangles, 0u);
  EXPECT_EQ(repair.flipped_triangles, 0u);
  EXPECT_EQ(repair.inverted_components, 0u);
  EXPECT_EQ(repair.inconsistent_edges, 0u);
  const MeshTopology topology = analyse_topology(mesh);
  EXPECT_TRUE(topology.closed());
  EXPECT_EQ(topology.inconsistent_edges, 0u);
  EXPECT_EQ(topology.components, 1u);
  EXPECT_NEAR(topology.signed_volume, analytic_volume(part.settings()), 1e-6);
}

// Unit directions spread evenly over the sphere (Fibonacci lattice).
std::vector<Eigen::Vector3d> sphere_directions(int count) {
  std::vector<Eigen::Vector3d> out;
  const double golden = kPi * (3 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1 - (2 * i + 1.0) / count, r = std::sqrt(1 - z * z);
    out.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return out;
}

// The pseudo-normal sign of MeshIndex against the analytic oracle, 1e-3 to 1 mm around every sharp
// edge and vertex of the part, on the natural and on a subdivided mesh.
TEST(PartSign, SignedDistanceMatchesContainsAroundEveryFeature) {
  const PartModel part;
  const auto directions = sphere_directions(300);
  for (std::size_t triangles : {std::size_t{0}, std::size_t{20000}}) {
    const MeshIndex index(part.mesh(triangles), 1);
    for (const PartFeature& f : part.features()) {
      std::size_t wrong = 0, probes = 0;
      for (double distance : {1e-3, 1e-2, 0.1, 1.0})
        for (const Eigen::Vector3d& u : directions) {
          const Eigen::Vector3d q = f.point + distance * u;
          SurfacePoint c;
          ASSERT_TRUE(index.closest(q, c));
          const double d = index.signed_distance(q, c);
          if (std::abs(d) < 1e-9) continue;  // on the surface: no side to check
          ++probes;
          wrong += (d < 0) != part.contains(q);
        }
      EXPECT_EQ(wrong, 0u) << f.name << " (" << to_string(f.kind) << "), " << triangles
                           << " triangles";
      EXPECT_GT(probes, 1150u) << f.name;
    }
  }
}

// A coarse scan (1 mm pitch) for the tests that walk every point.
AsBuiltSettings coarse_scan_settings() {
  AsBuiltSettings s;
  s.pitch = 0.8;
  s.seed = 5;
  return s;
}

struct Measured {
  Eigen::Vector3d cad;  // the scan point moved into the CAD frame
  double signed_distance;
  Eigen::Vector3d normal;  // of the closest CAD face
};

std::vector<Measured> measure(const AsBuiltScan& scan, const MeshIndex& index) {
  std::vector<SurfacePoint> closest;
  index.closest_points(scan.scan.positions, scan.T_cad_scan,
                       std::numeric_limits<double>::infinity(), 0, closest);
  std::vector<Measured> out;
  for (std::size_t i = 0; i < closest.size(); ++i) {
    const Eigen::Vector3d q = scan.T_cad_scan * scan.scan.positions[i];
    out.push_back(
        {q, index.signed_distance(q, closest[i]), index.face_normal(closest[i].triangle)});
  }
  return out;
}

TEST(PartScan, PartPointsLieAtTheirTrueDeviationFixturePointsFarAway) {
  const AsBuiltSettings s = coarse_scan_settings();
  const AsBuiltScan scan = make_as_built_scan(s);
  ASSERT_EQ(scan.label.size(), scan.scan.size());
  ASSERT_EQ(scan.deviation.size(), scan.scan.size());
  ASSERT_EQ(scan.view.size(), scan.scan.size());
  EXPECT_GT(scan.part_points, 20000u);
  EXPECT_GT(scan.fixture_points, 1000u);
  const MeshIndex index(PartModel(s.part).mesh());
  const std::vector<Measured> m = measure(scan, index);
  const double sigma = s.noise_sigma;
  double sq_sum = 0, largest_deviation = 0;
  std::size_t beyond_4_sigma = 0;
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (scan.label[i] == ScanLabel::kFixture) {
      EXPECT_GT(m[i].signed_distance, s.fixture_clearance - 6 * sigma);
      EXPECT_EQ(scan.deviation[i], 0.0);
      continue;
    }
    const double residual = m[i].signed_distance - scan.deviation[i];
    ASSERT_LT(std::abs(residual), 6 * sigma) << "point " << i << " at " << m[i].cad.transpose();
    beyond_4_sigma += std::abs(residual) > 4 * sigma;
    sq_sum += residual * residual;
    largest_deviation = std::max(largest_deviation, std::abs(scan.deviation[i]));
  }
  const double rms = std::sqrt(sq_sum / static_cast<double>(scan.part_points));
  EXPECT_LT(rms, sigma);  // range noise seen along the normal: σ·cos(incidence)
  EXPECT_GT(rms, 0.4 * sigma);
  EXPECT_LT(beyond_4_sigma, scan.part_points / 1000);
  EXPECT_GT(largest_deviation, 0.25);  // the defects were scanned
}

// `align3d synth --scene part` end to end, from its files alone: part.stl welded back to the same
// closed solid, scan.ply moved by ground_truth.txt onto it, scan_truth.ply's labels and deviations
// in scan order, and the defects where scene.json says: on each defect's face and within its
// radius the signed distance follows peak·cos²(πr/2R) up to the warp and the noise; elsewhere it
// stays within them.
class PartSynthCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir("synth_part");
    std::ostringstream out, err;
    ASSERT_EQ(cli::run({"synth", dir_->path().string(), "--scene", "part", "--points", "60000",
                        "--triangles", "3000", "--seed", "3"},
                       out, err),
              0)
        << err.str();
    std::ifstream in(dir_->path() / "scene.json");
    scene_ = new nlohmann::json(nlohmann::json::parse(in));
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete dir_;
  }
  static test::TempDir* dir_;
  static nlohmann::json* scene_;
};
test::TempDir* PartSynthCli::dir_ = nullptr;
nlohmann::json* PartSynthCli::scene_ = nullptr;

Eigen::Vector3d vector3(const nlohmann::json& j) {
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

struct TruthRecord {
  Eigen::Vector3f position;
  std::uint8_t label;
  float deviation;
  std::uint8_t view;
};

std::vector<TruthRecord> read_truth(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::size_t count = 0;
  while (std::getline(in, line) && line != "end_header")
    if (line.rfind("element vertex ", 0) == 0) count = std::stoul(line.substr(15));
  std::vector<TruthRecord> out(count);
  for (TruthRecord& r : out) {
    char record[18];
    in.read(record, sizeof record);
    std::memcpy(r.position.data(), record, 12);  // the test machine is little-endian
    std::memcpy(&r.deviation, record + 12, 4);   // x y z deviation label view (scene.json)
    r.label = static_cast<std::uint8_t>(record[16]);
    r.view = static_cast<std::uint8_t>(record[17]);
  }
  EXPECT_TRUE(in.good());
  EXPECT_EQ(in.peek(), EOF);
  return out;
}

TEST_F(PartSynthCli, WritesTheDocumentedFiles) {
  const nlohmann::json& j = *scene_;
  for (const char* file : {"part.stl", "part_fine.stl", "scan.ply", "scan_truth.ply",
                           "ground_truth.txt", "scene.json"})
    EXPECT_TRUE(std::filesystem::exists(dir_->path() / file)) << file;
  EXPECT_EQ(j["units"], "mm");
  EXPECT_EQ(j["scene"], "part");
  const TriangleMesh mesh = clean_mesh(io::read_mesh(dir_->path() / "part.stl"));
  const MeshTopology topology = analyse_topology(mesh);
  EXPECT_TRUE(topology.closed());
  EXPECT_EQ(topology.inconsistent_edges, 0u);
  EXPECT_EQ(mesh.triangles.size(), j["part"]["triangles"].get<std::size_t>());
  EXPECT_EQ(mesh.vertices.size(), j["part"]["vertices"].get<std::size_t>());
  EXPECT_NEAR(topology.signed_volume, analytic_volume(PartSettings{}), 0.05);  // float32 corners
  const TriangleMesh fine = clean_mesh(io::read_mesh(dir_->path() / "part_fine.stl"));
  EXPECT_GE(fine.triangles.size(), 3000u);
  EXPECT_TRUE(analyse_topology(fine).closed());
  const std::size_t points = j["scan"]["points"];
  EXPECT_NEAR(static_cast<double>(points), 60000.0, 1800.0);
  const PointCloud scan = io::read_point_cloud(dir_->path() / "scan.ply");
  ASSERT_EQ(scan.size(), points);
  const std::vector<TruthRecord> truth = read_truth(dir_->path() / "scan_truth.ply");
  ASSERT_EQ(truth.size(), points);
  std::size_t fixture = 0;
  for (std::size_t i = 0; i < points; ++i) {
    ASSERT_EQ(truth[i].position.cast<double>(), scan.positions[i]) << i;
    fixture += truth[i].label == 1;
    EXPECT_LT(truth[i].view, 2);
  }
  EXPECT_EQ(fixture, j["scan"]["fixture_points"].get<std::size_t>());
  EXPECT_EQ(points - fixture, j["scan"]["part_points"].get<std::size_t>());
  const Eigen::Isometry3d T = io::read_matrix(dir_->path() / "ground_truth.txt");
  EXPECT_TRUE(T.isApprox(AsBuiltScan{make_as_built_scan([] {
                           AsBuiltSettings c;
                           c.pitch = 3;
                           return c;
                         }())}
                             .T_cad_scan,
                         1e-15));
}

TEST_F(PartSynthCli, DefectsAreWhereSceneJsonSays) {
  const nlohmann::json& j = *scene_;
  const PointCloud scan = io::read_point_cloud(dir_->path() / "scan.ply");
  const std::vector<TruthRecord> truth = read_truth(dir_->path() / "scan_truth.ply");
  const Eigen::Isometry3d T = io::read_matrix(dir_->path() / "ground_truth.txt");
  const MeshIndex index(io::read_mesh(dir_->path() / "part.stl"));
  const double tolerance = j["scan"]["warp"]["amplitude"].get<double>() +
                           6 * j["scan"]["scanner"]["noise_sigma"].get<double>() +
                           1e-4;  // float32 coordinates
  const nlohmann::json& defects = j["scan"]["defects"];
  ASSERT_GE(defects.size(), 3u);
  std::vector<std::size_t> near_centre(defects.size(), 0);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    if (truth[i].label != 0) continue;
    const Eigen::Vector3d q = T * scan.positions[i];
    SurfacePoint c;
    ASSERT_TRUE(index.closest(q, c));
    const double d = index.signed_distance(q, c);
    double expected = 0;
    for (std::size_t k = 0; k < defects.size(); ++k) {
      const Eigen::Vector3d centre = vector3(defects[k]["centre"]);
      const Eigen::Vector3d n = vector3(defects[k]["normal"]);
      const double radius = defects[k]["radius"], peak = defects[k]["peak"];
      const Eigen::Vector3d r = q - centre;
      const double height = r.dot(n), rho = (r - height * n).norm();
      if (index.face_normal(c.triangle).dot(n) < 0.999 || std::abs(height) > 1 || rho >= radius)
        continue;
      const double cos = std::cos(kPi * rho / (2 * radius));
      expected += peak * cos * cos;
      near_centre[k] += rho < 0.3 * radius;
      EXPECT_EQ(defects[k]["kind"], peak < 0 ? "dent" : "bump");
    }
    ASSERT_NEAR(d, expected, tolerance) << q.transpose();
    ASSERT_NEAR(d, truth[i].deviation,
                6 * j["scan"]["scanner"]["noise_sigma"].get<double>() + 1e-4);
  }
  for (std::size_t k = 0; k < defects.size(); ++k)
    EXPECT_GT(near_centre[k], 10u) << "defect " << k << " was not scanned";
}

TEST_F(PartSynthCli, SameSeedSameBytes) {
  test::TempDir again("synth_part_again");
  std::ostringstream out, err;
  ASSERT_EQ(cli::run({"synth", again.path().string(), "--scene", "part", "--points", "60000",
                      "--triangles", "3000", "--seed", "3"},
                     out, err),
            0);
  for (const char* file : {"part.stl", "part_fine.stl", "scan.ply", "scan_truth.ply",
                           "ground_truth.txt", "scene.json"}) {
    std::ifstream a(dir_->path() / file, std::ios::binary),
        b(again.path() / file, std::ios::binary);
    const std::string x((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
    const std::string y((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
    EXPECT_TRUE(x == y) << file;
  }
}

TEST(PartSynthCliUsage, RejectsThreeViewsAndWritesOnlyAskedFiles) {
  test::TempDir d("synth_part_usage");
  std::ostringstream out, err;
  EXPECT_EQ(cli::run({"synth", d.path().string(), "--scene", "part", "--views", "3"}, out, err), 2);
  EXPECT_EQ(cli::run({"synth", d.path().string(), "--scene", "part", "--views", "1", "--noise",
                      "0.02", "--points", "5000"},
                     out, err),
            0)
      << err.str();
  EXPECT_FALSE(std::filesystem::exists(d / "part_fine.stl"));
  std::ifstream in(d / "scene.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["scan"]["scanner"]["views"].size(), 1u);
  EXPECT_EQ(j["scan"]["scanner"]["noise_sigma"], 0.02);
}

TEST(PartScan, SameBitsAtAnyThreadCount) {
  AsBuiltSettings s = coarse_scan_settings();
  s.pitch = 1.5;
  s.threads = 1;
  const AsBuiltScan a = make_as_built_scan(s);
  s.threads = 3;
  const AsBuiltScan b = make_as_built_scan(s);
  ASSERT_EQ(a.scan.size(), b.scan.size());
  EXPECT_EQ(a.scan.positions, b.scan.positions);
  EXPECT_EQ(a.label, b.label);
  EXPECT_EQ(a.deviation, b.deviation);
  EXPECT_EQ(a.view, b.view);
  s.seed = 6;  // another seed: other noise, the same rays
  const AsBuiltScan c = make_as_built_scan(s);
  EXPECT_EQ(c.label, a.label);
  EXPECT_NE(c.scan.positions, a.scan.positions);
}

TEST(PartScan, TargetPointsPicksThePitch) {
  AsBuiltSettings s;
  s.target_points = 40000;
  const AsBuiltScan scan = make_as_built_scan(s);
  EXPECT_NEAR(static_cast<double>(scan.scan.size()), 40000.0, 1200.0);
  s.views.resize(1);
  EXPECT_NEAR(static_cast<double>(make_as_built_scan(s).scan.size()), 40000.0, 1200.0);
}

TEST(PartScan, TheTransformIsTheStatedPose) {
  const AsBuiltSettings s;
  const Eigen::Isometry3d T = make_as_built_scan([] {
                                AsBuiltSettings c;
                                c.pitch = 3;
                                return c;
                              }())
                                  .T_cad_scan;
  const Eigen::Isometry3d T_scan_cad(
      Eigen::Translation3d(s.translation) *
      Eigen::AngleAxisd(s.rotation_deg * kPi / 180, s.rotation_axis.normalized()));
  EXPECT_TRUE((T * T_scan_cad).matrix().isIdentity(1e-12));
  EXPECT_GT(s.rotation_deg, 1);
  EXPECT_GT(s.translation.norm(), 2);
}

TEST(PartScan, RejectsBadSettings) {
  auto bad = [](auto change) {
    AsBuiltSettings s;
    s.pitch = 5;
    change(s);
    EXPECT_THROW(make_as_built_scan(s), std::invalid_argument);
  };
  bad([](AsBuiltSettings& s) { s.views.clear(); });
  bad([](AsBuiltSettings& s) { s.pitch = 0; });
  bad([](AsBuiltSettings& s) { s.noise_sigma = -1; });
  bad([](AsBuiltSettings& s) { s.defects[0].centre.z() = 41; });        // above the top
  bad([](AsBuiltSettings& s) { s.defects[0].centre = {-25, 0, 40}; });  // over the pocket
  bad([](AsBuiltSettings& s) { s.defects[1].normal = {0, 1, 0}; });     // facing inwards
  bad([](AsBuiltSettings& s) { s.defects[3].centre = {60, 10, 33}; });  // over the chamfer
}

}  // namespace
}  // namespace align3d::synth
