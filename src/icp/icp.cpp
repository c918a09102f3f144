#include "align3d/icp/icp.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "align3d/icp/correspondences.hpp"
#include "align3d/icp/solver.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

// The target points of the kept pairs whose normal `cache` does not know yet (in source order,
// with repeats).
std::vector<std::uint32_t> missing_normals(const Correspondences& c, double threshold,
                                           const NormalCache& cache, int threads) {
  return parallel_reduce(
      c.target.size(), threads, std::vector<std::uint32_t>{},
      [&](std::vector<std::uint32_t>& missing, std::size_t i) {
        if (is_kept(c, i, threshold) && !cache.known(c.target[i]))
          missing.push_back(static_cast<std::uint32_t>(c.target[i]));
      },
      [](std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
        a.insert(a.end(), b.begin(), b.end());
      });
}

// Whether the run reads a point-cloud target's normals: every method but point-to-point, and
// point-to-point onto tangent planes (IcpSettings::tangent_planes).
bool reads_target_normals(const IcpSettings& s) {
  return s.method != IcpMethod::kPointToPoint || s.tangent_planes;
}

// What a run registers onto: a point cloud with its kd-tree (and a NormalCache when its normals are
// estimated on demand), or a mesh's exact surface.
struct Target {
  const PointCloud* cloud = nullptr;
  const KdTree* tree = nullptr;
  NormalCache* cache = nullptr;
  const MeshIndex* surface = nullptr;
};

// Whether the covariance takes in the tangent planes' model error (IcpResult::model_error): a
// residual onto a point cloud's tangent planes alone (point-to-plane; point-to-point with
// tangent_planes), not both clouds' normals, and a source with normals for the symmetric step that
// measures it.
bool measures_model_error(const PointCloud& source, const Target& target, const IcpSettings& s) {
  return s.covariance && reads_target_normals(s) && !needs_source_normals(s.method) &&
         target.cloud && source.has_normals();
}

