// Point-cloud and matrix file I/O. Oracles: round trips through every encoding compared with the
// float32-rounded original; hand-built files (bytes written here, independently of the writers)
// with known coordinates; and a catalogue of malformed files, each of which must raise an IoError
// naming the file and the problem.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/ply_attributes.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "test_util.hpp"

namespace align3d::io {
namespace {

namespace fs = std::filesystem;

// Each test works in its own empty folder, removed afterwards.
class IoTest : public ::testing::Test {
 protected:
  test::TempDir temp_{"io_test"};
  const fs::path dir_ = temp_.path();

  fs::path write_file(const std::string& name, const std::string& bytes) const {
    const fs::path path = dir_ / name;
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return path;
  }
};

using test::Bytes;

// An LZF stream of literal runs only (control byte n-1, then n <= 32 bytes): valid by construction,
// so it tests the reader's column layout independently of liblzf's compressor and of write_pcd.
std::string lzf_literals(const std::string& raw) {
  std::string out;
  for (std::size_t i = 0; i < raw.size(); i += 32) {
    const std::size_t n = std::min<std::size_t>(32, raw.size() - i);
    out += static_cast<char>(n - 1);
    out.append(raw, i, n);
  }
  return out;
}

std::string format_double(double v) {
  std::array<char, 40> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  return std::string(buffer.data(), result.ptr);
}

PointCloud random_cloud(std::size_t n, bool with_normals, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coordinate(-250.0, 250.0);
  std::normal_distribution<double> gaussian;
  PointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) {
    cloud.positions.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
    if (with_normals) {
      cloud.normals.push_back(
          Eigen::Vector3d(gaussian(rng), gaussian(rng), gaussian(rng)).normalized());
    }
  }
  // Values at the edges of what a text or float32 writer must get right.
  cloud.positions[0] = Eigen::Vector3d(0.0, -0.0, 1e-30);
  cloud.positions[1] = Eigen::Vector3d(1e30, -123456.789, 0.1);
  return cloud;
}

// Rounded through a volatile float: GCC 12 at -O3 folded the double→float→double round trip
// of x and y here (seen with both Eigen's cast chain and plain static_casts).
double round_to_float(double x) {
  volatile float f = static_cast<float>(x);
  return f;
}
Eigen::Vector3d to_float32(const Eigen::Vector3d& v) {
  return {round_to_float(v.x()), round_to_float(v.y()), round_to_float(v.z())};
}

// ---- round trips ----

struct Encoding {
  std::string name;
  std::string extension;
  std::function<void(const fs::path&, const PointCloud&)> write;
  bool float32 = true;  // stores float32 (else %.9g text)
  bool stores_normals = true;
};

std::vector<Encoding> encodings() {
  const auto write_by_extension = [](const fs::path& p, const PointCloud& c) {
    write_point_cloud(p, c);
  };
  return {
      {"PlyAscii", ".ply",
       [](const fs::path& p, const PointCloud& c) { write_ply(p, c, PlyEncoding::kAscii); }},
      {"PlyBinaryLittleEndian", ".ply",
       [](const fs::path& p, const PointCloud& c) {
         write_ply(p, c, PlyEncoding::kBinaryLittleEndian);
       }},
      {"PlyBinaryBigEndian", ".ply",
       [](const fs::path& p, const PointCloud& c) {
         write_ply(p, c, PlyEncoding::kBinaryBigEndian);
       }},
      {"PcdAscii", ".pcd",
       [](const fs::path& p, const PointCloud& c) { write_pcd(p, c, PcdEncoding::kAscii); }},
      {"PcdBinary", ".pcd",
       [](const fs::path& p, const PointCloud& c) { write_pcd(p, c, PcdEncoding::kBinary); }},
      {"PcdBinaryCompressed", ".pcd",
       [](const fs::path& p, const PointCloud& c) {
         write_pcd(p, c, PcdEncoding::kBinaryCompressed);
       }},
      {"Xyz", ".xyz", [](const fs::path& p, const PointCloud& c) { write_xyz(p, c); }, false,
       false},
      {"WritePointCloudPly", ".ply", write_by_extension},
      {"WritePointCloudPcd", ".PCD", write_by_extension},
      {"WritePointCloudTxt", ".txt", write_by_extension, false, false},
      {"WritePointCloudCsv", ".csv", write_by_extension, false, false},
  };
}

void PrintTo(const Encoding& encoding, std::ostream* os) { *os << encoding.name; }

class IoRoundTripTest : public IoTest,
                        public ::testing::WithParamInterface<std::tuple<Encoding, bool>> {};

TEST_P(IoRoundTripTest, ReadsBackWhatWasWritten) {
  const auto& [encoding, with_normals] = GetParam();
  const PointCloud original = random_cloud(1000, with_normals, 42);
  const fs::path path = dir_ / ("cloud" + encoding.extension);
  encoding.write(path, original);

  ReadInfo info;
  info.dropped_non_finite = 99;
  const PointCloud read = read_point_cloud(path, &info);
  EXPECT_EQ(info.dropped_non_finite, 0u);
  ASSERT_EQ(read.size(), original.size());
  for (std::size_t i = 0; i < original.size(); ++i) {
    const Eigen::Vector3d& p = original.positions[i];
    if (encoding.float32) {
      // Float32 storage: the reader must return exactly the float-rounded coordinate.
      EXPECT_EQ(read.positions[i], to_float32(p))
          << "point " << i << std::hexfloat << ": " << read.positions[i].transpose() << " vs "
          << to_float32(p).transpose() << " from " << p.transpose();
    } else {
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(read.positions[i][k], p[k], 1e-8 * std::max(1.0, std::abs(p[k])))
            << "point " << i;
      }
    }
  }
  EXPECT_EQ(read.has_normals(), with_normals && encoding.stores_normals);
  if (read.has_normals()) {
    for (std::size_t i = 0; i < original.size(); ++i) {
      const Eigen::Vector3d expected = to_float32(original.normals[i]).normalized();
      EXPECT_LT((read.normals[i] - expected).norm(), 1e-12) << "normal " << i;
      EXPECT_NEAR(read.normals[i].norm(), 1.0, 1e-12);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllEncodings, IoRoundTripTest,
                         ::testing::Combine(::testing::ValuesIn(encodings()), ::testing::Bool()),
                         [](const auto& info) {
                           return std::get<0>(info.param).name +
                                  (std::get<1>(info.param) ? "WithNormals" : "");
                         });

TEST_F(IoTest, WritePointCloudPicksTheEncodingByExtension) {
  const PointCloud cloud = random_cloud(10, false, 1);
  const auto head = [&](const std::string& name, std::size_t n) {
    write_point_cloud(dir_ / name, cloud);
    std::ifstream in(dir_ / name, std::ios::binary);
    std::string text(n, '\0');
    in.read(text.data(), static_cast<std::streamsize>(n));
    return text;
  };
  EXPECT_EQ(head("a.ply", 35), "ply\nformat binary_little_endian 1.0");
  EXPECT_NE(head("a.pcd", 400).find("\nDATA binary\n"), std::string::npos);
  EXPECT_EQ(head("a.xyz", 2), "0 ");
}

TEST_F(IoTest, WriteWithUnknownExtensionIsAnOutputErrorAndWritesNothing) {
  EXPECT_THROW(write_point_cloud(dir_ / "cloud.obj", random_cloud(5, false, 1)), OutputError);
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(IoTest, WritersLeaveNoTemporaryFileAndReplaceTheOldContent) {
  const fs::path path = dir_ / "cloud.ply";
  write_ply(path, random_cloud(50, true, 1));
  write_ply(path, random_cloud(7, false, 2), PlyEncoding::kAscii);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
  EXPECT_EQ(read_point_cloud(path).size(), 7u);
}

TEST_F(IoTest, WriteIntoAMissingFolderIsAnOutputErrorWithThePath) {
  const fs::path path = dir_ / "no_such_folder" / "a.pcd";
  try {
    write_pcd(path, random_cloud(5, false, 1));
    FAIL() << "no OutputError";
  } catch (const OutputError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_EQ(std::string(e.what()).rfind(path.string() + ": cannot write", 0), 0u) << e.what();
  }
}

TEST_F(IoTest, ReadErrorsCarryThePath) {
  const fs::path path = write_file("bad.xyz", "1 2 x\n");
  try {
    read_point_cloud(path);
    FAIL() << "no IoError";
  } catch (const IoError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_EQ(std::string(e.what()), path.string() + ": line 1: bad number 'x'");
  }
}

TEST_F(IoTest, WriteSettingsByEncodingName) {
  EXPECT_EQ(write_settings(CloudFormat::kPly, "ascii").ply, PlyEncoding::kAscii);
  EXPECT_EQ(write_settings(CloudFormat::kPly, "binary_big_endian").ply,
            PlyEncoding::kBinaryBigEndian);
  EXPECT_EQ(write_settings(CloudFormat::kPly, "").ply, PlyEncoding::kBinaryLittleEndian);
  EXPECT_EQ(write_settings(CloudFormat::kPcd, "binary_compressed").pcd,
            PcdEncoding::kBinaryCompressed);
  EXPECT_EQ(encoding_name(CloudFormat::kPcd, write_settings(CloudFormat::kPcd, "ascii")), "ascii");
  EXPECT_THROW(write_settings(CloudFormat::kPcd, "binary_big_endian"), std::invalid_argument);
  EXPECT_THROW(write_settings(CloudFormat::kXyz, "ascii"), std::invalid_argument);
  EXPECT_NO_THROW(write_settings(CloudFormat::kXyz, ""));
}

TEST(RigidProblem, SaysWhatIsNotRigidAndSnapsWhatIs) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  EXPECT_EQ(rigid_problem(m), "");
  m(3, 0) = 0.5;
  bool last_row = false;
  EXPECT_NE(rigid_problem(m, &last_row).find("last row must be 0 0 0 1"), std::string::npos);
  EXPECT_TRUE(last_row);
  m = Eigen::Matrix4d::Identity();
  m(0, 0) = 2;
  EXPECT_NE(rigid_problem(m, &last_row).find("not orthonormal"), std::string::npos);
  EXPECT_FALSE(last_row);
  m(0, 0) = -1;
  EXPECT_NE(rigid_problem(m).find("determinant -1"), std::string::npos);
  m(0, 0) = std::nan("");
  EXPECT_NE(rigid_problem(m).find("non-finite"), std::string::npos);
  // A rotation a few ulps off comes back orthonormal, the translation as it was.
  Eigen::Matrix4d r = Eigen::Matrix4d::Identity();
  r.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  r(0, 1) += 1e-9;
  r.topRightCorner<3, 1>() = Eigen::Vector3d(1, -2, 3);
  ASSERT_EQ(rigid_problem(r), "");
  const Eigen::Isometry3d T = to_rigid(r);
  EXPECT_LT((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1, -2, 3));
}

TEST_F(IoTest, EmptyCloudIsWrittenButReadingItSaysNoPoints) {
  // A text file of no points is an empty file.
  for (const auto& [name, phrase] : {std::pair{"e.ply", "contains no points"},
                                     {"e.pcd", "contains no points"},
                                     {"e.xyz", "file is empty"}}) {
    write_point_cloud(dir_ / name, PointCloud{});
    try {
      read_point_cloud(dir_ / name);
      ADD_FAILURE() << name << ": no error";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(phrase), std::string::npos) << e.what();
    }
  }
  write_pcd(dir_ / "c.pcd", PointCloud{}, PcdEncoding::kBinaryCompressed);
  EXPECT_THROW(read_point_cloud(dir_ / "c.pcd"), IoError);
}

// ---- PLY by hand ----

// Faces before and after the vertex element, list properties, and vertex properties of mixed types
// interleaved with colours: the reader must pick x y z out of all of it.
const char* const kPlyHeaderTail =
    "comment made by hand\n"
    "obj_info scanner 3000\n"
    "element face 2\n"
    "property list uchar int vertex_indices\n"
    "property uchar flags\n"
    "element vertex 3\n"
    "property double x\n"
    "property uchar red\n"
    "property float y\n"
    "property uchar green\n"
    "property short z\n"
    "property uchar blue\n"
    "element edge 1\n"
    "property list ushort uint vertex_pair\n"
    "property float weight\n"
    "end_header\n";

const std::vector<Eigen::Vector3d> kHandPoints = {
    {0.1, -2.5, -7.0}, {1000.0, 0.03125, 32767.0}, {-0.0, 100.0, -32768.0}};

TEST_F(IoTest, PlyAsciiSkipsOtherPropertiesAndElements) {
  const std::string text = std::string("ply\nformat ascii 1.0\n") + kPlyHeaderTail +
                           "3 0 1 2 7\n"
                           "4 0 1 2 0 9\n"
                           "0.1 255 -2.5 0 -7 128\n"
                           "1e3 1 3.125e-2 2 32767 3\n"
                           "-0.0 0 100 0 -32768 0\n"
                           "2 0 1 0.5\n";
  const PointCloud cloud = read_point_cloud(write_file("hand.ply", text));
  EXPECT_EQ(cloud.positions, kHandPoints);
  EXPECT_FALSE(cloud.has_normals());
}

class IoPlyBinaryHandTest : public IoTest, public ::testing::WithParamInterface<bool> {};

TEST_P(IoPlyBinaryHandTest, SkipsOtherPropertiesAndElements) {
  const bool big = GetParam();
  Bytes b(big);
  b.text(big ? "ply\nformat binary_big_endian 1.0\n" : "ply\nformat binary_little_endian 1.0\n")
      .text(kPlyHeaderTail);
  b.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2);
  b.put<std::uint8_t>(7);
  b.put<std::uint8_t>(4).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(2);
  b.put<std::int32_t>(0).put<std::uint8_t>(9);
  for (const auto& p : kHandPoints) {
    b.put<double>(p.x()).put<std::uint8_t>(200).put<float>(static_cast<float>(p.y()));
    b.put<std::uint8_t>(100).put<std::int16_t>(static_cast<std::int16_t>(p.z()));
    b.put<std::uint8_t>(50);
  }
  b.put<std::uint16_t>(2).put<std::uint32_t>(0).put<std::uint32_t>(1).put<float>(0.5f);
  const PointCloud cloud = read_point_cloud(write_file("hand.ply", b.str()));
  EXPECT_EQ(cloud.positions, kHandPoints);
}

