// FPFH + RANSAC global registration (coarse/global.hpp describes the contract).
#pragma once

#include <memory>
#include <vector>

#include "align3d/coarse/fpfh.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/kdtree.hpp"

namespace align3d {

// One cloud ready for descriptor matching: downsampled to the voxel with isolated points dropped,
// its kd-tree, normals (in `down`) and FPFH descriptors.
struct FpfhCloud {
  PointCloud down;
  std::unique_ptr<KdTree> tree;
  std::vector<FpfhDescriptor> features;
};

// Throws DataError(what, …) when fewer than 10 points remain or they lie on a line.
std::shared_ptr<const FpfhCloud> prepare_fpfh(const PointCloud& cloud, double voxel,
                                              const char* what, int threads);

GlobalResult fpfh_ransac_register(const PointCloud& source, const PointCloud& target,
                                  const GlobalSettings& settings,
                                  const GlobalContext& context = {});

}  // namespace align3d
