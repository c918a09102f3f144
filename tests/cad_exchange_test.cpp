// STEP and IGES input through OpenCASCADE (io/mesh_io.hpp, src/io/cad_exchange.cpp). The test makes
// its own CAD files: solids built with OCCT's primitives and a boolean cut, written with OCCT's
// STEP and IGES writers, read back with read_mesh. The oracles are closed forms: the exact area
// and volume of the solid, bounded by what the chord tolerance allows (derived below), and the
// analytic surface every vertex must lie on.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <thread>

#include "align3d/error.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/mesh.hpp"
#include "test_util.hpp"

#ifdef ALIGN3D_HAS_OCCT
#include <BRepAlgoAPI_Cut.hxx>
#include <BRepBuilderAPI_MakeEdge.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakeSphere.hxx>
#include <IGESControl_Writer.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <STEPControl_Writer.hxx>
#include <TopoDS_Shape.hxx>
#include <gp_Ax2.hxx>
#include <gp_Pnt.hxx>

#include "detail/leak_check.hpp"
#endif

namespace align3d {
namespace {

namespace fs = std::filesystem;

using test::write_text;

// The error read_mesh throws for `path`, which must be an IoError naming the file.
std::string io_error(const fs::path& path) {
  try {
    io::read_mesh(path);
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": not an IoError: " << e.what();
    return "";
  }
  ADD_FAILURE() << path << ": read without an error";
  return "";
}

#ifndef ALIGN3D_HAS_OCCT

TEST(CadExchange, WithoutOpenCascadeStepIsAnIoErrorThatSaysSo) {
  ASSERT_FALSE(io::has_cad_exchange());
  test::TempDir dir("cad");
  write_text(dir / "part.step",
             "ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\nENDSEC;\nEND-ISO-10303-21;\n");
  EXPECT_NE(io_error(dir / "part.step").find("OpenCASCADE"), std::string::npos);
}

#else

using test::kPi;

// Area, enclosed volume (divergence theorem: Σ a·(b × c) / 6 over outward triangles) and whether
// the triangles close up: after welding identical coordinates, every edge must be used by exactly
// two triangles, once in each direction (a closed, consistently wound surface). Triangles that
// welding collapses (two corners at one point: a sphere's pole, where BRepMesh keeps several nodes)
// have no area and are left out, as clean_mesh drops them. Independent of clean_mesh, whose job
// that is in the library.
struct Measured {
  double area = 0, volume = 0;
  bool closed = true;
  std::size_t collapsed = 0;
};

Measured measure(const TriangleMesh& mesh) {
  std::map<std::array<double, 3>, std::uint32_t> welded;
  std::vector<std::uint32_t> id(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3d& v = mesh.vertices[i];
    id[i] = welded.try_emplace({v.x(), v.y(), v.z()}, static_cast<std::uint32_t>(welded.size()))
                .first->second;
  }
  Measured m;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : mesh.triangles) {
    if (id[t[0]] == id[t[1]] || id[t[1]] == id[t[2]] || id[t[2]] == id[t[0]]) {
      ++m.collapsed;
      continue;
    }
    const Eigen::Vector3d &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]],
                          &c = mesh.vertices[t[2]];
    m.area += 0.5 * (b - a).cross(c - a).norm();
    m.volume += a.dot(b.cross(c)) / 6;
    for (int k = 0; k < 3; ++k) ++directed[{id[t[k]], id[t[(k + 1) % 3]]}];
  }
  for (const auto& [edge, count] : directed) {
    const auto reverse = directed.find({edge.second, edge.first});
    if (count != 1 || reverse == directed.end() || reverse->second != 1) m.closed = false;
  }
  return m;
}

// OCCT's writers report to the default messenger, which prints to stdout: quiet while writing.
// They also register their controllers once per process and cache a default placement, memory
// that LeakSanitizer reports as leaked at exit (the same for one file written or many): the test's
// own writing is not what it checks, so the leak check looks away meanwhile (ASan builds).
class QuietOcct {
 public:
  QuietOcct() : saved_(Message::DefaultMessenger()->Printers()) {
    Message::DefaultMessenger()->ChangePrinters().Clear();
  }
  ~QuietOcct() { Message::DefaultMessenger()->ChangePrinters() = saved_; }

