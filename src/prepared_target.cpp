#include "align3d/prepared_target.hpp"

#include "detail/target_side.hpp"

namespace align3d {
namespace detail {

TargetSide::TargetSide(const PointCloud& target, const NormalSettings& normals, int threads,
                       bool shared)
    : refine(target, normals, threads),
      scale{refine.extent(), refine.spacing(), refine.noise()},
      global(refine.cloud()),
      shared(shared) {
  if (shared) refine.estimate_all_normals();
}

TargetSide::TargetSide(std::shared_ptr<const MeshIndex> surface, int threads, bool shared)
    : refine(std::move(surface), threads),
      scale{refine.extent(), refine.spacing(), refine.noise()},
      global(refine.cloud()),
      shared(shared) {
  if (shared) refine.estimate_all_normals();
}

}  // namespace detail

PreparedTarget::PreparedTarget(const PointCloud& target, const NormalSettings& normals, int threads)
    : side_(std::make_shared<detail::TargetSide>(target, normals, threads, true)) {}

PreparedTarget::PreparedTarget(const TriangleMesh& target, int threads)
    : side_(std::make_shared<detail::TargetSide>(
          std::make_shared<const MeshIndex>(target, threads, "target"), threads, true)) {}

PreparedTarget::PreparedTarget(std::shared_ptr<const MeshIndex> target, int threads)
    : side_(std::make_shared<detail::TargetSide>(std::move(target), threads, true)) {}

const MeshIndex* PreparedTarget::surface() const { return side_->refine.surface(); }

std::shared_ptr<const MeshIndex> PreparedTarget::shared_surface() const {
  return side_->refine.shared_surface();
}

const PointCloud& PreparedTarget::cloud() const { return side_->refine.cloud(); }

int PreparedTarget::normal_k() const { return side_->refine.normal_k(); }

}  // namespace align3d
