// The point cloud: positions and optional unit normals, in the caller's units (mm, m, ...).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

namespace align3d {

struct PointCloud {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> normals;  // empty, or one unit vector per position

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool has_normals() const { return !normals.empty() && normals.size() == positions.size(); }
};

// T·cloud: positions are transformed rigidly, normals rotated. T must be rigid.
PointCloud transformed(const PointCloud& cloud, const Eigen::Isometry3d& T);

// Axis-aligned bounding box diagonal length (0 for an empty cloud): the data's natural length
// scale.
double bounding_box_diagonal(const PointCloud& cloud);

Eigen::Vector3d centroid(const PointCloud& cloud);

}  // namespace align3d