INSTANTIATE_TEST_SUITE_P(Endianness, IoPlyBinaryHandTest, ::testing::Bool(), [](const auto& info) {
  return info.param ? "BigEndian" : "LittleEndian";
});

TEST_F(IoTest, PlyBinaryVertexElementWithAListProperty) {
  Bytes b;
  b.text(
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
      "property list uchar float extra\nproperty float y\nproperty float z\nend_header\n");
  b.put<float>(1.f).put<std::uint8_t>(0).put<float>(2.f).put<float>(3.f);
  b.put<float>(4.f).put<std::uint8_t>(3).put<float>(9.f).put<float>(9.f).put<float>(9.f);
  b.put<float>(5.f).put<float>(6.f);
  const PointCloud cloud = read_point_cloud(write_file("list.ply", b.str()));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1, 2, 3}, {4, 5, 6}}));
}

TEST_F(IoTest, PlyNormalsAreNormalised) {
  const PointCloud cloud = read_point_cloud(write_file(
      "n.ply",
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n"
      "0 0 0 0 0 2\n1 1 1 3 4 0\n"));
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_EQ(cloud.normals[0], Eigen::Vector3d(0, 0, 1));
  EXPECT_LT((cloud.normals[1] - Eigen::Vector3d(0.6, 0.8, 0)).norm(), 1e-15);
}

