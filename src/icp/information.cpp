#include "align3d/icp/information.hpp"

#include <algorithm>
#include <cmath>

#include "align3d/icp/factors.hpp"
#include "detail/parallel.hpp"

namespace align3d {

namespace {

struct InformationSums {
  LinearSystem6 system;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::size_t pairs = 0;
};

}  // namespace

PairInformation point_to_plane_information(const PointCloud& source, const PointCloud& target,
                                           const KdTree& tree, const Eigen::Isometry3d& T,
                                           double max_distance, int threads) {
  const double sq_max = max_distance * max_distance;
  const InformationSums sums = parallel_reduce(
      source.size(), threads, InformationSums{},
      [&](InformationSums& acc, std::size_t i) {
        const Eigen::Vector3d x = T * source.positions[i];
        Neighbor nb;
        if (!tree.nearest(x, nb, sq_max)) return;
        const Eigen::Vector3d& q = target.positions[nb.index];
        const Eigen::Vector3d& n = target.normals[nb.index];
        acc.system.add(PointToPlaneFactor::jacobian(x, n), PointToPlaneFactor::residual(x, q, n),
                       1.0);
        acc.centroid += q;
        ++acc.pairs;
      },
      [](InformationSums& a, const InformationSums& b) {
        a.system += b.system;
        a.centroid += b.centroid;
        a.pairs += b.pairs;
      });
  PairInformation out;
  out.pairs = sums.pairs;
  if (sums.pairs == 0) return out;
  out.hessian = sums.system.H;
  out.rms = std::sqrt(sums.system.sq_error / static_cast<double>(sums.pairs));
  out.centroid = sums.centroid / static_cast<double>(sums.pairs);
  const double sigma = std::max(out.rms, 1e-9 * max_distance);
  out.information = out.hessian / (sigma * sigma);
  return out;
}

}  // namespace align3d
