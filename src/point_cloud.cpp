#include "align3d/point_cloud.hpp"

namespace align3d {

PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T) {
  PointCloud out;
  out.positions.reserve(cloud.size());
  for (const auto& p : cloud.positions) out.positions.push_back(T * p);
  if (cloud.has_normals()) {
    out.normals.reserve(cloud.size());
    for (const auto& n : cloud.normals) out.normals.push_back(T.linear() * n);
  }
  return out;
}

double bounding_box_diagonal(const PointCloud& cloud) {
  if (cloud.empty()) return 0.0;
  Eigen::AlignedBox3d box;
  for (const auto& p : cloud.positions) box.extend(p);
  return box.diagonal().norm();
}

Eigen::Vector3d centroid(const PointCloud& cloud) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& p : cloud.positions) sum += p;
  return cloud.empty() ? sum : Eigen::Vector3d(sum / static_cast<double>(cloud.size()));
}

}  // namespace align3d