// The centre of the target's box: the update's coordinates are taken about it (conditioning).
Eigen::Vector3d centre_of(const MeshIndex& surface) {
  Eigen::Vector3d lo = surface.mesh().vertices[0], hi = lo;
  for (const Eigen::Vector3d& v : surface.mesh().vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return 0.5 * (lo + hi);
}

// The length of the left perturbation ξ (exp(ξ)·T) in the standard deviations of `covariance`; 0
// when that is zero or singular.
double mahalanobis(const Vector6d& xi, const Matrix6d& covariance) {
  if (covariance.isZero()) return 0;
  const Eigen::LDLT<Matrix6d> ldlt(covariance);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return 0;
  const double m2 = xi.dot(ldlt.solve(xi));
  return std::isfinite(m2) && m2 > 0 ? std::sqrt(m2) : 0.0;
}

// The length of the update `step` solved for, in standard deviations of the pose its pairs give
// (√(ξᵀHξ) / σ̂, TerminationSettings::step_sigmas); 0 without a system or a residual.
double step_length(const IcpStep& step) {
  if (!(step.rms > 0) || step.hessian.isZero()) return 0;
  const Vector6d xi = se3_log(step.delta);
  return std::sqrt(std::max(0.0, xi.dot(step.hessian * xi))) / step.rms;
}

// The loop; point-to-plane takes its normals from the surface's triangles, from `cache` when there
// is one (estimating those the kept pairs need first), or from the cloud's normals.
IcpResult run_icp(const PointCloud& source, const Target& target, const Eigen::Isometry3d& init,
                  const IcpSettings& s) {
  NormalCache* cache = target.cache;
  static const std::vector<Eigen::Vector3d> kNone;
  const std::vector<Eigen::Vector3d>& normals = cache          ? cache->normals()
                                                : target.cloud ? target.cloud->normals
                                                               : kNone;
  const Eigen::Vector3d centre =
      target.surface ? centre_of(*target.surface) : centroid(*target.cloud);
  const Eigen::Translation3d to_world(centre);
  const double diagonal =
      target.surface ? target.surface->diagonal() : bounding_box_diagonal(*target.cloud);
  const TerminationSettings& term = s.termination;

  // The source in spatial order (spatial_order, kdtree.hpp): consecutive queries and their target
  // partners are close in space, so the search and the sums stay in cache on large clouds.
  std::vector<Eigen::Vector3d> moving(source.size()), moving_normals;
  {
    const std::vector<std::uint32_t> order = spatial_order(source.positions, s.threads);
    for (std::size_t k = 0; k < moving.size(); ++k) moving[k] = source.positions[order[k]];
    if (needs_source_normals(s.method) || measures_model_error(source, target, s)) {
      moving_normals.resize(source.size());
      for (std::size_t k = 0; k < moving.size(); ++k) moving_normals[k] = source.normals[order[k]];
    }
  }
  const StepCost cost{s.method, s.kernel, s.kernel_scale};
  static const PointCloud kNoCloud;
  const PointCloud& target_cloud = target.cloud ? *target.cloud : kNoCloud;

  // Each pass evaluates the pose reached so far and, unless a criterion stops the loop there,
  // applies the update it solved for. The pose returned is the last one evaluated, so its RMS,
  // pairs and system are exact without a separate final pass: n updates cost n + 1 searches.
  IcpResult result;
  result.T_target_source = init;
  result.centre = centre;
  Correspondences c;
  double threshold = 0, kernel_scale = 0;
  // The kept pairs at the current pose, as the solver reads them.
  auto pairs = [&] {
    return StepInput{moving, moving_normals, target_cloud,    normals, c, result.T_target_source,
                     centre, threshold,      s.tangent_planes};
  };
  double previous_rms = std::numeric_limits<double>::quiet_NaN();
  Eigen::Isometry3d pending = Eigen::Isometry3d::Identity();  // the update not applied
  for (;;) {
    if (target.surface)
      find_surface_correspondences(moving, *target.surface, result.T_target_source,
                                   s.rejection.search_bound(), s.threads, c);
    else
      find_correspondences(moving, *target.cloud, *target.tree, result.T_target_source,
                           s.rejection.search_bound(), s.threads, c);
    threshold = rejection_threshold(s.rejection, c);
    if (s.reciprocity > 0 && target.cloud)
      set_aside_crowded(target.cloud->size(), threshold, s.reciprocity, s.reciprocity_floor,
                        s.threads, c);
    if (cache && reads_target_normals(s))
      cache->require(missing_normals(c, threshold, *cache, s.threads));
    IcpStep step = solve_step(pairs(), cost, s.threads);
    kernel_scale = step.kernel_scale;
    pending = step.delta;
    result.history.push_back({step.rms, step.kept, threshold});
    result.rms = step.rms;
    result.correspondences = step.kept;
    result.hessian = step.hessian;
    result.degenerate_directions = std::move(step.weak);
    if (!step.solvable || step.kept < min_pairs(s.method)) {
      result.stop_reason = StopReason::kTooFewCorrespondences;
      break;
    }
    if (check_termination(result.history, previous_rms, step.delta, diagonal, term,
                          result.stop_reason, term.step_sigmas > 0 ? step_length(step) : 0.0))
      break;
    if (result.iterations >= term.max_iterations) {
      result.stop_reason = StopReason::kMaxIterations;
      break;
    }
    result.T_target_source = to_world * step.delta * to_world.inverse() * result.T_target_source;
    result.T_target_source.linear() = nearest_rotation(result.T_target_source.linear());
    ++result.iterations;
    previous_rms = step.rms;
  }
  // Point-to-point onto a surface (a mesh's triangles, tangent planes): each residual lies along
  // its partner's normal, so the closed-form step does not move along the directions the data
  // leave free, and point-to-plane's system of the same pairs finds them (one more pass, at the
  // returned pose only).
  if (s.method == IcpMethod::kPointToPoint && (target.surface || s.tangent_planes) &&
      result.stop_reason != StopReason::kTooFewCorrespondences) {
    IcpStep plane =
        solve_step(pairs(), {IcpMethod::kPointToPlane, s.kernel, kernel_scale}, s.threads);
    result.hessian = plane.hessian;
    result.degenerate_directions = std::move(plane.weak);
    pending = plane.delta;  // toward the stationary point of the same distances
  }
  if (s.judge.noise >= 0 && result.stop_reason != StopReason::kTooFewCorrespondences &&
      (target.surface || reads_target_normals(s)))
    result.fit = judge_fit(normal_residuals(moving, result.T_target_source, c, threshold,
                                            target_cloud, normals, s.threads),
                           s.judge.noise, s.judge.spacing);
  if (s.covariance) {
    result.covariance = pose_covariance(pairs(), {s.method, s.kernel, kernel_scale}, result.hessian,
                                        result.degenerate_directions, diagonal, s.threads);
    const Vector6d left = se3_log(to_world * pending * to_world.inverse());  // the update not made
    if (measures_model_error(source, target, s) &&
        result.stop_reason != StopReason::kTooFewCorrespondences) {
      const IcpStep model =
          solve_step(pairs(), {IcpMethod::kSymmetric, s.kernel, kernel_scale}, s.threads);
      if (model.solvable) {  // the two stationary points, each a Gauss-Newton step away
        result.model_error = se3_log(to_world * model.delta * to_world.inverse()) - left;
        result.covariance.noalias() += result.model_error * result.model_error.transpose();
      }
    }
    // What the run did not reach is part of its error too (after measuring it against the rest).
    result.pending_sigmas = mahalanobis(left, result.covariance);
    result.covariance.noalias() += left * left.transpose();
  }
  result.fitness = source.empty() ? 0.0
                                  : static_cast<double>(result.correspondences) /
                                        static_cast<double>(source.size());
  result.converged = is_convergence(result.stop_reason);
  return result;
}

void check_run(const PointCloud& source, const IcpSettings& s) {
  if (s.rejection.kind == RejectionRule::Kind::kAuto)
    throw std::invalid_argument("icp: rejection 'auto' is refine()'s schedule, not one ICP run");
  if (needs_source_normals(s.method) && !source.has_normals())
    throw std::invalid_argument(std::string("icp: ") + to_string(s.method) +
                                " needs source normals");
}

}  // namespace

IcpResult icp(const PointCloud& source, const PointCloud& target, const KdTree& tree,
              const Eigen::Isometry3d& init, const IcpSettings& s) {
  check_run(source, s);
  if (reads_target_normals(s) && !target.has_normals())
    throw std::invalid_argument(
        std::string("icp: ") + to_string(s.method) +
        (s.method == IcpMethod::kPointToPoint ? " onto tangent planes" : "") +
        " needs target normals");
  if (tree.size() != target.size())
    throw std::invalid_argument("icp: the kd-tree does not index the target");
  return run_icp(source, {&target, &tree, nullptr, nullptr}, init, s);
}

IcpResult icp(const PointCloud& source, NormalCache& target, const Eigen::Isometry3d& init,
              const IcpSettings& s) {
  check_run(source, s);
  return run_icp(source, {&target.cloud(), &target.tree(), &target, nullptr}, init, s);
}

IcpResult icp(const PointCloud& source, const MeshIndex& target, const Eigen::Isometry3d& init,
              const IcpSettings& s) {
  check_run(source, s);
  return run_icp(source, {nullptr, nullptr, nullptr, &target}, init, s);
}

}  // namespace align3d