// A PLY with attributes (io/ply_attributes.hpp) carries normals after x y z; the cloud reader takes
// them back as the cloud's normals, and skips the attributes after them.
TEST_F(IoTest, PlyAttributesNormalsReadBackAsTheCloudsNormals) {
  const std::vector<Eigen::Vector3d> positions = {{0, 0, 0}, {1, 2, 3}, {-4, 5.5, 6}};
  PlyAttributes a;
  a.normals = {{0, 0, 1}, {0.6, 0.8, 0}, Eigen::Vector3d(1, 1, 1).normalized()};
  a.ints = {{"scan", {0, 1, 7}}};
  a.colors = {{{1, 2, 3}}, {{4, 5, 6}}, {{7, 8, 9}}};
  write_ply(dir_ / "a.ply", positions, a);
  const PointCloud cloud = read_point_cloud(dir_ / "a.ply");
  ASSERT_EQ(cloud.size(), 3u);
  ASSERT_TRUE(cloud.has_normals());
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_LT((cloud.positions[i] - positions[i]).norm(), 1e-6) << i;
    EXPECT_LT((cloud.normals[i] - a.normals[i]).norm(), 1e-7) << i;  // float32, renormalised
  }
  // The header lists them in that order, and the bytes hold 6 floats, an int and 3 bytes a point.
  const std::string bytes = test::read_text(dir_ / "a.ply");
  EXPECT_NE(bytes.find("property float z\nproperty float nx\nproperty float ny\nproperty float "
                       "nz\nproperty int scan\nproperty uchar red"),
            std::string::npos);
  EXPECT_EQ(bytes.size() - bytes.find("end_header\n") - 11, 3u * (6 * 4 + 4 + 3));
  // Without normals nothing changes: no nx, and the cloud has none.
  write_ply(dir_ / "b.ply", positions, PlyAttributes{});
  EXPECT_FALSE(read_point_cloud(dir_ / "b.ply").has_normals());
  a.normals.pop_back();
  EXPECT_THROW(write_ply(dir_ / "c.ply", positions, a), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_ / "c.ply"));
}

TEST_F(IoTest, PlyNormalsWithTinyOrHugeComponentsBecomeUnitVectors) {
  // Their squared norms underflow (1e-170, subnormal 4e-310) or overflow (1e200); found by the PLY
  // fuzzer, which required every normal to have norm 1 within 1e-9.
  const PointCloud cloud = read_point_cloud(write_file(
      "n.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty double nx\nproperty double ny\nproperty double nz\nend_header\n"
      "0 0 0 0 3e-170 4e-170\n1 1 1 -4e-310 0 0\n2 2 2 3e200 0 4e200\n"));
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_LT((cloud.normals[0] - Eigen::Vector3d(0, 0.6, 0.8)).norm(), 1e-15);
  EXPECT_EQ(cloud.normals[1], Eigen::Vector3d(-1, 0, 0));
  EXPECT_LT((cloud.normals[2] - Eigen::Vector3d(0.6, 0, 0.8)).norm(), 1e-15);
}

TEST_F(IoTest, PlyZeroOrNaNNormalMeansNoNormals) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n";
  const PointCloud zero =
      read_point_cloud(write_file("zero.ply", header + "0 0 0 0 0 1\n1 1 1 0 0 0\n"));
  EXPECT_EQ(zero.size(), 2u);
  EXPECT_FALSE(zero.has_normals());
  const PointCloud nan =
      read_point_cloud(write_file("nan.ply", header + "0 0 0 nan 0 1\n1 1 1 0 0 1\n"));
  EXPECT_EQ(nan.size(), 2u);
  EXPECT_FALSE(nan.has_normals());
  // The normal of a dropped point does not count.
  const PointCloud dropped =
      read_point_cloud(write_file("dropped.ply", header + "nan 0 0 0 0 0\n1 1 1 0 0 1\n"));
  EXPECT_EQ(dropped.size(), 1u);
  EXPECT_TRUE(dropped.has_normals());
}

TEST_F(IoTest, PlyWithCrLfHeaderAndSizedTypeNames) {
  Bytes b;
  b.text(
      "ply\r\nformat binary_little_endian 1.0\r\nelement vertex 1\r\nproperty float32 x\r\n"
      "property int32 y\r\nproperty uint8 z\r\nend_header\r\n");
  b.put<float>(1.5f).put<std::int32_t>(-3).put<std::uint8_t>(250);
  const PointCloud cloud = read_point_cloud(write_file("crlf.ply", b.str()));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1.5, -3, 250}}));
}

