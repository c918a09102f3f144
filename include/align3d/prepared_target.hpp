// A registration target prepared once for many sources: a line that registers thousands of scans
// against the same few models builds what depends on the model alone once, not per scan.
//
// It holds the target in spatial order with its kd-tree and every normal (estimated here when the
// cloud has none), its scale (cloud_stats.hpp: extent, spacing, noise), and, built by the first
// source that needs them, the global stage's FPFH descriptors and PPF model at the voxel in use
// (coarse/target_cache.hpp; the voxel follows the object, so a few voxels are kept).
// align(source, PreparedTarget(target), settings) returns the pose that align(source, target,
// settings) returns, to the bit; the report differs only in timings and in how many target normals
// were estimated (all of them, once).
//
// Lifetime: self-contained (copies the cloud); copies share the prepared data. Thread-safety: any
// number of align() calls may use one PreparedTarget at once.
#pragma once

#include <memory>

#include "align3d/mesh_index.hpp"
#include "align3d/normals.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

namespace detail {
struct TargetSide;
}

class PreparedTarget {
 public:
  // Throws DataError("target", …) for a cloud that cannot be registered (cloud_stats.hpp).
  // `normals.k` must match the AlignSettings it is used with (refine.normals.k); `threads`: for
  // the preparation (0: all cores).
  explicit PreparedTarget(const PointCloud& target, const NormalSettings& normals = {},
                          int threads = 0);
  // A mesh target (a CAD model): registered onto its exact surface (refine.hpp, RefineTarget).
  // Throws DataError("target", …) for a mesh with nothing to measure (mesh_index.hpp).
  explicit PreparedTarget(const TriangleMesh& target, int threads = 0);
  // The same with an index the caller keeps using (inspection measures deviations with it).
  explicit PreparedTarget(std::shared_ptr<const MeshIndex> target, int threads = 0);

  const PointCloud& cloud() const;   // the target in spatial order; a mesh's sample
  const MeshIndex* surface() const;  // a mesh target's surface, or null
  std::shared_ptr<const MeshIndex> shared_surface() const;  // the same, shared
  std::size_t size() const { return cloud().size(); }
  int normal_k() const;

 private:
  friend struct detail::TargetSide;
  std::shared_ptr<detail::TargetSide> side_;
};

}  // namespace align3d
