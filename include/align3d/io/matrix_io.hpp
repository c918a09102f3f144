// 4x4 rigid transform files: 4 rows of 4 numbers (whitespace or commas), '#' comments and blank
// lines allowed. The matrix must be rigid: last row 0 0 0 1, rotation orthonormal with det +1 (to
// 1e-6 after which it is re-orthonormalised), all entries finite; anything else is an IoError
// naming the file and the line.
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <string>

namespace align3d::io {

Eigen::Isometry3d read_matrix(const std::filesystem::path& path);
void write_matrix(const std::filesystem::path& path, const Eigen::Isometry3d& T);  // atomic, %.17g

// The rule above for a matrix in memory (the Python binding's 4x4 arrays): why `m` is not a rigid
// transform, or empty when it is one; `last_row` (optional) tells whether the last row is at fault
// rather than the rotation (rows 1-3).
std::string rigid_problem(const Eigen::Matrix4d& m, bool* last_row = nullptr);
// m as a rigid transform, its rotation snapped to the nearest one; m must pass rigid_problem.
Eigen::Isometry3d to_rigid(const Eigen::Matrix4d& m);

}  // namespace align3d::io