TEST_F(IoTest, PlyNonFinitePointsAreDroppedAndCounted) {
  Bytes b;
  b.text(
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n");
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  b.put(1.f).put(2.f).put(3.f).put(nan).put(0.f).put(0.f).put(0.f).put(-inf).put(0.f);
  b.put(4.f).put(5.f).put(6.f);
  ReadInfo info;
  const PointCloud cloud = read_point_cloud(write_file("nan.ply", b.str()), &info);
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_EQ(info.dropped_non_finite, 2u);
}

// ---- PCD by hand ----

struct PcdField {
  std::string name;
  char type;
  int size;
  int count;
};

// Extra fields with several sizes and types, a COUNT 3 field between x and y, and normals.
const std::vector<PcdField> kPcdFields = {{"x", 'F', 4, 1},        {"hist", 'F', 4, 3},
                                          {"y", 'F', 8, 1},        {"z", 'I', 2, 1},
                                          {"rgb", 'F', 4, 1},      {"intensity", 'U', 2, 1},
                                          {"normal_x", 'F', 4, 1}, {"normal_y", 'F', 4, 1},
                                          {"normal_z", 'F', 4, 1}, {"curvature", 'F', 4, 1}};
// Per point, all values in field order.
const std::vector<std::vector<double>> kPcdValues = {
    {1.5, 9, 9, 9, -2.25, -7, 4.2108e+06, 100, 0, 0, 2, 0.1},
    {-0.5, 8, 8, 8, 1e-3, 300, 0, 65535, 3, 4, 0, 0.2},
};

void put_pcd_value(Bytes& b, const PcdField& f, double v) {
  if (f.type == 'F' && f.size == 4) b.put(static_cast<float>(v));
  if (f.type == 'F' && f.size == 8) b.put(v);
  if (f.type == 'I' && f.size == 2) b.put(static_cast<std::int16_t>(v));
  if (f.type == 'U' && f.size == 2) b.put(static_cast<std::uint16_t>(v));
}

std::string pcd_header(const std::vector<PcdField>& fields, std::size_t points,
                       const std::string& data) {
  std::string names, sizes, types, counts;
  // Appended piece by piece: `" " + std::to_string(n)` here is a false -Wstringop-overflow of
  // GCC 12 at -O3 once this file is part of a larger translation unit (a unity build).
  for (const auto& f : fields) {
    names.append(" ").append(f.name);
    sizes.append(" ").append(std::to_string(f.size));
    types.append(" ").append(1, f.type);
    counts.append(" ").append(std::to_string(f.count));
  }
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS" + names + "\nSIZE" +
         sizes + "\nTYPE" + types + "\nCOUNT" + counts + "\nWIDTH " + std::to_string(points) +
         "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(points) + "\nDATA " +
         data + "\n";
}

void expect_hand_pcd(const PointCloud& cloud) {
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.positions[0], Eigen::Vector3d(1.5, -2.25, -7));
  EXPECT_EQ(cloud.positions[1], Eigen::Vector3d(-0.5, 1e-3, 300));  // y is F 8: 1e-3 exactly
  ASSERT_TRUE(cloud.has_normals());
  EXPECT_EQ(cloud.normals[0], Eigen::Vector3d(0, 0, 1));
  EXPECT_LT((cloud.normals[1] - Eigen::Vector3d(0.6, 0.8, 0)).norm(), 1e-15);
}

TEST_F(IoTest, PcdAsciiSkipsOtherFieldsHonouringCount) {
  std::string text = pcd_header(kPcdFields, 2, "ascii");
  for (const auto& point : kPcdValues) {
    for (std::size_t i = 0; i < point.size(); ++i) {
      if (i > 0) text += ' ';  // not (i ? " " : "") + ...: GCC 12 warns falsely (-Wrestrict)
      text += format_double(point[i]);
    }
    text += "\n";
  }
  expect_hand_pcd(read_point_cloud(write_file("hand.pcd", text)));
}

TEST_F(IoTest, PcdBinarySkipsOtherFieldsHonouringCount) {
  Bytes b;
  b.text(pcd_header(kPcdFields, 2, "binary"));
  for (const auto& point : kPcdValues) {
    std::size_t v = 0;
    for (const auto& f : kPcdFields) {
      for (int c = 0; c < f.count; ++c) put_pcd_value(b, f, point[v++]);
    }
  }
  expect_hand_pcd(read_point_cloud(write_file("hand.pcd", b.str())));
}

TEST_F(IoTest, PcdBinaryCompressedStoresOneColumnPerField) {
  Bytes columns;
  std::size_t first_value = 0;
  for (const auto& f : kPcdFields) {
    for (const auto& point : kPcdValues) {
      for (int c = 0; c < f.count; ++c) put_pcd_value(columns, f, point[first_value + c]);
    }
    first_value += static_cast<std::size_t>(f.count);
  }
  const std::string packed = lzf_literals(columns.str());
  Bytes b;
  b.text(pcd_header(kPcdFields, 2, "binary_compressed"));
  b.put(static_cast<std::uint32_t>(packed.size()))
      .put(static_cast<std::uint32_t>(columns.str().size()));
  b.text(packed);
  expect_hand_pcd(read_point_cloud(write_file("hand.pcd", b.str())));
}

TEST_F(IoTest, PcdOrganizedCloudDropsNaNPoints) {
  Bytes b;
  b.text(
      "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 2\n"
      "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\nDATA binary\n");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 6; ++i) {
    if (i == 1 || i == 4) {
      b.put(nan).put(nan).put(nan);
    } else {
      b.put(static_cast<float>(i)).put(0.f).put(1.f);
    }
  }
  ReadInfo info;
  const PointCloud cloud = read_point_cloud(write_file("organized.pcd", b.str()), &info);
  EXPECT_EQ(cloud.positions,
            (std::vector<Eigen::Vector3d>{{0, 0, 1}, {2, 0, 1}, {3, 0, 1}, {5, 0, 1}}));
  EXPECT_EQ(info.dropped_non_finite, 2u);
}

TEST_F(IoTest, PcdOlderHeaderWithoutCountHeightOrPoints) {
  const PointCloud cloud = read_point_cloud(write_file(
      "old.pcd", "COLUMNS x y z\nSIZE 8 8 8\nTYPE F F F\nWIDTH 2\nDATA ascii\n1 2 3\r\n4 5 6\n"));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1, 2, 3}, {4, 5, 6}}));
}

// ---- organized PCD, VIEWPOINT ----

TEST_F(IoTest, PcdViewpointWidthAndHeightAreReported) {
  ReadInfo info;
  read_point_cloud(write_file("vp.pcd",
                              "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\n"
                              "VIEWPOINT 1.5 -2 3e3 0.5 -0.5 0.5 0.5\nPOINTS 2\nDATA ascii\n"
                              "1 2 3\n4 5 6\n"),
                   &info);
  EXPECT_EQ(info.width, 2u);
  EXPECT_EQ(info.height, 1u);
  EXPECT_EQ(info.viewpoint.position, Eigen::Vector3d(1.5, -2, 3000));
  EXPECT_EQ(info.viewpoint.orientation.coeffs(), Eigen::Vector4d(-0.5, 0.5, 0.5, 0.5));  // x y z w
  // A quaternion that is not unit is normalised; a file without VIEWPOINT has the identity.
  read_point_cloud(write_file("vp2.pcd",
                              "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\n"
                              "VIEWPOINT 0 0 0 0 0 0 4e-310\nDATA ascii\n1 2 3\n"),
                   &info);
  EXPECT_EQ(info.viewpoint.orientation.coeffs(), Eigen::Vector4d(0, 0, 1, 0));
  read_point_cloud(write_file("vp3.pcd",
                              "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\n"
                              "DATA ascii\n1 2 3\n"),
                   &info);
  EXPECT_EQ(info.viewpoint.orientation.coeffs(), Eigen::Vector4d(0, 0, 0, 1));
  EXPECT_EQ(info.viewpoint.position, Eigen::Vector3d::Zero());
  EXPECT_EQ(info.width, 1u);
  EXPECT_EQ(info.height, 1u);
}

// A 4 x 3 depth image with pixels without a return (NaN), written organized and read back.
class IoOrganizedPcdTest : public IoTest, public ::testing::WithParamInterface<PcdEncoding> {};

