// One ICP update (chapter 39.1 step 3, 39.4): from the pairs kept at the current pose, the
// closed-form point-to-point transform (Kabsch, kabsch.hpp) or the Gauss-Newton step of the
// point-to-plane, symmetric or GICP cost (factors.hpp), solved without moving along directions the
// data leaves free (degeneracy.hpp). Pairs are weighted by a robust kernel (kernels.hpp). And the
// covariance of the pose those pairs determine.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "align3d/icp/correspondences.hpp"
#include "align3d/icp/degeneracy.hpp"
#include "align3d/icp/factors.hpp"
#include "align3d/icp/kernels.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/se3.hpp"

namespace align3d {

// The pairs (T·source[i], target[pairs.target[i]]) with distance <= threshold, evaluated in
// coordinates about `centre` (the sums stay conditioned far from the origin). `normals` (one per
// target point, meaningful where pairs land) is read by every method but point-to-point;
// `source_normals` (one per source point, in `source`'s order) by GICP and symmetric. When the
// pairs carry their partners (pairs.point: a mesh target), those and pairs.normal are used instead
// of `target` and `normals`. tangent_planes (IcpSettings::tangent_planes): point-to-point's partner
// is the source point's foot on the target point's tangent plane.
struct StepInput {
  const std::vector<Eigen::Vector3d>& source;
  const std::vector<Eigen::Vector3d>& source_normals;
  const PointCloud& target;
  const std::vector<Eigen::Vector3d>& normals;
  const Correspondences& pairs;
  const Eigen::Isometry3d& T;
  const Eigen::Vector3d& centre;
  double threshold;
  bool tangent_planes = false;
};

// The cost: the method, and the kernel of the pairs' residuals (distance for point-to-point, plane
// distance for the others: GICP's full distance is mostly the samplings' offset along the surface,
// a few spacings at the final stage, which a kernel would take for outliers). kernel_scale > 0: in
// data units; <= 0 with a kernel: kernel_tuning(kernel) × σ̂, σ̂ = 1.4826 × the median residual of
// the kept pairs (the noise, re-measured each iteration).
struct StepCost {
  IcpMethod method = IcpMethod::kPointToPlane;
  RobustKernel kernel = RobustKernel::kNone;
  double kernel_scale = 0;
};

struct IcpStep {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();  // in the frame centred on `centre`
  // RMS residual of the kept pairs at the current pose, in data units: the distance for
  // point-to-point (to the partner's tangent plane with tangent_planes), the plane distance for
  // point-to-plane and GICP (along the target normal) and symmetric (along the mean normal).
  double rms = 0;
  // Pairs with distance <= threshold (and, for GICP and symmetric, compatible normals).
  std::size_t kept = 0;
  double kernel_scale = 0;  // the scale the weights used (0: none)
  // H = Σ w JᵀJ of point-to-plane (unknowns ω, v), symmetric (ã, t̃) or GICP (Σ w Jᵀ M J);
  // zero for point-to-point.
  Matrix6d hessian = Matrix6d::Zero();
  std::vector<WeakDirection> weak;  // free directions of H, weakest first
  bool solvable = false;  // enough pairs (3 point-to-point, 6 otherwise) and a finite step
};

// Deterministic for any `threads`.
IcpStep solve_step(const StepInput& in, const StepCost& cost, int threads);

// The 6×6 covariance of the pose the pairs determine, for a left perturbation T ← exp(ξ)·T with
// ξ = (rotation in radians, translation) about the target frame's origin. Censi 2007's closed form
// with the residuals standing in for the noise, as a robust sandwich A⁻¹ B A⁻¹ (Huber 1981):
// A = Σ ψ'·JᵀMJ (kernels.hpp, kernel_slope), B = Σ over target points of (Σ g)(Σ g)ᵀ, g = w·JᵀM e
// each pair's gradient, summed over the pairs sharing a partner first (they share its noise: with
// each pair alone the covariance was 1.8× too small on tests/icp_methods_test.cpp's surfaces).
// A's eigenvalues are floored at 1e-12 of the largest, and each direction the step left free
// (`weak`, of its system `hessian`: IcpStep::weak, IcpStep::hessian) gets a standard deviation
// `free_sigma` (data units; the loop passes the target's diagonal): the data do not fix it.
// `cost.kernel_scale` must be the step's (IcpStep::kernel_scale). Zero with fewer pairs than the
// method needs. Point-to-point onto tangent planes (tangent_planes) stops where point-to-plane does
// and gets point-to-plane's covariance. Not for point-to-point's error on two samplings of a
// surface paired sample to sample, which is a bias from the pairing, not noise. The noise's part
// only: the loop adds point-to-plane's model error and the step it did not take (icp.hpp,
// IcpResult::covariance).
Matrix6d pose_covariance(const StepInput& in, const StepCost& cost, const Matrix6d& hessian,
                         const std::vector<WeakDirection>& weak, double free_sigma, int threads);

}  // namespace align3d
