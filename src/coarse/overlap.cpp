#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/kdtree.hpp"
#include "detail/parallel.hpp"

namespace align3d {

// The object's fraction of the voxel: its robust extent over this many voxels (the FPFH radius is
// 5 voxels, a tenth of the object; Open3D's examples use the same proportions).
constexpr double kVoxelsPerExtent = 50.0;

Role object_role(const PointCloud& source, const PointCloud& target) {
  return robust_extent(source) < robust_extent(target) ? Role::kSource : Role::kTarget;
}

double global_voxel(const PointCloud& source, const PointCloud& target,
                    const GlobalSettings& settings) {
  if (settings.voxel > 0) return settings.voxel;
  return std::min(robust_extent(source), robust_extent(target)) / kVoxelsPerExtent;
}

double overlap_fraction(const PointCloud& cloud, const KdTree& tree, const Eigen::Isometry3d& T,
                        double radius, int threads) {
  if (cloud.empty()) return 0.0;
  const double sq_radius = radius * radius;
  const std::size_t inside = parallel_reduce(
      cloud.size(), threads, std::size_t{0},
      [&](std::size_t& n, std::size_t i) {
        Neighbor nb;
        n += tree.nearest(T * cloud.positions[i], nb, sq_radius) ? 1 : 0;
      },
      [](std::size_t& a, std::size_t b) { a += b; });
  return static_cast<double>(inside) / static_cast<double>(cloud.size());
}

}  // namespace align3d