TEST_P(IoOrganizedPcdTest, KeepsNaNPixelsInPlaceAndTheViewpoint) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  PointCloud image;
  std::vector<Eigen::Vector3d> finite;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      const bool hole = (row * 4 + col) % 5 == 1;  // pixels 1, 6 and 11
      image.positions.push_back(hole ? Eigen::Vector3d(nan, nan, nan)
                                     : Eigen::Vector3d(col * 0.25, row * -0.5, 2.0 + col));
      if (!hole) finite.push_back(image.positions.back());
    }
  }
  PcdLayout layout;
  layout.width = 4;
  layout.height = 3;
  layout.viewpoint.position = Eigen::Vector3d(0.1, -0.2, 1.0 / 3.0);
  layout.viewpoint.orientation = Eigen::Quaterniond(0.5, 0.5, -0.5, 0.5);
  const fs::path path = dir_ / "image.pcd";
  write_pcd(path, image, GetParam(), layout);

  ReadInfo info;
  const PointCloud cloud = read_point_cloud(path, &info);
  EXPECT_EQ(cloud.positions, finite);
  EXPECT_EQ(info.dropped_non_finite, 3u);
  EXPECT_EQ(info.width, 4u);
  EXPECT_EQ(info.height, 3u);
  EXPECT_EQ(info.viewpoint.position, layout.viewpoint.position);  // written with 17 digits
  EXPECT_LT((info.viewpoint.orientation.coeffs() - layout.viewpoint.orientation.coeffs()).norm(),
            1e-15);

  // The holes sit in their pixels: in binary, record i is bytes [12 i, 12 i + 12) of the body.
  if (GetParam() != PcdEncoding::kBinary) return;
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t body = bytes.find("DATA binary\n") + 12;
  ASSERT_EQ(bytes.size(), body + 12 * 12);
  for (std::size_t i = 0; i < 12; ++i) {
    float x = 0;
    std::memcpy(&x, bytes.data() + body + 12 * i, sizeof(float));
    EXPECT_EQ(std::isnan(x), i % 5 == 1) << "pixel " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(AllEncodings, IoOrganizedPcdTest,
                         ::testing::Values(PcdEncoding::kAscii, PcdEncoding::kBinary,
                                           PcdEncoding::kBinaryCompressed));

TEST_F(IoTest, UnorganizedPcdLeavesNonFinitePointsOut) {
  PointCloud cloud = random_cloud(20, true, 3);
  cloud.positions[4].y() = std::numeric_limits<double>::infinity();
  cloud.positions[9].x() = std::numeric_limits<double>::quiet_NaN();
  for (const PcdEncoding encoding :
       {PcdEncoding::kAscii, PcdEncoding::kBinary, PcdEncoding::kBinaryCompressed}) {
    write_pcd(dir_ / "u.pcd", cloud, encoding);
    ReadInfo info;
    const PointCloud read = read_point_cloud(dir_ / "u.pcd", &info);
    EXPECT_EQ(info.dropped_non_finite, 0u);
    EXPECT_EQ(info.width, 18u);
    ASSERT_EQ(read.size(), 18u);
    EXPECT_EQ(read.positions[4], to_float32(cloud.positions[5]));
    EXPECT_EQ(read.positions[17], to_float32(cloud.positions[19]));
    EXPECT_TRUE(read.has_normals());
  }
}

TEST_F(IoTest, OrganizedLayoutMustMatchTheCloud) {
  const PointCloud cloud = random_cloud(12, false, 1);
  for (const auto& [width, height] : {std::pair<std::size_t, std::size_t>{5, 3}, {12, 0}, {0, 1}}) {
    PcdLayout layout;
    layout.width = width;
    layout.height = height;
    EXPECT_THROW(write_pcd(dir_ / "bad.pcd", cloud, PcdEncoding::kBinary, layout),
                 std::invalid_argument);
  }
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(IoTest, WritePointCloudHonoursTheSettingsOfItsFormat) {
  PointCloud image = random_cloud(6, false, 2);
  image.positions[2].z() = std::numeric_limits<double>::quiet_NaN();
  WriteSettings settings;
  settings.pcd = PcdEncoding::kAscii;
  settings.pcd_layout.width = 3;
  settings.pcd_layout.height = 2;
  settings.ply = PlyEncoding::kBinaryBigEndian;
  write_point_cloud(dir_ / "a.pcd", image, settings);
  write_point_cloud(dir_ / "a.ply", random_cloud(6, false, 2), settings);
  ReadInfo info;
  EXPECT_EQ(read_point_cloud(dir_ / "a.pcd", &info).size(), 5u);
  EXPECT_EQ(info.height, 2u);
  std::ifstream pcd(dir_ / "a.pcd");
  const std::string text((std::istreambuf_iterator<char>(pcd)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\nWIDTH 3\nHEIGHT 2\n"), std::string::npos);
  EXPECT_NE(text.find(" nan\n"), std::string::npos);  // z of point 2, kept in place
  std::ifstream ply(dir_ / "a.ply");
  std::string line;
  std::getline(ply, line);
  std::getline(ply, line);
  EXPECT_EQ(line, "format binary_big_endian 1.0");
}

TEST_F(IoTest, CloudFormatByExtension) {
  EXPECT_EQ(cloud_format("a/b.PLY"), CloudFormat::kPly);
  EXPECT_EQ(cloud_format("b.pcd"), CloudFormat::kPcd);
  for (const char* name : {"c.xyz", "c.TXT", "c.csv"})
    EXPECT_EQ(cloud_format(name), CloudFormat::kXyz);
  for (const char* name : {"c.obj", "c", "ply", "c.ply.gz"})
    EXPECT_EQ(cloud_format(name), std::nullopt);
}

// ---- line ends ----

TEST_F(IoTest, XyzWithClassicMacLineEnds) {
  const PointCloud cloud =
      read_point_cloud(write_file("mac.csv", "x,y,z\r# comment\r1.5,-2,3e2\r\r4;5;6\r7 8 9"));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1.5, -2, 300}, {4, 5, 6}, {7, 8, 9}}));
  // Line numbers count '\r' line ends.
  try {
    read_point_cloud(write_file("mac.xyz", "1 2 3\r4 5 6\r7 x 9\r"));
    ADD_FAILURE() << "no error";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("line 3: bad number 'x'"), std::string::npos) << e.what();
  }
}

TEST_F(IoTest, PlyAndPcdAsciiWithClassicMacLineEnds) {
  std::string ply = std::string("ply\nformat ascii 1.0\n") + kPlyHeaderTail +
                    "3 0 1 2 7\n4 0 1 2 0 9\n"
                    "0.1 1 -2.5 2 -7 3\n1000 4 0.03125 5 32767 6\n-0 7 100 8 -32768 9\n"
                    "2 0 1 0.5\n";
  std::replace(ply.begin(), ply.end(), '\n', '\r');
  EXPECT_EQ(read_point_cloud(write_file("mac.ply", ply)).positions, kHandPoints);
  std::string pcd = pcd_header(kPcdFields, 2, "ascii");
  for (const auto& point : kPcdValues) {
    for (std::size_t i = 0; i < point.size(); ++i) {
      if (i > 0) pcd += ' ';
      pcd += format_double(point[i]);
    }
    pcd += "\n";
  }
  std::replace(pcd.begin(), pcd.end(), '\n', '\r');
  expect_hand_pcd(read_point_cloud(write_file("mac.pcd", pcd)));
}