 private:
  Message_SequenceOfPrinters saved_;
  detail::LeakCheckPause writing_is_not_checked_;
};

// The block [0, 100] × [0, 60] × [0, 40] (mm) with a through hole of radius 15 along z, its axis at
// (50, 30): planes and a cylinder, joined by circles.
constexpr double kLength = 100, kWidth = 60, kHeight = 40, kHole = 15;
const Eigen::Vector2d kHoleAxis(50, 30);

TopoDS_Shape block_with_hole(double scale = 1) {
  const TopoDS_Shape block =
      BRepPrimAPI_MakeBox(kLength * scale, kWidth * scale, kHeight * scale).Shape();
  const gp_Ax2 axis(gp_Pnt(kHoleAxis.x() * scale, kHoleAxis.y() * scale, -scale), gp::DZ());
  const TopoDS_Shape hole = BRepPrimAPI_MakeCylinder(axis, kHole * scale, (kHeight + 2) * scale);
  return BRepAlgoAPI_Cut(block, hole).Shape();
}

constexpr double kSphereRadius = 25;

// In millimetres. (OCCT 7.6.3's STEP writer, told another unit by "write.step.unit", declares it
// but keeps the numbers; LengthUnitOfTheFileIsRespected relabels a file instead.)
void write_step(const TopoDS_Shape& shape, const fs::path& path) {
  const QuietOcct quiet;
  STEPControl_Writer writer;
  ASSERT_EQ(writer.Transfer(shape, STEPControl_AsIs), IFSelect_RetDone);
  ASSERT_EQ(writer.Write(path.c_str()), IFSelect_RetDone);
}

// `unit`: the length unit of the file ("MM", "IN"); the IGES writer converts the model into it.
void write_iges(const TopoDS_Shape& shape, const fs::path& path, const char* unit = "MM") {
  const QuietOcct quiet;
  IGESControl_Writer writer(unit, /*modecr: B-rep solids, not trimmed surfaces=*/1);
  ASSERT_TRUE(writer.AddShape(shape));
  writer.ComputeModel();
  ASSERT_TRUE(writer.Write(path.c_str()));
}

class CadExchange : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!io::has_cad_exchange()) GTEST_SKIP() << "built without OpenCASCADE (ALIGN3D_OCCT)";
  }
  test::TempDir dir_{"cad"};
};

// The block's exact area and volume, and how far a tessellation with chord tolerance `chord` can
// be from them. BRepMesh puts the vertices on the surface and discretises each circle of the hole
// into a polygon inscribed in it, with sagitta s ≤ chord. Each circular segment between a chord c
// and its arc lies in the c × s rectangle, so the polygon misses at most 2πr·chord of the disc's
// area; an arc of half-angle θ exceeds its chord by 2r(θ − sin θ) ≤ 2θ·r(1 − cos θ) = 2θs
// (sin θ ≥ θ cos θ on [0, π]), so the polygon's perimeter falls short by at most 2π·chord. Planes
// and the cylinder's straight direction are exact. Hence the tessellated volume exceeds the exact
// one by 0 … 2πr·chord·h, and the area is off by −2π·chord·h (the hole's wall) … +2·2πr·chord (the
// two end faces gain what the disc loses).
struct Expected {
  double area, volume, area_below, area_above, volume_above;
};
Expected block_expected(double chord) {
  const double r = kHole, h = kHeight;
  const double area =
      2 * (kLength * kWidth + kLength * h + kWidth * h) - 2 * kPi * r * r + 2 * kPi * r * h;
  return {area, kLength * kWidth * h - kPi * r * r * h, 2 * kPi * chord * h, 4 * kPi * r * chord,
          2 * kPi * r * chord * h};
}

// The distance from p to the block's surface: its six planes and the hole's cylinder, for a point
// inside the block or on its surface.
double distance_to_block(const Eigen::Vector3d& p) {
  const double to_planes =
      std::min({std::abs(p.x()), std::abs(p.x() - kLength), std::abs(p.y()),
                std::abs(p.y() - kWidth), std::abs(p.z()), std::abs(p.z() - kHeight)});
  const double to_hole = std::abs((p.head<2>() - kHoleAxis).norm() - kHole);
  return std::min(to_planes, to_hole);
}

