// Helpers shared by the tests.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "align3d/cli.hpp"
#include "align3d/error.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/camera.hpp"
#include "detail/random.hpp"

namespace align3d::test {

// Built with AddressSanitizer or ThreadSanitizer: they reserve terabytes of address space and keep
// freed memory in quarantine, so memory limits and resident-size bounds mean nothing there.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

// A fresh empty directory under the system temp dir, removed at scope exit.
class TempDir {
 public:
  explicit TempDir(const std::string& name) {
    static std::mt19937_64 rng{std::random_device{}()};
    path_ = std::filesystem::temp_directory_path() /
            ("align3d_" + name + "_" + std::to_string(rng() % 1000000000ULL));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

// A whole file's bytes ("" when it cannot be opened).
inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes `text` as the whole file, bytes as given.
inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

// One `align3d` command line run in-process (cli::run; args[0] is the subcommand): its exit code
// and what it printed on stdout and stderr.
struct CliRun {
  int code;
  std::string out, err;
};

inline CliRun run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = cli::run(args, out, err);
  return {code, out.str(), err.str()};
}

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

// An exit code as cli::run returns it.
inline int code(ExitCode c) { return static_cast<int>(c); }

inline double rotation_error_deg(const Eigen::Isometry3d& estimate,
                                 const Eigen::Isometry3d& truth) {
  return pose_error(estimate, truth).rotation_deg;
}

inline double translation_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return pose_error(estimate, truth).translation;
}

// Three uniform draws from [lo, hi), x first.
inline Eigen::Vector3d random_vector(Random& rng, double lo, double hi) {
  const double x = rng.uniform(lo, hi), y = rng.uniform(lo, hi), z = rng.uniform(lo, hi);
  return {x, y, z};
}

// A direction uniform on the unit sphere.
inline Eigen::Vector3d random_unit(Random& rng) {
  const double x = rng.normal(), y = rng.normal(), z = rng.normal();
  return Eigen::Vector3d(x, y, z).normalized();
}

// The angle between the lines along a and b (a direction and its opposite are one line), degrees.
inline double line_angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return rad_to_deg(std::atan2(a.cross(b).norm(), std::abs(a.dot(b))));
}

inline void expect_proper_rotation(const Eigen::Matrix3d& R) {
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
}

// Two organized clouds equal to the bit: size, shape labels and positions (NaN included).
inline bool same_bits(const synth::OrganizedCloud& a, const synth::OrganizedCloud& b) {
  return a.width == b.width && a.height == b.height && a.shape == b.shape &&
         a.positions.size() == b.positions.size() &&
         std::memcmp(a.positions.data(), b.positions.data(),
                     a.positions.size() * sizeof(Eigen::Vector3d)) == 0;
}

// Builds binary file content value by value in a chosen byte order.
class Bytes {
 public:
  explicit Bytes(bool big_endian = false) : big_endian_(big_endian) {}
  Bytes& text(std::string_view s) {
    data_ += s;
    return *this;
  }
  template <typename T>
  Bytes& put(T value) {
    auto bytes = std::bit_cast<std::array<char, sizeof(T)>>(value);
    if (big_endian_ != (std::endian::native == std::endian::big)) {
      std::reverse(bytes.begin(), bytes.end());
    }
    data_.append(bytes.data(), bytes.size());
    return *this;
  }
  const std::string& str() const { return data_; }

 private:
  bool big_endian_;
  std::string data_;
};

// The six faces of a 60 × 40 × 20 box centred at the origin, sampled uniformly by area: a shape
// with symmetries, for ambiguity tests.
inline PointCloud box_surface(int count, Random& rng) {
  const Eigen::Vector3d half(30, 20, 10);
  const double areas[3] = {half.y() * half.z(), half.x() * half.z(), half.x() * half.y()};
  const double total = areas[0] + areas[1] + areas[2];
  PointCloud cloud;
  for (int i = 0; i < count; ++i) {
    const double pick = rng.uniform() * total;
    const int axis = pick < areas[0] ? 0 : pick < areas[0] + areas[1] ? 1 : 2;
    Eigen::Vector3d p;
    for (int k = 0; k < 3; ++k) p(k) = rng.uniform(-half(k), half(k));
    p(axis) = rng.uniform() < 0.5 ? -half(axis) : half(axis);
    cloud.positions.push_back(p);
  }
  return cloud;
}

}  // namespace align3d::test