// With '\r' line ends, the binary body starts right after the DATA line's '\r', even when its first
// byte is '\n' (0x0A), which a "\r\n" would have swallowed.
TEST_F(IoTest, BinaryBodyAfterAClassicMacHeaderStartsAtItsFirstByte) {
  Bytes b;
  b.text("FIELDS x y z\rSIZE 1 1 1\rTYPE U U U\rWIDTH 2\rDATA binary\r");
  b.put<std::uint8_t>('\n').put<std::uint8_t>(2).put<std::uint8_t>(3);
  b.put<std::uint8_t>(4).put<std::uint8_t>(5).put<std::uint8_t>('\n');
  const PointCloud cloud = read_point_cloud(write_file("mac_binary.pcd", b.str()));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{10, 2, 3}, {4, 5, 10}}));
  Bytes p;
  p.text(
      "ply\rformat binary_little_endian 1.0\relement vertex 1\rproperty uchar x\r"
      "property uchar y\rproperty uchar z\rend_header\r");
  p.put<std::uint8_t>('\n').put<std::uint8_t>('\r').put<std::uint8_t>('\n');
  EXPECT_EQ(read_point_cloud(write_file("mac_binary.ply", p.str())).positions,
            (std::vector<Eigen::Vector3d>{{10, 13, 10}}));
}

// ---- text ----

TEST_F(IoTest, CsvWithHeaderAndExtraColumns) {
  const PointCloud cloud = read_point_cloud(write_file(
      "scan.csv", "# exported\n\"x\",\"y\",\"z\",\"intensity\"\n1.5,-2,3e2,17\n  4;5;6;0.5;red\n"));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1.5, -2, 300}, {4, 5, 6}}));
}

TEST_F(IoTest, XyzSkipsCommentsAndBlankLinesAndAcceptsAnySeparator) {
  const PointCloud cloud = read_point_cloud(write_file(
      "scan.XYZ", "\n  # comment\n1\t2\t3\r\n\r\n+4 -5 .5 # trailing words ignored\n7, 8, 9\n"));
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1, 2, 3}, {4, -5, 0.5}, {7, 8, 9}}));
}

TEST_F(IoTest, XyzNonFiniteRowsAreDroppedAndCounted) {
  ReadInfo info;
  const PointCloud cloud = read_point_cloud(
      write_file("nan.txt", "1 2 3\nnan 0 0\n0 -inf 0\n0 0 1e999\n4 5 6\n"), &info);
  EXPECT_EQ(cloud.positions, (std::vector<Eigen::Vector3d>{{1, 2, 3}, {4, 5, 6}}));
  EXPECT_EQ(info.dropped_non_finite, 3u);
}

// ---- malformed input ----

struct Hostile {
  std::string name;
  std::string file_name;
  std::optional<std::string> bytes;  // nullopt: the file does not exist
  std::string phrase;                // expected in the message
};

void PrintTo(const Hostile& input, std::ostream* os) { *os << input.name; }

