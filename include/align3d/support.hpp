// How well the data support a pose: the measure align() uses to judge an ICP answer, to choose
// between the answer from the initial pose and the one from global registration, and to warn.
//
// Of the two clouds, the object is the one of smaller robust extent (coarse/global.hpp), whichever
// role it has. At a pose T (target ≈ T·source), an object point is "on" the other cloud's surface
// when its nearest point of the other cloud lies within `reach` of it and within `band` of the
// target's tangent plane there (the PCA normal, k = 20, of the object point when the object is the
// target, else of that nearest point: always the target's normals, which the ICP's point-to-plane
// pairs estimate anyway). `overlap` is the share of the object's points
// that are on the surface: a wrong local minimum lays part of the object onto the other cloud and
// leaves the rest off, the right pose lays every overlapping part on it. The distances follow the
// data, so mm and m behave the same:
//   s = the larger of the two point spacings (cloud_stats.hpp), σ₀ = √(σ_source² + σ_target²) with
//   σ the surface noise of each cloud (cloud_stats.hpp), or √(σ₀² + σ_x²) where the pose fits at
//   the noise and its pairs show structured noise σ_x beyond σ₀ (icp/fit.hpp, align.cpp);
//   reach = 1.5 s + 3 σ₀, band = max(3 σ₀, 0.1 s).
// At most 50 000 object points, evenly spaced, are tested.
#pragma once

#include <Eigen/Geometry>
#include <memory>

#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

struct Support {
  double overlap = 0;     // share of the object's points on the other cloud's surface at the pose
  double noise = 0;       // σ₀ (data units)
  double spacing = 0;     // s (data units)
  double structured = 0;  // σ_x the test allowed for (data units; 0: none)
  double reach = 0, band = 0;   // the distances of the test (data units)
  Role object = Role::kTarget;  // which cloud the share is of
};

// Prepared once for a pair of clouds (the noise, the spacings, their kd-trees), then measures any
// number of poses. A tree or a scale (measure_scale) the caller already has may be passed (it must
// be of that cloud); the others are built or measured. Lifetime: keeps references to the clouds
// and the given trees, which must outlive it. Thread-safety: one measure() at a time (it estimates
// normals on demand).
class SupportMeter {
 public:
  // `target_normals`: the target's normals estimated on demand (a NormalCache of `target` with
  // k = 20, such as a RefineTarget's), shared instead of estimated again.
  SupportMeter(const PointCloud& source, const PointCloud& target, int threads = 0,
               const KdTree* source_tree = nullptr, const KdTree* target_tree = nullptr,
               const CloudScale* source_scale = nullptr, const CloudScale* target_scale = nullptr,
               NormalCache* target_normals = nullptr);
  ~SupportMeter();
  SupportMeter(const SupportMeter&) = delete;
  SupportMeter& operator=(const SupportMeter&) = delete;

  // `structured`: σ_x (data units) the pose's fit showed (FitEvidence::structured of a pose that
  // fits at the noise; 0: none).
  Support measure(const Eigen::Isometry3d& T_target_source, double structured = 0);

 private:
  const PointCloud& source_;
  const PointCloud& target_;
  int threads_;
  std::unique_ptr<KdTree> own_source_tree_, own_target_tree_;
  const KdTree* source_tree_;
  const KdTree* target_tree_;
  std::unique_ptr<NormalCache> own_normals_;
  NormalCache* target_normals_ = nullptr;
  Support base_;  // the pose-independent fields
};

}  // namespace align3d