// The block read back at chord tolerance `chord`: closed, outward, every vertex on the surface,
// area and volume within the bounds above.
void expect_block(const TriangleMesh& mesh, double chord) {
  const Measured m = measure(mesh);
  EXPECT_TRUE(m.closed) << "the faces do not meet at identical vertices, or wind inconsistently";
  EXPECT_EQ(m.collapsed, 0u);
  const Expected e = block_expected(chord);
  EXPECT_GE(m.volume, e.volume) << "positive: outward; at least the exact volume: inscribed hole";
  EXPECT_LE(m.volume, e.volume + e.volume_above);
  EXPECT_GE(m.area, e.area - e.area_below);
  EXPECT_LE(m.area, e.area + e.area_above);
  double worst = 0, outside = 0;
  for (const Eigen::Vector3d& v : mesh.vertices) {
    worst = std::max(worst, distance_to_block(v));
    outside = std::max({outside, -v.x(), v.x() - kLength, -v.y(), v.y() - kWidth, -v.z(),
                        v.z() - kHeight, kHole - (v.head<2>() - kHoleAxis).norm()});
  }
  // Vertices are evaluations of the surface, exact to rounding; chord bounds the triangles between.
  EXPECT_LE(worst, 1e-9 * kLength);
  EXPECT_LE(outside, 1e-9 * kLength);
}

TEST_F(CadExchange, StepBlockWithHoleIsClosedOutwardAndWithinTheChordBounds) {
  write_step(block_with_hole(), dir_ / "block.step");
  io::MeshReadInfo info;
  const double chord = 0.05;
  const TriangleMesh mesh = io::read_mesh(dir_ / "block.step", {.chord_tolerance = chord}, &info);
  EXPECT_EQ(info.format, "step");
  EXPECT_EQ(info.chord_tolerance, chord);
  expect_block(mesh, chord);
}

TEST_F(CadExchange, IgesBlockWithHoleIsClosedOutwardAndWithinTheChordBounds) {
  write_iges(block_with_hole(), dir_ / "block.igs");
  io::MeshReadInfo info;
  const double chord = 0.05;
  const TriangleMesh mesh = io::read_mesh(dir_ / "block.igs", {.chord_tolerance = chord}, &info);
  EXPECT_EQ(info.format, "iges");
  expect_block(mesh, chord);
}

// A sphere tessellated with its vertices on it and every triangle within `chord` of it lies between
// the balls of radius R − chord and R, so (convex bodies) its volume and area lie between theirs.
TEST_F(CadExchange, SphereLiesBetweenTheBallsItsChordToleranceAllows) {
  write_step(BRepPrimAPI_MakeSphere(kSphereRadius).Shape(), dir_ / "sphere.stp");
  const double chord = 0.02, r = kSphereRadius;
  const TriangleMesh mesh = io::read_mesh(dir_ / "sphere.stp", {.chord_tolerance = chord});
  const Measured m = measure(mesh);
  EXPECT_TRUE(m.closed);
  EXPECT_LE(m.volume, 4 * kPi * r * r * r / 3);
  EXPECT_GE(m.volume, 4 * kPi * std::pow(r - chord, 3) / 3);
  EXPECT_LE(m.area, 4 * kPi * r * r);
  EXPECT_GE(m.area, 4 * kPi * (r - chord) * (r - chord));
  double worst = 0;
  for (const Eigen::Vector3d& v : mesh.vertices) worst = std::max(worst, std::abs(v.norm() - r));
  EXPECT_LE(worst, 1e-9 * r);
}

// Tolerances below r(1 − cos 0.05) ≈ 0.019 for the hole: above it the angular deflection decides
// (OCCT steps 0.1 rad along a circle for kAngularDeflection = 0.2) and the triangles stay the same.
TEST_F(CadExchange, SmallerToleranceGivesMoreTrianglesAndASmallerError) {
  write_step(block_with_hole(), dir_ / "block.step");
  const double exact = block_expected(0).volume;
  std::size_t previous_triangles = 0;
  double previous_error = std::numeric_limits<double>::infinity();
  for (const double chord : {0.01, 0.001, 0.0001}) {
    const TriangleMesh mesh = io::read_mesh(dir_ / "block.step", {.chord_tolerance = chord});
    const double error = measure(mesh).volume - exact;
    EXPECT_GT(mesh.triangles.size(), previous_triangles) << chord;
    EXPECT_LT(error, previous_error) << chord;
    EXPECT_LE(error, block_expected(chord).volume_above) << chord;
    previous_triangles = mesh.triangles.size();
    previous_error = error;
  }
}

