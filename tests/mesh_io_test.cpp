// Triangle-mesh file I/O (io/mesh_io.hpp). Oracles: a closed box whose volume and area are known in
// closed form, through every writer and back (exact where the format stores float64 or %.17g text,
// float32-rounded for STL); hand-written files in every dialect (bytes built here, independently of
// the writers) with known triangles; and malformed files, each of which must raise an IoError
// naming the file and the problem.
#include "align3d/io/mesh_io.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io/mesh_readers.hpp"
#include "test_util.hpp"

namespace align3d::io {
namespace {

namespace fs = std::filesystem;
using Triangles = std::vector<std::array<std::uint32_t, 3>>;

// A 3 × 5 × 7 box with a corner at `origin`, its 12 triangles counter-clockwise seen from outside:
// volume 105, area 2·(15 + 21 + 35) = 142.
TriangleMesh box(const Eigen::Vector3d& origin = {0.1, -2.3, 1e-3}) {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.push_back(origin + Eigen::Vector3d(i & 1 ? 3 : 0, i & 2 ? 5 : 0, i & 4 ? 7 : 0));
  }
  mesh.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                    {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return mesh;
}
constexpr double kBoxVolume = 105, kBoxArea = 142;

// Σ a·(b × c) / 6 and Σ |(b − a) × (c − a)| / 2, written out here rather than taken from mesh.hpp.
double volume(const TriangleMesh& m) {
  double v = 0;
  for (const auto& t : m.triangles) {
    v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]])) / 6;
  }
  return v;
}
double area(const TriangleMesh& m) {
  double a = 0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d& p = m.vertices[t[0]];
    a += (m.vertices[t[1]] - p).cross(m.vertices[t[2]] - p).norm() / 2;
  }
  return a;
}

Eigen::Vector3d as_float32(const Eigen::Vector3d& v) {
  Eigen::Vector3d out;
  for (int k = 0; k < 3; ++k) {
    volatile float f = static_cast<float>(v[k]);  // volatile: keep the rounding (cli_test.cpp)
    out[k] = f;
  }
  return out;
}

using test::Bytes;

class MeshIo : public ::testing::Test {
 protected:
  test::TempDir temp_{"mesh_io_test"};
  const fs::path dir_ = temp_.path();

