// FPFH + RANSAC global registration (coarse/global.hpp describes the contract).
#pragma once

#include "align3d/coarse/global.hpp"

namespace align3d {

GlobalResult fpfh_ransac_register(const PointCloud& source, const PointCloud& target,
                                  const GlobalSettings& settings);

}  // namespace align3d
