// 4x4 rigid transform files: 4 rows of 4 numbers (whitespace or commas), '#' comments and blank
// lines allowed. The matrix must be rigid: last row 0 0 0 1, rotation orthonormal with det +1 (to
// 1e-6 after which it is re-orthonormalised), all entries finite; anything else is an IoError
// naming the file and the line.
#pragma once

#include <Eigen/Geometry>
#include <filesystem>

namespace align3d::io {

Eigen::Isometry3d read_matrix(const std::filesystem::path& path);
void write_matrix(const std::filesystem::path& path, const Eigen::Isometry3d& T);  // atomic, %.17g

}  // namespace align3d::io
