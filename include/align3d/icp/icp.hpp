// The ICP loop (chapter 39.1-39.4): correspondences (correspondences.hpp) → rejection
// (rejection.hpp) → update (solver.hpp: closed-form point-to-point or Gauss-Newton point-to-plane)
// → compose → termination check (termination.hpp) → repeat.
// This is one ICP run with one fixed rejection rule; refine.hpp builds the robust default schedule
// on top of it.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "align3d/icp/degeneracy.hpp"
#include "align3d/icp/factors.hpp"
#include "align3d/icp/fit.hpp"
#include "align3d/icp/kernels.hpp"
#include "align3d/icp/rejection.hpp"
#include "align3d/icp/termination.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/normals.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/se3.hpp"

namespace align3d {

struct IcpSettings {
  IcpMethod method = IcpMethod::kPointToPlane;
  RejectionRule rejection = RejectionRule::median();
  TerminationSettings termination;
  // Pairs are weighted by this kernel of their residual (distance for point-to-point, plane
  // distance for the others; solver.hpp, StepCost), re-weighted every iteration (IRLS); none:
  // plain least squares as in the chapter. kernel_scale > 0 is its scale in data units; <= 0: from
  // the noise, re-measured each iteration (solver.hpp, StepCost).
  RobustKernel kernel = RobustKernel::kNone;
  double kernel_scale = 0.0;
  // Estimate IcpResult::covariance at the returned pose (one more pass over the pairs and a sort
  // of them); refine() asks for it in its final stage only.
  bool covariance = false;
  // >= 1 (a point-cloud target): a pair (p, q) within the threshold and longer than
  // reciprocity_floor (data units) enters the update only when no other kept pair of the same
  // target point q is shorter than |p − q| ÷ reciprocity (1: the shortest pair of each target
  // point only, PCL's CorrespondenceRejectorOneToOne). It sets aside the pairs of source points
  // beyond the target's rim, which crowd onto the rim and drag the source along the surface; a
  // pair within the floor (refine(): half a point spacing) cannot reach far beyond a rim. The RMS
  // and the kept pairs (IcpResult) still count the pairs set aside, so they judge a pose as
  // without it. 0: off.
  double reciprocity = 0.0;
  double reciprocity_floor = 0.0;
  // Point-to-point onto a point cloud with normals: each source point pairs with its foot on the
  // tangent plane of its nearest target point (the target's local surface) instead of the sample
  // itself, as it pairs with the closest point of a mesh's triangles: the closest point on the
  // shape (Besl and McKay 1992), not on its samples (CloudCompare's cloud-to-cloud distance with a
  // local model is the same idea). Two samplings of one surface then meet at the noise floor,
  // where sample-to-sample pairs leave a bias of a fraction of a spacing (the chapter's
  // point-to-point stops above the noise floor for this reason). The residual lies along the
  // normal, so the run stops where point-to-plane's does (Σ Jᵀ(p − q') = 0 is point-to-plane's
  // normal equations), by the closed-form step, and its covariance is point-to-plane's. refine()
  // sets it in its final stage. Read by point-to-point only.
  bool tangent_planes = false;
  // With judge.noise >= 0, IcpResult::fit: the returned pose's own pairs (the kept ones the update
  // used, none set aside) judged at the noise (icp/fit.hpp), where the run reads the target's
  // normals or surface (every method but point-to-point sample to sample). refine() asks for it in
  // its final stage.
  FitScale judge;
  int threads = 0;  // 0: all cores; the result does not depend on it
};

struct IcpResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  int iterations = 0;      // updates applied
  bool converged = false;  // a convergence criterion fired with enough pairs (never merely the cap)
  StopReason stop_reason = StopReason::kMaxIterations;
  // At the returned pose (the last evaluation, history.back()):
  double rms = 0;  // RMS of the kept pairs' residuals (metric as in IterationRecord)
  std::size_t correspondences = 0;       // kept pairs
  double fitness = 0;                    // kept pairs ÷ source points (Open3D's meaning)
  std::vector<IterationRecord> history;  // iterations + 1 evaluations, the last at the result
  // The method's system at the returned pose (H of Σ w r², in the frame centred on `centre`,
  // unknowns ω then v; ã then t̃ for symmetric) for judging which directions the data constrains;
  // point-to-point onto a mesh or tangent planes: point-to-plane's of its pairs at the returned
  // pose; zero for point-to-point sample to sample.
  Matrix6d hessian = Matrix6d::Zero();
  // The point the system's unknowns are taken about: the target's centroid (a mesh: the centre of
  // its bounding box). An update (ω, v) moves x to x + ω × (x − centre) + v.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  // Directions of that system the data leaves (nearly) free, weakest first (icp/degeneracy.hpp):
  // every update is solved without moving along them (point-to-point's closed-form step on a
  // surface does not: each residual lies along its normal). Empty when all six are constrained,
  // and always for point-to-point sample to sample, whose step analyses no system.
  std::vector<WeakDirection> degenerate_directions;
  // With IcpSettings::covariance, the covariance of the returned pose: rotation (radians) then
  // translation, for T ← exp(ξ)·T about the target frame's origin; zero otherwise. The noise's
  // part from the kept pairs' residuals (pose_covariance, solver.hpp), plus model_error·model_
  // errorᵀ, plus p·pᵀ for the update p the run would apply next (it did not reach its stationary
  // point by that much; far below a standard deviation after a Gauss-Newton step). The accuracy of
  // a correct convergence only: it says nothing of a wrong minimum.
  Matrix6d covariance = Matrix6d::Zero();
  // With the covariance: the length of that next update p (for point-to-point onto a mesh or
  // tangent planes, point-to-plane's Gauss-Newton step toward the stationary point of the same
  // distances) in the standard deviations (Mahalanobis) of the covariance without p·pᵀ. Far below
  // 1 at a stationary point; above, the run stopped about that far short of it (align() warns
  // stopped_short above kStoppedShortSigmas, align.hpp).
  double pending_sigmas = 0;
  // Point-to-plane onto a point cloud's tangent planes (point-to-point's too with tangent_planes),
  // with the covariance and a source with normals (refine()'s schedule estimates them): the
  // symmetric objective's Gauss-Newton step of the same pairs minus the method's own, i.e. from
  // the method's stationary point to the symmetric one (rotation then translation, as the
  // covariance), added to the covariance as d·dᵀ. A tangent plane misses the surface under the
  // source point by ½κu² (κ its curvature, u the samples' offset along it), an error of one sign on
  // a curved part that the residuals' scatter does not show; the symmetric residual, with both
  // normals, cancels it to second order (Rusinkiewicz 2019), so the distance between the two
  // stationary points measures what it does to the pose. Measured on two range scans 40° apart
  // (tests/icp_methods_test.cpp, Covariance/RangeScans): point-to-plane's NEES 20 → 6.8 on the
  // test object, 11 → 6.5 on the animal (expected 6). Zero otherwise.
  Vector6d model_error = Vector6d::Zero();
  // With IcpSettings::judge: how the returned pose fits at the noise (icp/fit.hpp); zero otherwise.
  FitEvidence fit;
};

// Registers `source` onto `target` starting from `init` (target ≈ T·source). `tree` must index
// target.positions; every method but point-to-point needs target normals, GICP and symmetric also
// source normals (std::invalid_argument otherwise, and for the rejection rule kAuto, which is
// refine()'s schedule).
IcpResult icp(const PointCloud& source, const PointCloud& target, const KdTree& tree,
              const Eigen::Isometry3d& init, const IcpSettings& settings);

// The same with the target's normals estimated as point-to-plane needs them (normals.hpp,
// NormalCache): only the target points of kept pairs get one, and the result has the same bits as
// with every normal estimated first. The cache may be shared by several runs on one target.
IcpResult icp(const PointCloud& source, NormalCache& target, const Eigen::Isometry3d& init,
              const IcpSettings& settings);

// The same onto a mesh's exact surface: each source point pairs with its closest point on the
// triangles (correspondences.hpp), point-to-plane uses that triangle's normal.
IcpResult icp(const PointCloud& source, const MeshIndex& target, const Eigen::Isometry3d& init,
              const IcpSettings& settings);

}  // namespace align3d
