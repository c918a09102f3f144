// Plain-text point lists (.xyz, .txt, .csv): one point per row, x y z being its first three
// numbers.
#include <algorithm>
#include <string>

#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace {

// No point row is anywhere near this long; a longer line means a binary file or a missing newline,
// and refusing it keeps errors readable.
constexpr std::size_t kMaxXyzLineBytes = std::size_t{64} << 10;

// Runs of separators count as one, so "1, 2, 3" and "1\t2\t3" read alike (an empty CSV field
// therefore does not shift the columns; such files are rare for point lists).
constexpr auto is_xyz_separator = [](char c) {
  return detail::is_space(c) || c == ',' || c == ';';
};

using detail::BlockReader;

// The number of rows, counted before parsing so that the points are allocated once: a growing
// vector holds its old and its new copy at once when it doubles, up to twice the final points. A
// second read of the file costs far less than parsing it. "\r\n" counts once, as does '\r' alone
// (classic Mac OS line ends).
std::uint64_t count_rows(BlockReader& in) {
  std::uint64_t lf = 0, cr = 0;
  for (std::string_view data = in.peek(1); !data.empty(); data = in.peek(1)) {
    lf += static_cast<std::uint64_t>(std::count(data.begin(), data.end(), '\n'));
    cr += static_cast<std::uint64_t>(std::count(data.begin(), data.end(), '\r'));
    in.consume(data.size());
  }
  in.rewind();
  return std::max(lf, cr) + 1;
}

}  // namespace

namespace detail {

PointCloud read_xyz(BlockReader& in, ReadInfo& info) {
  const std::filesystem::path& path = in.path();
  CloudBuilder builder(path, false);
  // A point row takes at least 6 bytes ("0 0 0\n"), which bounds the reservation for files of blank
  // or comment lines.
  builder.reserve(static_cast<std::size_t>(std::min(count_rows(in), in.remaining() / 6 + 1)));

  LineReader lines(in);
  std::string_view line;
  bool seen_row = false;
  while (lines.next(line, kMaxXyzLineBytes)) {
    check_line_length(path, line, lines.number(), kMaxXyzLineBytes);
    const auto first = line.find_first_not_of(" \t\r\v\f");
    if (first == std::string_view::npos || line[first] == '#') continue;
    std::array<double, 3> xyz{};
    std::size_t pos = 0;
    std::size_t found = 0;
    bool header = false;
    for (; found < 3; ++found) {
      const auto token = next_number(line, pos, is_xyz_separator, xyz[found]);
      if (token == Token::kEnd) break;
      if (token == Token::kNumber) continue;
      // Column names ("x,y,z") are common in CSV exports; elsewhere a word is an error.
      if (!seen_row && found == 0) {
        header = true;
        break;
      }
      fail(path, "line " + std::to_string(lines.number()) + ": bad number " +
                     quoted(next_token(line, pos, is_xyz_separator)));
    }
    seen_row = true;
    if (header) continue;
    if (found < 3) {
      fail(path, "line " + std::to_string(lines.number()) +
                     ": expected at least 3 numbers, found " + std::to_string(found));
    }
    builder.add(xyz[0], xyz[1], xyz[2]);
  }
  PointCloud cloud = builder.finish();
  info.width = cloud.size() + builder.dropped();
  info.height = 1;
  info.dropped_non_finite = builder.dropped();
  return cloud;
}

}  // namespace detail

void write_xyz(const std::filesystem::path& path, const PointCloud& cloud) {
  write_atomically(path, [&](std::ostream& out) {
    detail::ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    for (const auto& p : cloud.positions) {
      for (int k = 0; k < 3; ++k) {
        detail::append_general(buffer, p[k], 9);
        buffer += k < 2 ? ' ' : '\n';
      }
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace align3d::io
