#include <algorithm>
#include <cmath>

#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/error.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/se3.hpp"
#include "detail/parallel.hpp"

namespace align3d {

// The voxel rule (global.hpp): the object's robust extent over this many voxels (the FPFH radius
// is 5 voxels, a tenth of the object; Open3D's examples use the same proportions), but not finer
// than a few point spacings: a voxel must gather points, and descriptors of single noisy samples
// do not repeat. Measured on generated depth-camera scenes (σ ≈ 1.6 mm, spacing 1.7 mm, a 180 mm
// part, extent / 50 = 3.5 mm): FPFH found the part for voxels of 5-8 mm and failed at 4.5 mm and
// below, and at 10 mm and above (too few points left on the part). A rule on the noise as well
// (4 σ) chose alike there, but a cloud that is no surface at all (scattered points) reads as
// noise of the order of its spacing and inflated the voxel until anything matched it.
constexpr double kVoxelsPerExtent = 50.0;
constexpr double kMinVoxelSpacings = 3.0;
constexpr double kMaxVoxelsPerExtent = 15.0;  // ... yet the object keeps ~15 voxels across
// surface_fit (global.hpp).
constexpr double kFitReachVoxels = 1.5;
constexpr double kFitPlaneVoxels = 0.25;
constexpr double kFitNormalDeg = 20;

Role object_role(const CloudScale& source, const CloudScale& target) {
  return source.extent < target.extent ? Role::kSource : Role::kTarget;
}

double global_voxel(const CloudScale& source, const CloudScale& target,
                    const GlobalSettings& settings) {
  if (settings.voxel > 0) return settings.voxel;
  const double spacing = std::max(source.spacing, target.spacing);
  const double extent = std::min(source.extent, target.extent);
  return std::max(extent / kVoxelsPerExtent,
                  std::min(kMinVoxelSpacings * spacing, extent / kMaxVoxelsPerExtent));
}

namespace {

// `known`, or the extent of `cloud` and, when `spacing`, its spacing, measured here (the noise is
// not needed).
CloudScale scale_of(const PointCloud& cloud, const CloudScale* known, bool spacing, int threads) {
  if (known) return *known;
  CloudScale s;
  s.extent = robust_extent(cloud);
  if (spacing && !cloud.empty()) s.spacing = point_spacing(cloud, KdTree(cloud.positions, threads));
  return s;
}

}  // namespace

GlobalPlan plan_global(const PointCloud& source, const PointCloud& target,
                       const GlobalSettings& settings, const GlobalContext& context) {
  const bool spacing = !(settings.voxel > 0);
  const CloudScale s = scale_of(source, context.source, spacing, settings.threads);
  const CloudScale t = scale_of(target, context.target, spacing, settings.threads);
  const GlobalPlan plan{object_role(s, t), global_voxel(s, t, settings)};
  if (!(plan.voxel > 0) || !std::isfinite(plan.voxel))
    throw DataError(to_string(plan.object),
                    "all points are at one spot (no length scale for the voxel)");
  return plan;
}

Role object_role(const PointCloud& source, const PointCloud& target) {
  return robust_extent(source) < robust_extent(target) ? Role::kSource : Role::kTarget;
}

double global_voxel(const PointCloud& source, const PointCloud& target,
                    const GlobalSettings& settings) {
  if (settings.voxel > 0) return settings.voxel;
  return global_voxel(scale_of(source, nullptr, true, settings.threads),
                      scale_of(target, nullptr, true, settings.threads), settings);
}

double surface_fit(const PointCloud& cloud, const PointCloud& other, const KdTree& other_tree,
                   const Eigen::Isometry3d& T, double voxel, int threads) {
  if (cloud.empty()) return 0.0;
  const double sq_radius = (kFitReachVoxels * voxel) * (kFitReachVoxels * voxel);
  const double max_plane = kFitPlaneVoxels * voxel;
  const double min_cos = std::cos(deg_to_rad(kFitNormalDeg));
  const std::size_t fitting = parallel_reduce(
      cloud.size(), threads, std::size_t{0},
      [&](std::size_t& count, std::size_t i) {
        const Eigen::Vector3d p = T * cloud.positions[i];
        Neighbor nb;
        if (!other_tree.nearest(p, nb, sq_radius)) return;
        const Eigen::Vector3d& n = other.normals[nb.index];
        if (std::abs(n.dot(p - other.positions[nb.index])) < max_plane &&
            std::abs(n.dot(T.linear() * cloud.normals[i])) > min_cos)
          ++count;
      },
      [](std::size_t& a, std::size_t b) { a += b; });
  return static_cast<double>(fitting) / static_cast<double>(cloud.size());
}

}  // namespace align3d