std::string ply_ascii_header(const std::string& vertex_count) {
  return "ply\nformat ascii 1.0\nelement vertex " + vertex_count +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

std::string ply_binary_header(const std::string& vertex_count) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + vertex_count +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

const char* const kPcdXyzHeader =
    "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA binary_compressed\n";

std::string compressed_pcd(std::uint32_t compressed, std::uint32_t uncompressed,
                           const std::string& stream) {
  Bytes b;
  b.text(kPcdXyzHeader).put(compressed).put(uncompressed).text(stream);
  return b.str();
}

std::vector<Hostile> hostile_inputs() {
  const std::string one_point = lzf_literals(Bytes().put(1.f).put(2.f).put(3.f).str());
  std::vector<Hostile> cases = {
      {"MissingFile", "missing.ply", std::nullopt, "file not found"},
      {"UnknownExtension", "cloud.obj", "v 1 2 3\n", "unknown point cloud format '.obj'"},
      {"NoExtension", "cloud", "1 2 3\n", "unknown point cloud format"},
      {"EmptyPly", "empty.ply", "", "file is empty"},
      {"EmptyXyz", "empty.xyz", "", "file is empty"},
      {"PlyNoMagic", "a.ply", "PLY?\nformat ascii 1.0\n", "not a PLY file"},
      {"PlyNoEndHeader", "a.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n",
       "without an end_header"},
      {"PlyDataWithoutEndHeader", "a.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "property float z\n1 2 3\n",
       "line 7: unknown header keyword '1' (missing end_header?)"},
      {"PlyHeaderLongerThan1MiB", "a.ply",
       "ply\nformat ascii 1.0\n" + std::string(1 << 20, 'c') + "\nend_header\n",
       "longer than 1 MiB"},
      {"PlyUnknownFormat", "a.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n",
       "unknown PLY format 'binary_middle_endian'"},
      {"PlyNoFormatLine", "a.ply", "ply\nelement vertex 0\nend_header\n", "no format line"},
      {"PlyBinaryVertexCount1e12", "a.ply",
       Bytes().text(ply_binary_header("1000000000000")).put(1.f).put(2.f).put(3.f).str(),
       "announces 1000000000000 records of 12 bytes at byte offset 127, but only 12 bytes remain"},
      {"PlyAsciiVertexCount1e12", "a.ply", ply_ascii_header("1000000000000") + "1 2 3\n",
       "can hold at most 1"},
      {"PlyVertexCountOverflowsU64", "a.ply", ply_ascii_header("99999999999999999999999"),
       "bad element count"},
      {"PlyBinaryTruncated", "a.ply",
       Bytes().text(ply_binary_header("3")).put(1.f).put(2.f).put(3.f).put(4.f).str(),
       "only 16 bytes remain (truncated file?)"},
      {"PlyAsciiTruncated", "a.ply", ply_ascii_header("3") + "1.25 2.25 3.25\n4.25 5.25 6.25\n",
       "truncated data: element 'vertex' announces 3 records, the file ends after 2"},
      {"PlyMissingZ", "a.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
       "end_header\n1 2\n",
       "element 'vertex' has no property 'z'"},
      {"PlyBadPropertyType", "a.ply",
       "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
       "line 4: unknown property type 'float128'"},
      {"PlyFloatListCount", "a.ply",
       "ply\nformat ascii 1.0\nelement face 1\nproperty list float int idx\nend_header\n",
       "list count type must be an integer type"},
      {"PlyListWithAbsurdCount", "a.ply",
       Bytes()
           .text("ply\nformat binary_little_endian 1.0\nelement face 1\n"
                 "property list uint int idx\n")
           .text(ply_binary_header("1").substr(36))
           .put(std::uint32_t{0xFFFFFFF0})
           .put(1.f)
           .put(2.f)
           .put(3.f)
           .str(),
       "list count 4294967280 at byte offset"},
      {"PlyNegativeListCount", "a.ply",
       Bytes()
           .text("ply\nformat binary_big_endian 1.0\nelement face 1\nproperty list int int idx\n")
           .text(ply_binary_header("0").substr(36))
           .put(std::int32_t{-1})
           .str(),
       "negative list count"},
      {"PlyAsciiBadNumber", "a.ply", ply_ascii_header("2") + "1 2 3\n1 2 abc\n",
       "line 9: bad number 'abc' for property 'z'"},
      {"PlyAsciiTooFewValues", "a.ply", ply_ascii_header("2") + "1.25 2.25 3.25\n1.25 2.25\n",
       "line 9: too few values"},
      {"PlyAsciiTooManyValues", "a.ply", ply_ascii_header("1") + "1 2 3 4\n",
       "line 8: too many values"},
      {"PlyNoVertexElement", "a.ply",
       "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int idx\nend_header\n",
       "no vertex element"},
      {"PlyZeroVertices", "a.ply", ply_ascii_header("0"), "contains no points"},
      {"PcdMissingData", "a.pcd",
       "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\n",
       "header ends without a DATA line"},
      {"PcdUnknownKeyword", "a.pcd", "hello\n", "unknown header keyword 'hello'"},
      {"PcdFieldsSizeMismatch", "a.pcd",
       "FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       "SIZE has 2 entries but FIELDS has 3"},
      {"PcdBadType", "a.pcd", "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       "unsupported TYPE 'F' with SIZE 2 for field 'z'"},
      {"PcdMissingZ", "a.pcd",
       "FIELDS x y intensity\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 3\n",
       "no field 'z'"},
      {"PcdPointsNotWidthTimesHeight", "a.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nHEIGHT 2\nPOINTS 5\nDATA ascii\n1 2 3\n",
       "POINTS 5 does not equal WIDTH * HEIGHT = 3 * 2"},
      {"PcdViewpointOfSixNumbers", "a.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nVIEWPOINT 0 0 0 1 0 0\nDATA ascii\n1 2 3\n",
       "line 5: expected 'VIEWPOINT tx ty tz qw qx qy qz'"},
      {"PcdViewpointNaN", "a.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nVIEWPOINT nan 0 0 1 0 0 0\nWIDTH 1\nDATA ascii\n1 2 "
       "3\n",
       "line 4: expected 'VIEWPOINT"},
      {"PcdViewpointZeroQuaternion", "a.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nVIEWPOINT 0 0 0 0 0 0 0\nWIDTH 1\nDATA ascii\n1 2 "
       "3\n",
       "a non-zero quaternion"},
      {"PcdUnknownData", "a.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA zip\n",
       "unknown DATA encoding 'zip'"},
      {"PcdAsciiTooFewValues", "a.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nDATA ascii\n1.25 2.25 3.25\n4.25 5.25\n",
       "line 7: too few values"},
      {"PcdBinaryTruncated", "a.pcd",
       Bytes()
           .text("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nDATA binary\n")
           .put(1.f)
           .put(2.f)
           .put(3.f)
           .put(4.f)
           .put(5.f)
           .put(6.f)
           .str(),
       "announces 3 points of 12 bytes at byte offset 55, but only 24 bytes remain"},
      {"PcdCompressedLyingCompressedSize", "a.pcd", compressed_pcd(1000, 12, one_point),
       "compressed size 1000 at byte offset"},
      {"PcdCompressedLyingUncompressedSize", "a.pcd",
       compressed_pcd(static_cast<std::uint32_t>(one_point.size()), 24, one_point),
       "uncompressed size 24 at byte offset 132 does not match POINTS * point size = 1 * 12"},
      {"PcdCompressedImpossibleExpansion", "a.pcd",
       Bytes()
           .text("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 100000000\n"
                 "DATA binary_compressed\n")
           .put(std::uint32_t{2})
           .put(std::uint32_t{1200000000})
           .text(std::string("\x1f\x00", 2))
           .str(),
       "is impossible for 2 bytes of LZF data"},
      // A back-reference before the start of the output.
      {"PcdCompressedCorruptStream", "a.pcd", compressed_pcd(2, 12, std::string("\x20\x00", 2)),
       "is corrupt"},
      // A literal run longer than the stream.
      {"PcdCompressedTruncatedStream", "a.pcd", compressed_pcd(5, 12, one_point.substr(0, 5)),
       "is corrupt"},
      {"PcdCompressedShortSizeHeader", "a.pcd", std::string(kPcdXyzHeader) + "abc",
       "shorter than its 8-byte size header"},
      {"XyzTwoColumnRow", "a.xyz", "1 2 3\n4 5\n", "line 2: expected at least 3 numbers, found 2"},
      {"XyzGarbage", "a.xyz", "1 2 3\nhello world foo\n", "line 2: bad number 'hello'"},
      {"XyzBadThirdNumber", "a.txt", "1 2 3x\n", "line 1: bad number '3x'"},
      {"CsvSecondHeader", "a.csv", "x,y,z\nx,y,z\n1,2,3\n", "line 2: bad number 'x'"},
      {"XyzEndlessLine", "a.xyz", std::string(1 << 20, '1'), "line 1 is longer than 65536 bytes"},
      {"XyzOnlyComments", "a.xyz", "# nothing\n\n", "contains no points"},
      {"XyzOnlyNaNPoints", "a.xyz", "nan nan nan\n1 nan 2\n",
       "contains no points (all 2 had a NaN or Inf coordinate)"},
      {"PcdOnlyNaNPoints", "a.pcd",
       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\nnan nan nan\n",
       "contains no points (all 1 had"},
  };
  return cases;
}

class IoHostileInputTest : public IoTest, public ::testing::WithParamInterface<Hostile> {};

TEST_P(IoHostileInputTest, IsAnIoErrorNamingTheFileAndTheProblem) {
  const Hostile& input = GetParam();
  const fs::path path =
      input.bytes ? write_file(input.file_name, *input.bytes) : dir_ / input.file_name;
  EXPECT_THROW(read_point_cloud(path), IoError);
  try {
    read_point_cloud(path);
  } catch (const IoError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(input.phrase), std::string::npos) << message;
    EXPECT_EQ(e.code(), ExitCode::kInput);
  }
}

INSTANTIATE_TEST_SUITE_P(Catalogue, IoHostileInputTest, ::testing::ValuesIn(hostile_inputs()),
                         [](const auto& info) { return info.param.name; });

TEST_F(IoTest, AFolderIsNotAPointCloud) {
  fs::create_directory(dir_ / "folder.ply");
  try {
    read_point_cloud(dir_ / "folder.ply");
    ADD_FAILURE() << "no error";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
}

// ---- memory ----

// This process's peak resident size (VmHWM) in kB since `reset` last restarted it from the
// current size (Linux: writing 5 to /proc/self/clear_refs); nullopt where that is unavailable.
std::optional<long> peak_rss_kb(bool reset) {
  if (reset) {
    std::ofstream clear("/proc/self/clear_refs");
    if (!(clear << "5" << std::flush)) return std::nullopt;
  }
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return std::nullopt;
}

// Reading streams the file through a fixed buffer: a 4-million-point binary PLY (48 MB) costs the
// cloud (24 bytes a point, 96 MB), not the file on top of it. The bound, half the file, leaves
// room for the 4 MiB buffer; the whole file held while parsing would exceed it.
TEST_F(IoTest, ReadingDoesNotHoldTheFile) {
  if (test::kSanitized) GTEST_SKIP() << "resident memory means little under a sanitizer";
  constexpr std::size_t kPoints = 4000000;
  {
    std::ofstream out(dir_ / "big.ply", std::ios::binary);
    out << ply_binary_header(std::to_string(kPoints));
    const std::string block(12 * 1000, '\0');
    for (std::size_t i = 0; i < kPoints / 1000; ++i) out << block;
  }
  const auto before = peak_rss_kb(true);
  if (!before) GTEST_SKIP() << "no /proc/self/clear_refs";
  const PointCloud cloud = read_point_cloud(dir_ / "big.ply");
  ASSERT_EQ(cloud.size(), kPoints);
  const double grown_mb = static_cast<double>(*peak_rss_kb(false) - *before) * 1024 / 1e6;
  const double cloud_mb = kPoints * 24 / 1e6, file_mb = kPoints * 12 / 1e6;
  EXPECT_GT(grown_mb, 0.9 * cloud_mb) << "the cloud itself must be resident";
  EXPECT_LT(grown_mb, cloud_mb + file_mb / 2);
}

// ---- matrices ----

Eigen::Isometry3d random_rigid(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gaussian;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(gaussian(rng), gaussian(rng), gaussian(rng), gaussian(rng))
                   .normalized()
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(gaussian(rng), gaussian(rng), gaussian(rng)) * 100.0;
  return T;
}

TEST_F(IoTest, MatrixRoundTrip) {
  const Eigen::Isometry3d T = random_rigid(7);
  write_matrix(dir_ / "T.txt", T);
  const Eigen::Isometry3d read = read_matrix(dir_ / "T.txt");
  // %.17g is exact; only the re-orthonormalisation may move the last bit.
  EXPECT_LT((read.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(read.translation(), T.translation());
}

TEST_F(IoTest, MatrixWithCommentsCommasAndBlankLines) {
  const Eigen::Isometry3d T = read_matrix(write_file(
      "T.txt", "# target <- source\n\n0, -1, 0, 1.5\n1, 0, 0, -2  # row 2\n0 0 1 3\n0 0 0 1\n"));
  Eigen::Matrix4d expected;
  expected << 0, -1, 0, 1.5, 1, 0, 0, -2, 0, 0, 1, 3, 0, 0, 0, 1;
  EXPECT_EQ(T.matrix(), expected);
}

TEST_F(IoTest, MatrixIsReorthonormalised) {
  Eigen::Isometry3d T = random_rigid(3);
  Eigen::Isometry3d noisy = T;
  noisy.linear()(0, 1) += 3e-7;  // within the 1e-6 tolerance
  write_matrix(dir_ / "T.txt", noisy);
  const Eigen::Matrix3d R = read_matrix(dir_ / "T.txt").linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
  EXPECT_LT((R - T.linear()).norm(), 1e-6);
}

struct HostileMatrix {
  std::string name;
  std::optional<std::string> text;
  std::string phrase;
};

void PrintTo(const HostileMatrix& input, std::ostream* os) { *os << input.name; }

class IoHostileMatrixTest : public IoTest, public ::testing::WithParamInterface<HostileMatrix> {};

TEST_P(IoHostileMatrixTest, IsAnIoErrorNamingTheFileAndTheLine) {
  const HostileMatrix& input = GetParam();
  const fs::path path = input.text ? write_file("T.txt", *input.text) : dir_ / "missing.txt";
  EXPECT_THROW(read_matrix(path), IoError);
  try {
    read_matrix(path);
  } catch (const IoError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind(path.string() + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(input.phrase), std::string::npos) << message;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Catalogue, IoHostileMatrixTest,
    ::testing::Values(
        HostileMatrix{"Missing", std::nullopt, "file not found"},
        HostileMatrix{"Empty", "", "file is empty"},
        HostileMatrix{"ThreeRows", "1 0 0 0\n0 1 0 0\n0 0 1 0\n", "expected 4 rows, found 3"},
        HostileMatrix{"FiveRows", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n0 0 0 1\n",
                      "line 5: more than 4 rows"},
        HostileMatrix{"RowOfThree", "1 0 0 0\n0 1 0\n0 0 1 0\n0 0 0 1\n",
                      "line 2: expected 4 numbers, found 3"},
        HostileMatrix{"RowOfFive", "1 0 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
                      "line 1: expected 4 numbers, found 5"},
        HostileMatrix{"Garbage", "1 0 0 0\n0 1 0 0\n0 0 one 0\n0 0 0 1\n",
                      "line 3: bad number 'one'"},
        HostileMatrix{"NaN", "1 0 0 0\n0 1 0 nan\n0 0 1 0\n0 0 0 1\n",
                      "line 2: non-finite value 'nan'"},
        HostileMatrix{"Inf", "1 0 0 0\n0 1 0 0\n0 0 1 -inf\n0 0 0 1\n", "line 3: non-finite"},
        HostileMatrix{"LastRowNotAffine", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1e-3 1\n",
                      "line 4: last row must be 0 0 0 1"},
        HostileMatrix{"Scaled", "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n",
                      "lines 1-3: rotation is not orthonormal"},
        HostileMatrix{"Sheared", "1 1e-3 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "not orthonormal"},
        HostileMatrix{"Reflection", "# mirror\n-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
                      "lines 2-4: rotation has determinant -1 (a reflection"}),
    [](const auto& info) { return info.param.name; });

// ---- the fuzzers' seed corpus (fuzz/corpus) ----

// The seeds are meant to be valid files of every encoding, so that fuzzing starts from deep inside
// the parsers; one that stopped parsing would quietly weaken scripts/fuzz.sh.
TEST(FuzzSeedCorpus, EverySeedReads) {
  const fs::path corpus(ALIGN3D_FUZZ_CORPUS_DIR);
  std::size_t seeds = 0;
  for (const char* format : {"ply", "pcd", "xyz"}) {
    for (const auto& entry : fs::directory_iterator(corpus / format)) {
      ReadInfo info;
      EXPECT_NO_THROW(EXPECT_GE(read_point_cloud(entry.path(), &info).size(), 2u)) << entry.path();
      ++seeds;
    }
  }
  for (const auto& entry : fs::directory_iterator(corpus / "matrix")) {
    EXPECT_NO_THROW(read_matrix(entry.path())) << entry.path();
    ++seeds;
  }
  EXPECT_GE(seeds, 16u);
}

}  // namespace
}  // namespace align3d::io

namespace align3d {
namespace {

// A destination that is a FIFO (like /dev/null or /dev/stdout, no regular file) is written in
// place: renaming the temporary over it would replace it (as root, /dev/null itself).
TEST(AtomicFile, WritesDevicesAndFifosInPlace) {
  test::TempDir d("fifo");
  const std::filesystem::path fifo = d / "pipe";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  // A reader that does not block: the write below finds it, and the text waits in the pipe.
  const int reader = open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  io::write_text_atomically(fifo, "through the pipe\n");
  char buffer[64] = {};
  const ssize_t got = read(reader, buffer, sizeof buffer);
  close(reader);
  const std::string received(buffer, got > 0 ? static_cast<std::size_t>(got) : 0);
  EXPECT_EQ(received, "through the pipe\n");
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(d.path()), {}), 1);  // no leftovers
}

}  // namespace
}  // namespace align3d
