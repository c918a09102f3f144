#include "align3d/io/matrix_io.hpp"

#include <Eigen/SVD>
#include <array>
#include <cmath>
#include <string>

#include "align3d/io/atomic_file.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace {

// A matrix file is a few hundred bytes; anything this large is the wrong file.
constexpr std::uint64_t kMaxMatrixFileBytes = std::uint64_t{1} << 20;
constexpr double kLastRowTolerance = 1e-9;
constexpr double kOrthonormalTolerance = 1e-6;

constexpr auto is_separator = [](char c) { return detail::is_space(c) || c == ','; };

std::string line_name(std::size_t line) { return "line " + std::to_string(line); }

}  // namespace

namespace detail {

Eigen::Isometry3d parse_matrix(BlockReader& in) {
  const std::filesystem::path& path = in.path();
  LineReader lines(in);
  Eigen::Matrix4d m;
  std::array<std::size_t, 4> row_line{};
  int rows = 0;
  std::string_view line;
  while (lines.next(line, kMaxMatrixFileBytes)) {
    detail::check_line_length(path, line, lines.number(), kMaxMatrixFileBytes);
    line = line.substr(0, line.find('#'));  // a comment runs to the end of the line
    const std::string where = line_name(lines.number()) + ": ";
    std::size_t pos = 0;
    std::array<double, 4> row{};
    std::size_t found = 0;
    for (auto token = detail::next_token(line, pos, is_separator); !token.empty();
         token = detail::next_token(line, pos, is_separator)) {
      double value = 0.0;
      if (!align3d::detail::parse_number(token, value)) {
        detail::fail(path, where + "bad number " + detail::quoted(token));
      }
      if (!std::isfinite(value)) {
        detail::fail(path, where + "non-finite value " + detail::quoted(token));
      }
      if (found < 4) row[found] = value;
      ++found;
    }
    if (found == 0) continue;
    if (found != 4) {
      detail::fail(path, where + "expected 4 numbers, found " + std::to_string(found));
    }
    if (rows == 4) detail::fail(path, where + "more than 4 rows");
    for (int c = 0; c < 4; ++c) m(rows, c) = row[static_cast<std::size_t>(c)];
    row_line[static_cast<std::size_t>(rows)] = lines.number();
    ++rows;
  }
  if (rows != 4) detail::fail(path, "expected 4 rows, found " + std::to_string(rows));

  bool last_row = false;
  const std::string problem = rigid_problem(m, &last_row);
  if (!problem.empty()) {
    detail::fail(path, (last_row ? line_name(row_line[3])
                                 : "lines " + std::to_string(row_line[0]) + "-" +
                                       std::to_string(row_line[2])) +
                           ": " + problem);
  }
  return to_rigid(m);
}

}  // namespace detail

std::string rigid_problem(const Eigen::Matrix4d& m, bool* last_row) {
  if (last_row != nullptr) *last_row = false;
  if (!m.allFinite()) return "non-finite entry (not a rigid transform)";
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > kLastRowTolerance) {
    if (last_row != nullptr) *last_row = true;
    return "last row must be 0 0 0 1 (not a rigid transform)";
  }
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  const double error = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (error > kOrthonormalTolerance) {
    std::string shown;
    detail::append_general(shown, error, 3);
    return "rotation is not orthonormal (||R^T R - I|| = " + shown +
           "; not a rigid transform: scaled or sheared?)";
  }
  if (R.determinant() < 0.0)
    return "rotation has determinant -1 (a reflection, not a rigid transform)";
  return {};
}

Eigen::Isometry3d to_rigid(const Eigen::Matrix4d& m) {
  // Text rounding leaves R a few ulps off orthonormal; snapping it to the nearest rotation (U Vᵀ of
  // its SVD, the orthogonal Procrustes solution) keeps composed transforms from drifting.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixU() * svd.matrixV().transpose();
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

Eigen::Isometry3d read_matrix(const std::filesystem::path& path) {
  const auto file = detail::open_file(path, kMaxMatrixFileBytes);
  detail::BlockReader in(path, *file);
  return detail::parse_matrix(in);
}

void write_matrix(const std::filesystem::path& path, const Eigen::Isometry3d& T) {
  std::string text;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      // 17 significant digits round-trip a double exactly.
      detail::append_general(text, c < 3 ? T.linear()(r, c) : T.translation()(r), 17);
      text += c < 3 ? ' ' : '\n';
    }
  }
  // Written rather than copied from T.matrix(), whose last row an Isometry3d built without
  // Identity() leaves uninitialised.
  text += "0 0 0 1\n";
  write_text_atomically(path, text);
}

}  // namespace align3d::io
