// Helpers shared by the tests.
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <random>
#include <string>

#include "align3d/se3.hpp"

namespace align3d::test {

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

inline double rotation_error_deg(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return rad_to_deg(rotation_angle(estimate.linear().transpose() * truth.linear()));
}

inline double translation_error(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  return (estimate.translation() - truth.translation()).norm();
}

}  // namespace align3d::test
