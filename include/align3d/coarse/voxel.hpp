// Voxel-grid downsampling: one point per occupied voxel (the centroid of its points; normals
// averaged and renormalised when present). Output order is the voxels' sorted integer keys, so the
// result does not depend on input order beyond floating-point summation, nor on threads.
#pragma once

#include "align3d/point_cloud.hpp"

namespace align3d {

// voxel > 0 (data units). Throws std::invalid_argument otherwise or when the grid would need more
// than 2^21 cells along an axis (choose a larger voxel).
PointCloud voxel_downsample(const PointCloud& cloud, double voxel);

}  // namespace align3d
