// Voxel-grid downsampling: one point per occupied voxel (the centroid of its points; normals
// averaged and renormalised when present). Output order is the voxels' sorted integer keys, so the
// result does not depend on input order beyond floating-point summation, nor on threads.
#pragma once

#include <cstdint>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d {

// voxel > 0 (data units). Throws std::invalid_argument otherwise or when the grid would need more
// than 2^21 cells along an axis (choose a larger voxel).
PointCloud voxel_downsample(const PointCloud& cloud, double voxel);
// The same with a label per point (`labels`, one per point): each output point gets the label most
// of its voxel's points carry (the smallest on a tie), in `out_labels`.
PointCloud voxel_downsample(const PointCloud& cloud, double voxel,
                            const std::vector<std::int32_t>& labels,
                            std::vector<std::int32_t>& out_labels);

}  // namespace align3d
