#include "align3d/coarse/global.hpp"
#include "align3d/kdtree.hpp"
#include "detail/parallel.hpp"

namespace align3d {

double global_voxel(const PointCloud& target, const GlobalSettings& settings) {
  return settings.voxel > 0 ? settings.voxel : bounding_box_diagonal(target) / 50.0;
}

double overlap_fraction(const PointCloud& source, const KdTree& tree, const Eigen::Isometry3d& T,
                        double radius, int threads) {
  if (source.empty()) return 0.0;
  const double sq_radius = radius * radius;
  const std::size_t inside = parallel_reduce(
      source.size(), threads, std::size_t{0},
      [&](std::size_t& n, std::size_t i) {
        Neighbor nb;
        n += tree.nearest(T * source.positions[i], nb, sq_radius) ? 1 : 0;
      },
      [](std::size_t& a, std::size_t b) { a += b; });
  return static_cast<double>(inside) / static_cast<double>(source.size());
}

}  // namespace align3d