// 0: kDefaultChordFraction × the bounding-box diagonal, so the same part at 1000 times the size
// (a metre-scale model, or the same in µm) gives the same triangles, scaled.
TEST_F(CadExchange, DefaultToleranceIsAFractionOfTheDiagonal) {
  write_step(block_with_hole(), dir_ / "block.step");
  write_step(block_with_hole(1000), dir_ / "large.step");
  io::MeshReadInfo info, large_info;
  const TriangleMesh mesh = io::read_mesh(dir_ / "block.step", {}, &info);
  const TriangleMesh large = io::read_mesh(dir_ / "large.step", {}, &large_info);
  const double diagonal = std::sqrt(kLength * kLength + kWidth * kWidth + kHeight * kHeight);
  EXPECT_NEAR(info.chord_tolerance, io::kDefaultChordFraction * diagonal, 1e-9 * diagonal);
  EXPECT_NEAR(large_info.chord_tolerance, 1000 * info.chord_tolerance, 1e-6 * diagonal);
  EXPECT_EQ(large.triangles.size(), mesh.triangles.size());
  expect_block(mesh, info.chord_tolerance);
}

// OCCT converts from the length unit a file declares to millimetres. A STEP file in mm reads as
// written; the same numbers declared as metres read 1000 times larger; IGES written in inches
// (OCCT's IGES writer converts the mm model to inches) reads back in mm.
TEST_F(CadExchange, LengthUnitOfTheFileIsRespected) {
  const double diagonal = std::hypot(kLength, kWidth, kHeight);
  write_step(block_with_hole(), dir_ / "block.step");
  const TriangleMesh mm = io::read_mesh(dir_ / "block.step", {.chord_tolerance = 0.05});
  EXPECT_NEAR(bounding_box_diagonal(mm), diagonal, 1e-9 * diagonal);

  std::ifstream in(dir_ / "block.step");
  std::string text{std::istreambuf_iterator<char>(in), {}};
  const std::string millimetre = "SI_UNIT(.MILLI.,.METRE.)";
  const std::size_t unit = text.find(millimetre);
  ASSERT_NE(unit, std::string::npos);
  write_text(dir_ / "block_m.step", text.replace(unit, millimetre.size(), "SI_UNIT($,.METRE.)"));
  io::MeshReadInfo info;
  const TriangleMesh m = io::read_mesh(dir_ / "block_m.step", {}, &info);
  EXPECT_NEAR(bounding_box_diagonal(m), 1000 * diagonal, 1e-9 * 1000 * diagonal);
  EXPECT_NEAR(info.chord_tolerance, 1000 * io::kDefaultChordFraction * diagonal, 1e-6 * diagonal);

  write_iges(block_with_hole(), dir_ / "block_in.igs", "IN");
  const TriangleMesh inches = io::read_mesh(dir_ / "block_in.igs", {.chord_tolerance = 0.05});
  EXPECT_NEAR(bounding_box_diagonal(inches), diagonal, 1e-6 * diagonal);
  expect_block(inches, 0.05);
}

TEST_F(CadExchange, ReadingIsDeterministicAndSafeFromTwoThreads) {
#if defined(__SANITIZE_ADDRESS__)
  // GCC 12's ASan runtime does not hold its allocator's locks across fork(): a reader's child
  // forked while the other thread allocates inherits a held lock and waits forever (seen: the
  // child blocked in the allocator, the parent on its pipe). glibc's malloc, which the plain build
  // uses, takes its locks around fork(), so the test runs there (the README's test stage).
  GTEST_SKIP() << "ASan's allocator is not fork-safe with a second thread allocating";
#endif
  write_step(block_with_hole(), dir_ / "block.step");
  TriangleMesh meshes[2];
  {
    std::jthread a([&] { meshes[0] = io::read_mesh(dir_ / "block.step"); });
    std::jthread b([&] { meshes[1] = io::read_mesh(dir_ / "block.step"); });
  }
  EXPECT_EQ(meshes[0].triangles, meshes[1].triangles);
  EXPECT_EQ(meshes[0].vertices, meshes[1].vertices);
  EXPECT_EQ(meshes[0].triangles, io::read_mesh(dir_ / "block.step").triangles);
}

