// The target's side of a registration (prepared_target.hpp): built per call by align(source,
// target), or once by a PreparedTarget and shared by its calls. Internal to the pipeline.
#pragma once

#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/target_cache.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/prepared_target.hpp"

namespace align3d::detail {

struct TargetSide {
  // `shared`: used by several calls, maybe at once; everything ICP reads is then estimated here
  // (every normal), so the calls only read. Otherwise normals follow the pairs (NormalCache).
  TargetSide(const PointCloud& target, const NormalSettings& normals, int threads, bool shared);
  // A mesh target: ICP onto its exact surface, the rest on its sample (refine.hpp).
  TargetSide(std::shared_ptr<const MeshIndex> surface, int threads, bool shared);

  static TargetSide& of(const PreparedTarget& t) { return *t.side_; }

  RefineTarget refine;  // the target in spatial order, its tree and normals
  CloudScale scale;     // of refine.cloud()
  GlobalTargetCache global;
  bool shared;
};

}  // namespace align3d::detail
