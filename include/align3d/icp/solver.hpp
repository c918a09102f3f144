// One ICP update (chapter 39.1 step 3, 39.4): from the pairs kept at the current pose, the
// closed-form point-to-point transform (Kabsch, kabsch.hpp) or the Gauss-Newton point-to-plane
// step (factors.hpp), solved without moving along directions the data leaves free
// (degeneracy.hpp). Pairs are weighted by the robust kernel (kernels.hpp).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "align3d/icp/correspondences.hpp"
#include "align3d/icp/degeneracy.hpp"
#include "align3d/icp/factors.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/se3.hpp"

namespace align3d {

struct IcpStep {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();  // in the frame centred on `centre`
  double rms = 0;        // RMS residual of the kept pairs at the current pose (factors' metric)
  std::size_t kept = 0;  // pairs with distance <= threshold
  Matrix6d hessian = Matrix6d::Zero();  // point-to-plane H = Σ w JᵀJ (zero for point-to-point)
  std::vector<WeakDirection> weak;      // free directions of H, weakest first
  bool solvable = false;  // enough pairs (3 point-to-point, 6 point-to-plane) and a finite step
};

// Evaluates the pairs (T·source[i], target[pairs.target[i]]) with distance <= threshold in
// coordinates about `centre` (the sums stay conditioned far from the origin) and solves for the
// update. `normals` (one per target point, meaningful where pairs land) is read for
// point-to-plane only. When the pairs carry their partners (pairs.point: a mesh target), those
// and pairs.normal are used instead of `target` and `normals`. robust_scale > 0 weights pairs by
// the Geman-McClure kernel of that scale. Deterministic for any `threads`.
IcpStep solve_step(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                   const std::vector<Eigen::Vector3d>& normals, const Correspondences& pairs,
                   const Eigen::Isometry3d& T, const Eigen::Vector3d& centre, double threshold,
                   IcpMethod method, double robust_scale, int threads);

}  // namespace align3d