// OCCT prints its reports (a parse error, IGES's entity count) to stdout through the default
// messenger; the reader diverts them while it runs and gives the messenger back its printers.
TEST_F(CadExchange, NothingReachesStdoutAndTheMessengerIsRestored) {
  write_iges(block_with_hole(), dir_ / "block.igs");
  std::ifstream in(dir_ / "block.igs");
  std::string text{std::istreambuf_iterator<char>(in), {}};
  write_text(dir_ / "cut.igs", text.substr(0, text.size() / 2));
  const Handle(Message_Messenger) messenger = Message::DefaultMessenger();
  if (messenger->Printers().IsEmpty()) messenger->AddPrinter(new Message_PrinterOStream);
  const int printers = messenger->Printers().Length();
  testing::internal::CaptureStdout();
  io::read_mesh(dir_ / "block.igs");
  EXPECT_THROW(io::read_mesh(dir_ / "cut.igs"), IoError);
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
  EXPECT_EQ(messenger->Printers().Length(), printers);
}

TEST_F(CadExchange, BadFilesAreIoErrorsNamingTheFile) {
  write_step(block_with_hole(), dir_ / "block.step");
  std::ifstream in(dir_ / "block.step");
  const std::string good{std::istreambuf_iterator<char>(in), {}};

  write_text(dir_ / "empty.step", "");
  EXPECT_NE(io_error(dir_ / "empty.step").find("file is empty"), std::string::npos);
  EXPECT_NE(io_error(dir_ / "missing.step").find("file not found"), std::string::npos);

  write_text(dir_ / "notes.step", "Meeting notes\nThe part is attached.\n");
  EXPECT_NE(io_error(dir_ / "notes.step").find("not a STEP file"), std::string::npos);
  write_text(dir_ / "notes.igs", "Meeting notes\nThe part is attached.\n");
  EXPECT_NE(io_error(dir_ / "notes.igs").find("not an IGES file"), std::string::npos);

  Random rng(7);
  std::string garbage(4096, '\0');
  for (char& c : garbage) c = static_cast<char>(static_cast<int>(rng.uniform(0, 256)));
  write_text(dir_ / "garbage.step", garbage);
  EXPECT_NE(io_error(dir_ / "garbage.step").find("not a STEP file"), std::string::npos);

  write_text(dir_ / "truncated.step", good.substr(0, good.size() / 2));
  EXPECT_NE(io_error(dir_ / "truncated.step").find("cannot parse"), std::string::npos);

  // An entity removed: the references to it dangle, which OCCT's transfer would dereference.
  const std::size_t vector = good.find("= VECTOR(");
  ASSERT_NE(vector, std::string::npos);
  const std::size_t line = good.rfind('#', vector);
  std::string dangling = good;
  dangling.erase(line, good.find(";\n", vector) + 2 - line);
  write_text(dir_ / "dangling.step", dangling);
  EXPECT_NE(io_error(dir_ / "dangling.step").find("broken file"), std::string::npos);

  // A curve but no surface.
  write_step(BRepBuilderAPI_MakeEdge(gp_Pnt(0, 0, 0), gp_Pnt(10, 0, 0)).Edge(), dir_ / "edge.stp");
  EXPECT_NE(io_error(dir_ / "edge.stp").find("no face"), std::string::npos);
  write_text(dir_ / "no_data.step",
             "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('','',(''),(''),"
             "'','','');\nFILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\nDATA;\nENDSEC;\n"
             "END-ISO-10303-21;\n");
  EXPECT_NE(io_error(dir_ / "no_data.step").find("no STEP entities"), std::string::npos);
}

TEST_F(CadExchange, NegativeOrNonFiniteChordToleranceIsAnInvalidArgument) {
  write_step(block_with_hole(), dir_ / "block.step");
  EXPECT_THROW(io::read_mesh(dir_ / "block.step", {.chord_tolerance = -1}), std::invalid_argument);
  EXPECT_THROW(io::read_mesh(dir_ / "block.step", {.chord_tolerance = std::nan("")}),
               std::invalid_argument);
}

#endif

}  // namespace
}  // namespace align3d