  fs::path write_file(const std::string& name, const std::string& bytes) const {
    const fs::path path = dir_ / name;
    test::write_text(path, bytes);
    return path;
  }
  // Reads `bytes` as file `name`; expects an IoError whose message is "<path>: ..." and contains
  // `phrase`.
  void expect_error(const std::string& name, const std::string& bytes, const std::string& phrase) {
    const fs::path path = write_file(name, bytes);
    try {
      read_mesh(path);
      ADD_FAILURE() << name << ": no error, expected '" << phrase << "'";
    } catch (const IoError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
      EXPECT_NE(message.find(phrase), std::string::npos)
          << "expected '" << phrase << "' in " << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
};

// ---- round trips ----

TEST_F(MeshIo, EveryWriterRoundTripsTheBoxExactlyExceptStlsFloat32) {
  const TriangleMesh original = box();
  ASSERT_NEAR(volume(original), kBoxVolume, 1e-12);
  ASSERT_NEAR(area(original), kBoxArea, 1e-12);
  for (const char* ext : {".ply", ".obj", ".off", ".PLY", ".Obj"}) {
    SCOPED_TRACE(ext);
    const fs::path path = dir_ / (std::string("box") + ext);
    write_mesh(path, original);
    MeshReadInfo info;
    const TriangleMesh read = read_mesh(path, {}, &info);
    EXPECT_EQ(read.vertices, original.vertices);  // float64 or %.17g: exact
    EXPECT_EQ(read.triangles, original.triangles);
    EXPECT_EQ(info.dropped_faces, 0u);
    EXPECT_NEAR(volume(read), kBoxVolume, 1e-12);
    EXPECT_NEAR(area(read), kBoxArea, 1e-12);
  }
}

TEST_F(MeshIo, StlRoundTripKeepsEachFacetsFloat32CornersUnwelded) {
  const TriangleMesh original = box();
  write_mesh(dir_ / "box.stl", original);
  EXPECT_EQ(fs::file_size(dir_ / "box.stl"), 84u + 50u * 12u);
  MeshReadInfo info;
  const TriangleMesh read = read_mesh(dir_ / "box.stl", {}, &info);
  EXPECT_EQ(info.format, "stl-binary");
  ASSERT_EQ(read.triangles.size(), 12u);
  ASSERT_EQ(read.vertices.size(), 36u);  // three per facet, as STL stores them
  for (std::size_t t = 0; t < 12; ++t) {
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(read.triangles[t][k], 3 * t + k);
      EXPECT_EQ(read.vertices[3 * t + k], as_float32(original.vertices[original.triangles[t][k]]));
    }
  }
  EXPECT_NEAR(volume(read), kBoxVolume, 1e-4);  // float32 corners
  EXPECT_NEAR(area(read), kBoxArea, 1e-4);
}

TEST_F(MeshIo, StlWriterStoresUnitFacetNormalsAndAHeaderThatIsNotSolid) {
  write_mesh(dir_ / "box.stl", box());
  const std::string bytes = test::read_text(dir_ / "box.stl");
  EXPECT_NE(bytes.rfind("solid", 0), 0u);
  float n[3];
  std::memcpy(n, bytes.data() + 84, sizeof n);  // the first facet, {0, 2, 1}: the z = min face
  EXPECT_EQ(n[0], 0.f);
  EXPECT_EQ(n[1], 0.f);
  EXPECT_EQ(n[2], -1.f);
}

TEST_F(MeshIo, PlyWriterUsesDoublesAndUintLists) {
  write_mesh(dir_ / "box.ply", box());
  std::ifstream in(dir_ / "box.ply", std::ios::binary);
  std::string header, line;
  while (std::getline(in, line) && line != "end_header") header += line + "\n";
  EXPECT_NE(header.find("format binary_little_endian 1.0\n"), std::string::npos) << header;
  EXPECT_NE(header.find("element vertex 8\nproperty double x\n"), std::string::npos) << header;
  EXPECT_NE(header.find("element face 12\nproperty list uchar uint vertex_indices\n"),
            std::string::npos)
      << header;
}

// ---- STL ----

std::string stl_binary(const std::string& header_text, const std::vector<std::array<float, 9>>& f,
                       std::uint32_t count) {
  std::string header = header_text;
  header.resize(80, ' ');
  Bytes b;
  b.text(header).put(count);
  for (const auto& corners : f) {
    b.put(0.f).put(0.f).put(1.f);
    for (const float c : corners) b.put(c);
    b.put(std::uint16_t{0});
  }
  return b.str();
}

TEST_F(MeshIo, BinaryStlWhoseHeaderStartsWithSolidIsReadAsBinary) {
  const auto path = write_file(
      "solid.stl", stl_binary("solid exported by a CAD tool", {{0, 0, 0, 1, 0, 0, 0, 1, 0}}, 1));
  MeshReadInfo info;
  const TriangleMesh mesh = read_mesh(path, {}, &info);
  EXPECT_EQ(info.format, "stl-binary");
  EXPECT_EQ(mesh.vertices, (std::vector<Eigen::Vector3d>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(mesh.triangles, (Triangles{{0, 1, 2}}));
}

TEST_F(MeshIo, AsciiStlWithSeveralSolidsCrlfAndAQuadFacet) {
  const std::string text =
      "solid a\r\n  facet normal 0 0 1\r\n    outer loop\r\n      vertex 0 0 0\r\n"
      "      vertex 1 0 0\r\n      vertex 0.1 1 0\r\n    endloop\r\n  endfacet\r\nendsolid a\r\n"
      "solid b\r\nfacet normal 0 0 0\r\nouter loop\r\nvertex 0 0 1\r\nvertex 1 0 1\r\n"
      "vertex 1 1 1\r\nvertex 0 1 1\r\nendloop\r\nendfacet\r\n"
      "facet normal 0 0 0\r\nouter loop\r\nvertex 0 0 2\r\nvertex 1 0 2\r\nendloop\r\nendfacet\r\n"
      "endsolid b\r\n";
  MeshReadInfo info;
  const TriangleMesh mesh = read_mesh(write_file("ascii.stl", text), {}, &info);
  EXPECT_EQ(info.format, "stl-ascii");
  EXPECT_EQ(info.dropped_faces, 1u);    // the two-corner loop
  ASSERT_EQ(mesh.vertices.size(), 9u);  // the dropped loop's two corners stay, unused
  EXPECT_EQ(mesh.vertices[2], Eigen::Vector3d(0.1, 1, 0));  // text is read as float64
  EXPECT_EQ(mesh.triangles, (Triangles{{0, 1, 2}, {3, 4, 5}, {3, 5, 6}}));
}

TEST_F(MeshIo, StlErrors) {
  expect_error("short.stl", "12 bytes only", "not an STL file");
  expect_error("cut.stl",
               stl_binary("binary", {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 0, 1, 0, 0, 0, 1, 0}}, 2)
                   .substr(0, 150),
               "binary STL announces 2 facets, which take 84 + 50 × 2 = 184 bytes, but the file "
               "has 150");
  // "solid" at the start, but binary bytes and the wrong size: a cut binary file, not text.
  expect_error("cut_solid.stl", stl_binary("solid x", {{0, 0, 0, 1, 0, 0, 0, 1, 0}}, 7),
               "binary STL announces 7 facets");
  expect_error("huge.stl", stl_binary("binary", {}, 0xFFFFFFFFu), "announces 4294967295 facets");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  expect_error("nan.stl",
               stl_binary("b", {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 0, nan, 0, 0, 0, 1, 0}}, 2),
               "byte offset 134 (facet 1): corner 2 has a NaN or Inf coordinate");
  const std::string facet =
      "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
      "endfacet\n";
  expect_error("truncated.stl", "solid s\n" + facet + "facet normal 0 0 1\nouter loop\n",
               "truncated file: it ends after line 10, where 'vertex' or 'endloop' should follow");
  expect_error("no_end.stl", "solid s\n" + facet, "where 'facet' or 'endsolid' should follow");
  expect_error("bad.stl", "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 zero 0\n",
               "line 4: bad number 'zero'");
  expect_error("order.stl", "solid s\nvertex 0 0 0\n",
               "line 2: unexpected 'vertex' (expected 'facet' or 'endsolid')");
  expect_error("empty_solid.stl", "solid s\nendsolid s\n", "contains no triangles");
}

// ---- OBJ ----

TEST_F(MeshIo, ObjNegativeIndicesCornerFormsFanningAndComments) {
  const std::string text =
      "# a square and a pentagon\nmtllib x.mtl\no square\nv 0 0 0\nv 1 0 0 1\nv 1 1 0\n"
      "v 0 1 0 0.5 0.5 0.5\nvt 0 0\nvn 0 0 1\ns off\nf 1/1/1 2//1 3/1 4 # a quad\n"
      "g pentagon\nv 0 0 1\nv 1 0 1\nv 2 1 1\nv 1 2 1\nv 0 1 1\n"
      "f -5 -4/1 -3//1 \\\n  -2/1/1 -1\nl 1 2\nf 1 1 2\nf 1 2\nfo 3 2 1\n";
  MeshReadInfo info;
  const TriangleMesh mesh = read_mesh(write_file("shapes.obj", text), {}, &info);
  EXPECT_EQ(info.format, "obj");
  EXPECT_EQ(info.dropped_faces, 2u);  // a repeated corner; two corners
  EXPECT_EQ(mesh.vertices.size(), 9u);
  EXPECT_EQ(mesh.vertices[3], Eigen::Vector3d(0, 1, 0));
  EXPECT_EQ(mesh.triangles,
            (Triangles{{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}, {4, 7, 8}, {2, 1, 0}}));
}

TEST_F(MeshIo, ObjFacesMayComeBeforeTheirVertices) {
  const TriangleMesh mesh =
      read_mesh(write_file("late.obj", "f 1 2 3\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\n"));
  EXPECT_EQ(mesh.triangles, (Triangles{{0, 1, 2}}));
  EXPECT_EQ(mesh.vertices.size(), 3u);
}

TEST_F(MeshIo, UnusedNonFiniteVerticesAreRemovedAndTheOthersRenumbered) {
  const TriangleMesh mesh = read_mesh(
      write_file("nan_unused.obj", "v nan 0 0\nv 0 0 0\nv inf 1 1\nv 1 0 0\nv 0 1 0\nf 2 4 5\n"));
  EXPECT_EQ(mesh.vertices, (std::vector<Eigen::Vector3d>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
  EXPECT_EQ(mesh.triangles, (Triangles{{0, 1, 2}}));
}

TEST_F(MeshIo, ObjErrors) {
  const std::string three = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  expect_error("range.obj", three + "f 1 2 3\nf 1 2 4\n",
               "line 5: vertex index 4 out of range (the file has 3 vertices)");
  expect_error("late_range.obj", "f 1 2 9\n" + three,
               "line 1: vertex index 9 out of range (the file has 3 vertices)");
  expect_error("zero.obj", three + "f 0 1 2\n", "line 4: vertex index 0 (OBJ counts from 1)");
  expect_error("relative.obj", three + "f -1 -2 -4\n",
               "line 4: relative vertex index -4 reaches before the first vertex (3 vertices so "
               "far)");
  expect_error("huge.obj", three + "f 1 2 99999999999999999999999\n",
               "line 4: vertex index '99999999999999999999999' out of range");
  expect_error("corner.obj", three + "f 1 2 x/1\n", "line 4: bad face corner 'x/1'");
  expect_error("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
               "line 4: vertex 2 has a NaN or Inf coordinate and is used by a triangle");
  expect_error("few.obj", "v 1 2\n", "line 1: expected 3 coordinates after 'v', found 2");
  expect_error("word.obj", "v 1 two 3\n", "line 1: bad number 'two'");
  expect_error("points.obj", three, "contains no triangles");
  expect_error("degenerate.obj", three + "f 1 2\nf 1 1 2\n",
               "contains no triangles (all 2 faces had fewer than 3 corners or a repeated corner)");
}

// ---- OFF ----

TEST_F(MeshIo, OffDialects) {
  const Triangles expected{{0, 1, 2}, {0, 2, 3}};
  const std::vector<std::pair<std::string, std::string>> files = {
      {"plain", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"},
      {"counts_on_keyword_line", "OFF 4 1 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"},
      {"coff_comments_crlf",
       "# colours\r\nCOFF\r\n\r\n4 1 0 # counts\r\n0 0 0 255 0 0 255\r\n1 0 0 0 255 0 255\r\n"
       "1 1 0 0 0 255 255\r\n0 1 0 9 9 9 255\r\n4 0 1 2 3 0.5 0.5 0.5\r\n"},
      {"noff", "NOFF\n4 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n4 0 1 2 3\n"},
      {"no_keyword", "4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3"},
  };
  for (const auto& [name, text] : files) {
    SCOPED_TRACE(name);
    MeshReadInfo info;
    const TriangleMesh mesh = read_mesh(write_file(name + ".off", text), {}, &info);
    EXPECT_EQ(info.format, "off");
    EXPECT_EQ(mesh.triangles, expected);
    EXPECT_EQ(mesh.vertices[2], Eigen::Vector3d(1, 1, 0));
  }
}

TEST_F(MeshIo, OffErrors) {
  const std::string square = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
  expect_error("range.off", "OFF\n4 1 0\n" + square + "3 0 1 4\n",
               "line 7: vertex index 4 out of range (the file has 4 vertices)");
  expect_error("negative.off", "OFF\n4 1 0\n" + square + "3 0 -1 2\n",
               "line 7: vertex index -1 out of range");
  expect_error("count.off", "OFF\n1000000000000 1 0\n" + square,
               "line 2: announces 1000000000000 vertices and 1 faces, but the 24 bytes after it "
               "cannot hold them");
  expect_error("faces.off", "OFF\n4 3 0\n" + square + "3 0 1 2\n",
               "the header announces 3 faces, the file ends after 1");
  expect_error("many_faces.off", "OFF\n4 100 0\n" + square + "3 0 1 2\n",
               "line 2: announces 4 vertices and 100 faces, but the 32 bytes after it cannot hold "
               "them");
  expect_error("vertices.off", "OFF\n5 0 0\n" + square + "\n\n\n\n\n\n",
               "the header announces 5 vertices, the file ends after 4");
  expect_error("corners.off", "OFF\n4 1 0\n" + square + "4 0 1 2\n",
               "line 7: the face announces 4 corners, the line holds 3");
  expect_error("binary.off", "OFF BINARY\n4 1 0\n", "line 1: binary OFF is not supported");
  expect_error("4off.off", "4OFF\n1 0 0\n0 0 0 0\n", "only 3-dimensional OFF is supported");
  expect_error("ply.off", "ply\nformat ascii 1.0\n", "not an OFF file (line 1 starts with 'ply'");
  expect_error("nan.off", "OFF\n4 1 0\n0 0 0\n1 nan 0\n1 1 0\n0 1 0\n3 0 1 2\n",
               "line 7: vertex 1 has a NaN or Inf coordinate");
  expect_error("no_faces.off", "OFF\n4 0 0\n" + square, "contains no triangles");
}

// ---- PLY ----

std::string ply_header(const std::string& format, const std::string& elements) {
  return "ply\nformat " + format + " 1.0\ncomment hand-made\n" + elements + "end_header\n";
}

// Two triangles and a quad over five vertices, faces with a colour before the corner list.
const Triangles kPlyTriangles{{0, 1, 2}, {1, 3, 2}, {0, 1, 3}, {0, 3, 4}};

std::string ply_binary(bool big, const std::string& count_type, const std::string& index_type) {
  Bytes b(big);
  b.text(ply_header(big ? "binary_big_endian" : "binary_little_endian",
                    "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
                    "property list uchar int extra\n"
                    "element face 3\nproperty uchar red\nproperty list " +
                        count_type + " " + index_type + " vertex_indices\n"));
  for (int i = 0; i < 5; ++i) b.put(float(i)).put(float(i * i)).put(-0.5f).put(std::uint8_t{0});
  const auto face = [&](std::vector<int> corners) {
    b.put(std::uint8_t{200});
    if (count_type == "uchar") b.put(static_cast<std::uint8_t>(corners.size()));
    if (count_type == "int") b.put(static_cast<std::int32_t>(corners.size()));
    for (const int c : corners) {
      if (index_type == "int") b.put(static_cast<std::int32_t>(c));
      if (index_type == "uint") b.put(static_cast<std::uint32_t>(c));
      if (index_type == "ushort") b.put(static_cast<std::uint16_t>(c));
    }
  };
  face({0, 1, 2});
  face({1, 3, 2});
  face({0, 1, 3, 4});
  return b.str();
}

TEST_F(MeshIo, PlyBinaryBothEndiannessesAndListTypes) {
  for (const bool big : {false, true}) {
    for (const auto& [count, index] : std::vector<std::pair<std::string, std::string>>{
             {"uchar", "int"}, {"int", "uint"}, {"uchar", "ushort"}}) {
      SCOPED_TRACE(std::string(big ? "BE " : "LE ") + count + " " + index);
      MeshReadInfo info;
      const TriangleMesh mesh =
          read_mesh(write_file("b.ply", ply_binary(big, count, index)), {}, &info);
      EXPECT_EQ(info.format, "ply");
      EXPECT_EQ(mesh.triangles, kPlyTriangles);
      ASSERT_EQ(mesh.vertices.size(), 5u);
      EXPECT_EQ(mesh.vertices[3], Eigen::Vector3d(3, 9, -0.5));
    }
  }
}

TEST_F(MeshIo, PlyAsciiCrlfFacesFirstAndVertexIndexName) {
  const std::string text =
      "ply\r\nformat ascii 1.0\r\nelement face 3\r\nproperty list uchar int vertex_index\r\n"
      "property uchar red\r\nelement vertex 5\r\nproperty float x\r\nproperty float y\r\n"
      "property float z\r\nend_header\r\n3 0 1 2 7\r\n3 1 3 2 7\r\n4 0 1 3 4 7\r\n"
      "0 0 -0.5\r\n1 1 -0.5\r\n2 4 -0.5\r\n3 9 -0.5\r\n4 16 0.1\r\n";
  const TriangleMesh mesh = read_mesh(write_file("a.ply", text));
  EXPECT_EQ(mesh.triangles, kPlyTriangles);
  EXPECT_EQ(mesh.vertices[4], Eigen::Vector3d(4, 16, double(0.1f)));  // float32 property
}

TEST_F(MeshIo, PlyMeshAndCloudReadersShareTheFile) {
  const fs::path path = write_file("b.ply", ply_binary(false, "uchar", "int"));
  EXPECT_TRUE(is_mesh_file(path));
  EXPECT_EQ(read_point_cloud(path).size(), 5u);  // the cloud reader takes the vertices
  write_point_cloud(dir_ / "cloud.ply", read_point_cloud(path));
  EXPECT_FALSE(is_mesh_file(dir_ / "cloud.ply"));
  expect_error("cloud.ply",
               ply_header("ascii",
                          "element vertex 1\nproperty float x\nproperty float y\n"
                          "property float z\n") +
                   "1 2 3\n",
               "no face element in the header (a point cloud, not a mesh)");
}

TEST_F(MeshIo, PlyErrors) {
  const std::string vertices =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string faces = "element face 1\nproperty list uchar int vertex_indices\n";
  expect_error("range.ply",
               ply_header("ascii", vertices + faces) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
               "line 14 (element 'face', record 0): vertex index 3 out of range (the file has 3 "
               "vertices)");
  Bytes neg;
  neg.text(ply_header("binary_little_endian", vertices + faces));
  for (int i = 0; i < 9; ++i) neg.put(float(i));
  neg.put(std::uint8_t{3}).put(0).put(-1).put(2);
  expect_error("negative.ply", neg.str(),
               "byte offset 223 (element 'face', record 0): vertex index -1 out of range");
  expect_error(
      "face_count.ply",
      ply_header("binary_little_endian", vertices + "element face 1000000000000\n"
                                                    "property list uchar int vertex_indices\n") +
          std::string(36, '\0'),
      "element 'face' announces 1000000000000 records of at least 1 bytes");
  expect_error("ascii_face_count.ply",
               ply_header("ascii", vertices + "element face 1000000\n"
                                              "property list uchar int vertex_indices\n") +
                   "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
               "element 'face' announces 1000000 records, but the 8 bytes after line 10");
  Bytes cut(true);
  cut.text(ply_header("binary_big_endian", vertices + faces));
  for (int i = 0; i < 9; ++i) cut.put(float(i));
  cut.put(std::uint8_t{3}).put(0).put(1);
  expect_error("cut.ply", cut.str(),
               "list count 3 at byte offset 220 (element 'face', property "
               "'vertex_indices') exceeds the 8 bytes remaining");
  expect_error("nan.ply",
               ply_header("ascii", vertices + faces) + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
               "line 14 (element 'face', record 0): vertex 1 has a NaN or Inf coordinate");
  expect_error(
      "float_index.ply",
      ply_header("ascii", vertices + "element face 1\nproperty list uchar float vertex_indices\n") +
          "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
      "property 'vertex_indices' of element 'face' must hold integers");
  expect_error("bad_index.ply",
               ply_header("ascii", vertices + faces) + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n",
               "line 14: bad vertex index '1.5' for property 'vertex_indices'");
  expect_error("no_list.ply",
               ply_header("ascii", vertices + "element face 1\nproperty int vertex_indices\n") +
                   "0 0 0\n1 0 0\n0 1 0\n3\n",
               "property 'vertex_indices' of element 'face' is not a list");
}

// ---- dispatch, detection, writing ----

TEST_F(MeshIo, FormatsByExtension) {
  EXPECT_EQ(mesh_format("a.STL"), MeshFormat::kStl);
  EXPECT_EQ(mesh_format("dir.x/a.obj"), MeshFormat::kObj);
  EXPECT_EQ(mesh_format("a.off"), MeshFormat::kOff);
  EXPECT_EQ(mesh_format("a.ply"), MeshFormat::kPly);
  EXPECT_EQ(mesh_format("a.stp"), MeshFormat::kStep);
  EXPECT_EQ(mesh_format("a.STEP"), MeshFormat::kStep);
  EXPECT_EQ(mesh_format("a.igs"), MeshFormat::kIges);
  EXPECT_EQ(mesh_format("a.iges"), MeshFormat::kIges);
  EXPECT_EQ(mesh_format("a.xyz"), std::nullopt);
  EXPECT_EQ(mesh_format("stl"), std::nullopt);
  EXPECT_TRUE(is_mesh_file(dir_ / "missing.stl"));  // by extension; the reader says it is missing
  EXPECT_FALSE(is_mesh_file(dir_ / "missing.ply"));
  EXPECT_FALSE(is_mesh_file(dir_ / "a.pcd"));
  EXPECT_EQ(is_mesh_file("a.step"), has_cad_exchange());
}

TEST_F(MeshIo, UnknownExtensionsAndStepWithoutOpenCascade) {
  expect_error("a.3ds", "3ds", "unknown mesh format '.3ds' (expected .stl, .obj, .ply, .off");
  expect_error("noext", "v 0 0 0", "unknown mesh format (no extension)");
  EXPECT_THROW(write_mesh(dir_ / "a.xyz", box()), OutputError);
  EXPECT_THROW(write_mesh(dir_ / "a.step", box()), OutputError);
  if (!has_cad_exchange()) expect_error("a.step", "ISO-10303-21;", "OpenCASCADE");
}

TEST_F(MeshIo, WriteMeshIsAtomicAndRefusesBadMeshes) {
  write_file("old.obj", "previous");
  TriangleMesh bad = box();
  bad.triangles.push_back({0, 1, 8});
  EXPECT_THROW(write_mesh(dir_ / "old.obj", bad), std::invalid_argument);
  TriangleMesh huge = box();
  huge.vertices[0].x() = 1e39;  // beyond float32
  EXPECT_THROW(write_mesh(dir_ / "old.stl", huge), OutputError);
  fs::create_directory(dir_ / "taken.ply");
  EXPECT_THROW(write_mesh(dir_ / "taken.ply", box()), OutputError);
  std::ifstream in(dir_ / "old.obj");
  std::string content;
  std::getline(in, content);
  EXPECT_EQ(content, "previous");
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 2u) << "a temporary was left behind";
}

// A 20 × 20 grid of squares, each split in two: 441 vertices, 800 triangles.
TriangleMesh grid() {
  TriangleMesh mesh;
  for (int i = 0; i <= 20; ++i) {
    for (int j = 0; j <= 20; ++j) mesh.vertices.emplace_back(i * 0.1, j * 0.3, (i * j) % 7 * 0.01);
  }
  for (std::uint32_t i = 0; i < 20; ++i) {
    for (std::uint32_t j = 0; j < 20; ++j) {
      const std::uint32_t a = i * 21 + j;
      mesh.triangles.push_back({a, a + 21, a + 22});
      mesh.triangles.push_back({a, a + 22, a + 1});
    }
  }
  return mesh;
}

// The readers on memory in reads of 1 to 7 bytes through a buffer much smaller than the file
// (block_reader.hpp): block boundaries anywhere give the same mesh.
TEST_F(MeshIo, ShortReadsGiveTheSameMesh) {
  const TriangleMesh original = grid();
  for (const char* ext : {".stl", ".obj", ".off", ".ply"}) {
    SCOPED_TRACE(ext);
    const fs::path path = dir_ / (std::string("grid") + ext);
    write_mesh(path, original);
    const TriangleMesh whole = read_mesh(path);
    EXPECT_EQ(whole.triangles.size(), 800u);
    const std::string bytes = test::read_text(path);
    ASSERT_GT(bytes.size(), 10000u);
    for (std::size_t max_read = 1; max_read <= 7; ++max_read) {
      detail::MemorySource source(bytes, max_read);
      detail::BlockReader reader(path, source, 600);  // above the STL reader's 512-byte look
      MeshReadInfo info;
      const std::string_view e = ext;
      const TriangleMesh mesh = e == ".stl"   ? detail::read_stl(reader, info)
                                : e == ".obj" ? detail::read_obj(reader, info)
                                : e == ".off" ? detail::read_off(reader, info)
                                              : detail::read_ply_mesh(reader, info);
      EXPECT_EQ(mesh.vertices, whole.vertices);
      EXPECT_EQ(mesh.triangles, whole.triangles);
    }
  }
}

// ---- align3d convert ----

using test::CliRun;
using test::run;

TEST_F(MeshIo, ConvertBetweenMeshFormats) {
  write_mesh(dir_ / "box.obj", box());
  const CliRun r = run({"convert", (dir_ / "box.obj").string(), (dir_ / "box.stl").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "converted " + (dir_ / "box.obj").string() + " to " +
                       (dir_ / "box.stl").string() + " (binary STL): 12 triangles, 8 vertices\n");
  const CliRun back = run({"convert", (dir_ / "box.stl").string(), (dir_ / "back.ply").string()});
  ASSERT_EQ(back.code, 0) << back.err;
  EXPECT_NEAR(volume(read_mesh(dir_ / "back.ply")), kBoxVolume, 1e-4);
}

TEST_F(MeshIo, ConvertWarnsAboutDroppedFaces) {
  write_file("d.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n");
  const CliRun r = run({"convert", (dir_ / "d.obj").string(), (dir_ / "d.off").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err, "align3d: warning: " + (dir_ / "d.obj").string() +
                       ": dropped 1 faces with fewer than 3 corners or a repeated corner\n");
}

TEST_F(MeshIo, ConvertSamplesAMeshIntoAPointCloud) {
  write_mesh(dir_ / "box.off", box());
  const CliRun r =
      run({"convert", (dir_ / "box.off").string(), (dir_ / "box.pcd").string(), "--sample", "500"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("500 points with normals sampled from 12 triangles"), std::string::npos)
      << r.out;
  const PointCloud cloud = read_point_cloud(dir_ / "box.pcd");
  ASSERT_EQ(cloud.size(), 500u);
  ASSERT_TRUE(cloud.has_normals());
  const Eigen::Vector3d centre = Eigen::Vector3d(0.1, -2.3, 1e-3) + Eigen::Vector3d(1.5, 2.5, 3.5);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_GT(cloud.normals[i].dot(cloud.positions[i] - centre), 0) << "inward normal " << i;
  }
}

TEST_F(MeshIo, ConvertExplainsWhatAMeshNeeds) {
  write_mesh(dir_ / "box.stl", box());
  const std::string in = (dir_ / "box.stl").string();
  const CliRun no_sample = run({"convert", in, (dir_ / "box.xyz").string()});
  EXPECT_EQ(no_sample.code, static_cast<int>(ExitCode::kUsage));
  EXPECT_NE(no_sample.err.find("--sample N"), std::string::npos) << no_sample.err;
  const CliRun encoding = run({"convert", in, (dir_ / "box.ply").string(), "--encoding", "ascii"});
  EXPECT_EQ(encoding.code, static_cast<int>(ExitCode::kUsage));
  const CliRun chord =
      run({"convert", in, (dir_ / "box.ply").string(), "--chord-tolerance", "0.1"});
  EXPECT_EQ(chord.code, static_cast<int>(ExitCode::kUsage));
  EXPECT_NE(chord.err.find("STEP and IGES"), std::string::npos) << chord.err;
  const CliRun step = run({"convert", in, (dir_ / "box.step").string()});
  EXPECT_EQ(step.code, static_cast<int>(ExitCode::kOutput));
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 1u) << "a file was written";
}

TEST_F(MeshIo, ConvertHelpNamesTheMeshFormatsAndOptions) {
  const CliRun help = run({"convert", "--help"});
  EXPECT_EQ(help.code, 0);
  for (const char* word : {".stl", ".obj", ".off", "--sample", "--chord-tolerance", "STEP"}) {
    EXPECT_NE(help.out.find(word), std::string::npos) << word;
  }
}

}  // namespace
}  // namespace align3d::io
