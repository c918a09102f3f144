// The streaming input of the readers (src/io/block_reader.hpp, lzf_stream.hpp). Oracles: clouds of
// exactly representable coordinates, which every reader must return whatever the read sizes and the
// buffer's capacity (so block boundaries fall inside every line, record and LZF step); line
// splitting against hand-written expectations; and the streaming LZF decoder against liblzf's own
// lzf_compress / lzf_decompress, on valid and on corrupted streams.
#include <gtest/gtest.h>
#include <lzf.h>

#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io/block_reader.hpp"
#include "io/io_detail.hpp"
#include "io/lzf_stream.hpp"
#include "test_util.hpp"

namespace align3d::io {
namespace {

namespace fs = std::filesystem;
using detail::BlockReader;
using detail::LineReader;
using detail::MemorySource;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// ---- lines ----

std::vector<std::string> lines_of(const std::string& text, std::size_t max_read,
                                  std::size_t limit = 100) {
  MemorySource source(text, max_read);
  BlockReader in("t.txt", source, 64);
  LineReader lines(in);
  std::vector<std::string> out;
  std::string_view line;
  while (lines.next(line, limit)) {
    out.emplace_back(line);
    EXPECT_EQ(lines.number(), out.size());
  }
  return out;
}

TEST(LineReader, TheFirstLineEndDecidesTheTerminator) {
  using Lines = std::vector<std::string>;
  for (const std::size_t max_read : {1u, 2u, 3u, 5u, 64u}) {
    SCOPED_TRACE(max_read);
    EXPECT_EQ(lines_of("a b\nc\n\nd", max_read), (Lines{"a b", "c", "", "d"}));
    EXPECT_EQ(lines_of("a b\r\nc\r\n\r\nd\r\n", max_read), (Lines{"a b", "c", "", "d"}));
    EXPECT_EQ(lines_of("a b\rc\r\rd\r", max_read), (Lines{"a b", "c", "", "d"}));
    // After '\r' line ends, a '\n' that follows one belongs to it (mixed files).
    EXPECT_EQ(lines_of("a\rb\r\nc\r", max_read), (Lines{"a", "b", "c"}));
    // After '\n' line ends, a lone '\r' is not a line end (it is whitespace to the parsers).
    EXPECT_EQ(lines_of("a\nb\rc\n", max_read), (Lines{"a", "b\rc"}));
    EXPECT_EQ(lines_of("x\r", max_read), (Lines{"x"}));
    EXPECT_EQ(lines_of("\n\n", max_read), (Lines{"", ""}));
  }
}

TEST(LineReader, ALineLongerThanTheLimitComesBackCutToLimitPlusOne) {
  const auto lines = lines_of("12345\n" + std::string(30, 'x') + "\nab\n", 7, 10);
  ASSERT_GE(lines.size(), 2u);
  EXPECT_EQ(lines[0], "12345");
  EXPECT_EQ(lines[1], std::string(11, 'x'));
}

TEST(BlockReader, OffsetsPeekAndSkipAcrossReads) {
  std::string data;
  for (int i = 0; i < 1000; ++i) data += static_cast<char>(i % 251);
  MemorySource source(data, 3);
  BlockReader in("b.bin", source, 16);
  EXPECT_EQ(in.remaining(), 1000u);
  EXPECT_EQ(in.peek(10).substr(0, 10), data.substr(0, 10));
  in.consume(4);
  EXPECT_EQ(in.skip(500), 500u);
  EXPECT_EQ(in.offset(), 504u);
  EXPECT_EQ(in.peek(16).substr(0, 16), data.substr(504, 16));
  EXPECT_EQ(in.skip(1000), 496u);  // only 496 left
  EXPECT_TRUE(in.peek(1).empty());
  in.rewind();
  EXPECT_EQ(in.offset(), 0u);
  EXPECT_EQ(in.peek(5).substr(0, 5), data.substr(0, 5));
}

// ---- every reader at every block boundary ----

// 150 points whose coordinates and normals float32 and short text hold exactly.
PointCloud exact_cloud(bool normals) {
  PointCloud cloud;
  for (int i = 0; i < 150; ++i) {
    cloud.positions.emplace_back(0.5 * i, -0.25 * i, 1000.0 - i);
    if (normals) {
      cloud.normals.push_back(i % 2 == 0 ? Eigen::Vector3d(0.6, 0.8, 0.0)
                                         : Eigen::Vector3d(0.0, 0.0, -1.0));
    }
  }
  return cloud;
}

void expect_cloud(const PointCloud& read, const PointCloud& expected) {
  ASSERT_EQ(read.size(), expected.size());
  EXPECT_EQ(read.positions, expected.positions);
  ASSERT_EQ(read.has_normals(), expected.has_normals());
  for (std::size_t i = 0; i < read.normals.size(); ++i) {
    // 0.6 and 0.8 are not floats: allow their rounding, renormalised.
    EXPECT_LT((read.normals[i] - expected.normals[i]).norm(), 1e-7) << i;
  }
}

class ReaderAtAnyBoundary : public ::testing::TestWithParam<std::string> {};

TEST_P(ReaderAtAnyBoundary, ReadsTheSamePoints) {
  test::TempDir dir("stream");
  const std::string name = GetParam();
  const bool normals = name.find("normals") != std::string::npos;
  const PointCloud cloud = exact_cloud(normals);
  const fs::path path = dir / name;
  const std::string ext = path.extension().string();
  if (name.rfind("ply_ascii", 0) == 0) write_ply(path, cloud, PlyEncoding::kAscii);
  if (name.rfind("ply_le", 0) == 0) write_ply(path, cloud, PlyEncoding::kBinaryLittleEndian);
  if (name.rfind("ply_be", 0) == 0) write_ply(path, cloud, PlyEncoding::kBinaryBigEndian);
  if (name.rfind("pcd_ascii", 0) == 0) write_pcd(path, cloud, PcdEncoding::kAscii);
  if (name.rfind("pcd_binary", 0) == 0) write_pcd(path, cloud, PcdEncoding::kBinary);
  if (name.rfind("pcd_compressed", 0) == 0) write_pcd(path, cloud, PcdEncoding::kBinaryCompressed);
  if (ext == ".xyz") write_xyz(path, cloud);
  std::string bytes = read_bytes(path);
  // The same text with '\r\n' or '\r' line ends: the whole of a text file, the header of a binary
  // one.
  if (name.find("crlf") != std::string::npos || name.find("_cr.") != std::string::npos) {
    const std::string end = name.find("crlf") != std::string::npos ? "\r\n" : "\r";
    const std::size_t data = std::min(bytes.find("DATA binary"), bytes.find("format binary"));
    const std::size_t text_end = data == std::string::npos ? bytes.size()
                                 : ext == ".pcd"           ? bytes.find('\n', data) + 1
                                                           : bytes.find("end_header\n") + 11;
    std::string converted;
    for (std::size_t i = 0; i < text_end; ++i) {
      converted += bytes[i] == '\n' ? end : std::string(1, bytes[i]);
    }
    bytes = converted + bytes.substr(text_end);
  }
  const auto reader = ext == ".ply"   ? &detail::read_ply
                      : ext == ".pcd" ? &detail::read_pcd
                                      : &detail::read_xyz;
  for (const std::size_t capacity : {std::size_t{256}, detail::kBlockBytes}) {
    for (const std::size_t max_read : {1u, 2u, 7u, 33u, 1000u, 1u << 20}) {
      SCOPED_TRACE(std::to_string(capacity) + " bytes of buffer, reads of " +
                   std::to_string(max_read));
      MemorySource source(bytes, max_read);
      BlockReader in(path, source, capacity);
      ReadInfo info;
      expect_cloud(reader(in, info), cloud);
      EXPECT_EQ(info.width, cloud.size());
      EXPECT_EQ(info.height, 1u);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Files, ReaderAtAnyBoundary,
                         ::testing::Values("ply_ascii.ply", "ply_ascii_normals_crlf.ply",
                                           "ply_ascii_normals_cr.ply", "ply_le_normals.ply",
                                           "ply_be.ply", "pcd_ascii_normals.pcd",
                                           "pcd_ascii_cr.pcd", "pcd_binary_normals_cr.pcd",
                                           "pcd_binary.pcd", "pcd_compressed_normals.pcd",
                                           "pcd_compressed.pcd", "points.xyz", "points_crlf.xyz",
                                           "points_cr.xyz"),
                         [](const auto& info) {
                           std::string name = info.param;
                           for (char& c : name)
                             c = std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
                           return name;
                         });

// A PCD record larger than the buffer (a field with a large COUNT) is walked field by field; the
// values are chosen so that a misplaced offset reads a different number.
TEST(PcdRecordLargerThanTheBuffer, IsReadFieldByField) {
  constexpr int kCount = 100;  // 400 bytes of "hist" per point, against a 256-byte buffer
  std::string text = "FIELDS hist z x y\nSIZE 4 8 4 2\nTYPE F F F I\nCOUNT " +
                     std::to_string(kCount) + " 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary\n";
  const auto put = [&](auto value) {
    text.append(reinterpret_cast<const char*>(&value), sizeof(value));
  };
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < kCount; ++k) put(static_cast<float>(-1000 - k));
    put(static_cast<double>(10 * i) + 0.125);
    put(static_cast<float>(i));
    put(static_cast<std::int16_t>(-7 * i));
  }
  for (const std::size_t max_read : {1u, 5u, 100000u}) {
    MemorySource source(text, max_read);
    BlockReader in("big.pcd", source, 256);
    ReadInfo info;
    const PointCloud cloud = detail::read_pcd(in, info);
    EXPECT_EQ(cloud.positions,
              (std::vector<Eigen::Vector3d>{{0, 0, 0.125}, {1, -7, 10.125}, {2, -14, 20.125}}));
  }
  // Cut inside the last record's walk: truncated, with the byte offset.
  MemorySource source(std::string_view(text).substr(0, text.size() - 5), 64);
  BlockReader in("big.pcd", source, 256);
  ReadInfo info;
  EXPECT_THROW(detail::read_pcd(in, info), IoError);
}

// ---- LZF ----

// Text-like data with repeats near and far (up to the 8 KiB window and beyond), and noise.
std::string lzf_sample(std::size_t size, unsigned seed) {
  std::mt19937 rng(seed);
  std::string data;
  while (data.size() < size) {
    const unsigned kind = rng() % 3;
    if (kind == 0 || data.size() < 16) {
      for (int i = 0; i < 20; ++i) data += static_cast<char>(rng());
    } else {
      const std::size_t distance = 1 + rng() % std::min<std::size_t>(data.size(), 10000);
      const std::size_t length = 1 + rng() % 300;
      for (std::size_t i = 0; i < length; ++i) data += data[data.size() - distance];
    }
  }
  data.resize(size);
  return data;
}

std::string lzf_compressed(const std::string& raw) {
  std::string packed(raw.size() + raw.size() / 16 + 64, '\0');
  const unsigned n = lzf_compress(raw.data(), static_cast<unsigned>(raw.size()), packed.data(),
                                  static_cast<unsigned>(packed.size()));
  packed.resize(n);
  return packed;
}

// Decodes `packed` through a BlockReader; the sink leaves a varying partial tail (up to 7 bytes)
// for the next call, as the PCD reader may, and checks that it is offered again.
detail::LzfResult stream_decode(const std::string& packed, std::uint64_t uncompressed,
                                std::size_t max_read, std::string& out) {
  MemorySource source(packed, max_read);
  BlockReader in("c.pcd", source, 4096);
  out.clear();
  return detail::lzf_decompress_stream(
      in, packed.size(), uncompressed,
      [&](const char* data, std::size_t size, std::uint64_t offset) -> std::size_t {
        EXPECT_EQ(offset, out.size());
        const bool last = offset + size == uncompressed;
        const std::size_t leave = last ? 0 : std::min<std::size_t>(size, (offset * 31 + size) % 8);
        out.append(data, size - leave);
        return size - leave;
      });
}

TEST(LzfStream, ExpandsWhatLiblzfCompressed) {
  for (const std::size_t size : {1u, 100u, 9000u, 600000u}) {
    const std::string raw = lzf_sample(size, static_cast<unsigned>(size));
    const std::string packed = lzf_compressed(raw);
    ASSERT_GT(packed.size(), 0u);
    for (const std::size_t max_read : {1u, 3u, 34u, 5000u}) {
      std::string out;
      const detail::LzfResult result = stream_decode(packed, raw.size(), max_read, out);
      EXPECT_TRUE(result.ok) << size << " bytes, reads of " << max_read;
      EXPECT_EQ(result.produced, raw.size());
      EXPECT_TRUE(out == raw) << size << " bytes, reads of " << max_read;
    }
  }
}

// Random corruptions of valid streams: the stream decoder accepts exactly what lzf_decompress
// expands to the announced size, with the same bytes.
TEST(LzfStream, AgreesWithLiblzfOnCorruptStreams) {
  std::mt19937 rng(7);
  std::size_t accepted = 0, refused = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const std::string raw = lzf_sample(200 + rng() % 3000, rng());
    std::string packed = lzf_compressed(raw);
    for (int flips = 1 + static_cast<int>(rng() % 3); flips > 0; --flips) {
      packed[rng() % packed.size()] = static_cast<char>(rng());
    }
    if (rng() % 4 == 0) packed.resize(1 + rng() % packed.size());  // truncated
    std::string expected(raw.size(), '\0');
    const unsigned n = lzf_decompress(packed.data(), static_cast<unsigned>(packed.size()),
                                      expected.data(), static_cast<unsigned>(expected.size()));
    std::string out;
    const detail::LzfResult result = stream_decode(packed, raw.size(), 1 + rng() % 50, out);
    ASSERT_EQ(result.ok, n == raw.size()) << "trial " << trial;
    if (result.ok) {
      EXPECT_TRUE(out == expected) << "trial " << trial;
      ++accepted;
    } else {
      ++refused;
    }
  }
  // Both kinds occurred (flipped literal bytes stay valid; most other flips do not).
  EXPECT_GT(accepted, 20u);
  EXPECT_GT(refused, 20u);
}

TEST(LzfStream, RefusesAReferenceBeforeTheStartAndOutputBeyondTheSize) {
  std::string out;
  EXPECT_FALSE(stream_decode(std::string("\x20\x00", 2), 12, 1, out).ok);
  const std::string packed = lzf_compressed(std::string(100, 'a'));
  EXPECT_FALSE(stream_decode(packed, 99, 7, out).ok);  // expands beyond the announced size
  const auto short_stream = stream_decode(packed, 101, 7, out);  // ends before it
  EXPECT_FALSE(short_stream.ok);
  EXPECT_EQ(short_stream.produced, 100u);
}

// ---- out of memory ----

TEST(CloudBuilder, RunningOutOfMemoryNamesTheFileAndTheAllocation) {
  // 10^17 points (2.4 EB) cannot be allocated anywhere: operator new throws std::bad_alloc (where
  // AddressSanitizer does not abort first).
  if (test::kSanitized) GTEST_SKIP() << "AddressSanitizer aborts on the allocation instead";
  detail::CloudBuilder builder("huge.ply", true);
  try {
    builder.reserve(std::size_t{100000000000000000});
    FAIL() << "no error";
  } catch (const DataError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("huge.ply: not enough memory for 100000000000000000 "
                                          "points (",
                                          0),
              0u)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("MiB with normals)"), std::string::npos) << e.what();
    EXPECT_EQ(e.code(), ExitCode::kData);
  }
}

}  // namespace
}  // namespace align3d::io
