// libFuzzer target: the 4x4 matrix reader (src/io/matrix_io.cpp) on arbitrary bytes. A returned
// transform must be what matrix_io.hpp promises: finite, a rotation (orthonormal, det +1).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "align3d/error.hpp"
#include "fuzz_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;  // open_file rejects empty files before the parser sees them
  align3d::fuzz::FuzzInput input("fuzz.txt", data, size);
  try {
    const Eigen::Isometry3d T = align3d::io::detail::parse_matrix(input.in);
    const Eigen::Matrix3d R = T.linear();
    if (!T.matrix().allFinite() ||
        (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-9 ||
        std::abs(R.determinant() - 1.0) > 1e-9) {
      __builtin_trap();
    }
  } catch (const align3d::IoError&) {
  }
  return 0;
}
