#include "align3d/icp/icp.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "align3d/icp/degeneracy.hpp"
#include "align3d/icp/factors.hpp"
#include "align3d/kabsch.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

// Nearest target point for each transformed source point (kNone when beyond the search bound).
struct Correspondences {
  std::vector<std::size_t> target;
  std::vector<double> distance;  // true distance
};

// From the second iteration on, the previous partner bounds each search: the nearest point is at
// most as far as it, so the result is the same exact nearest neighbour, found with far less
// backtracking.
void find_correspondences(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                          const KdTree& tree, const Eigen::Isometry3d& T, double bound, int threads,
                          Correspondences& out) {
  const std::size_t n = source.size();
  if (out.target.size() != n) out.target.assign(n, kNone);
  out.distance.resize(n);
  const double sq_bound =
      std::isfinite(bound) ? bound * bound * (1 + 1e-12) : std::numeric_limits<double>::infinity();
  parallel_for(n, threads, [&](std::size_t i) {
    const Eigen::Vector3d p = T * source[i];
    double sq_limit = sq_bound;
    if (out.target[i] != kNone)
      sq_limit = std::min(
          sq_limit, (p - target.positions[out.target[i]]).squaredNorm() * (1 + 1e-12) + 1e-300);
    Neighbor nb;
    if (tree.nearest(p, nb, sq_limit)) {
      out.target[i] = nb.index;
      out.distance[i] = std::sqrt(nb.sq_distance);
    } else {
      out.target[i] = kNone;
      out.distance[i] = std::numeric_limits<double>::infinity();
    }
  });
}

double threshold_for(const RejectionRule& rule, const Correspondences& c) {
  thread_local std::vector<double> found;
  found.clear();
  if (rule.kind != RejectionRule::Kind::kMedian) return rejection_threshold(rule, found);
  for (double d : c.distance)
    if (std::isfinite(d)) found.push_back(d);
  return rejection_threshold(rule, found);
}

struct Step {
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();  // in the centred frame
  double rms = 0;
  std::size_t kept = 0;
  Matrix6d hessian = Matrix6d::Zero();
  std::vector<WeakDirection> weak;
  bool solvable = false;
};

// Sums over the kept pairs (distance <= threshold), in coordinates about `centre`: `add(sums, p, q,
// target index, distance)` folds one pair into the metric's sums and returns its squared residual.
template <class Sums>
struct PairTotals {
  Sums sums;
  double sq_error = 0;
  std::size_t kept = 0;
};

template <class Sums, class Add>
PairTotals<Sums> reduce_pairs(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                              const Correspondences& c, const Eigen::Isometry3d& T,
                              const Eigen::Vector3d& centre, double threshold, int threads,
                              Add add) {
  return parallel_reduce(
      source.size(), threads, PairTotals<Sums>{},
      [&](PairTotals<Sums>& a, std::size_t i) {
        if (c.target[i] == kNone || c.distance[i] > threshold) return;
        const Eigen::Vector3d p = T * source[i] - centre;
        const Eigen::Vector3d q = target.positions[c.target[i]] - centre;
        a.sq_error += add(a.sums, p, q, c.target[i], c.distance[i]);
        ++a.kept;
      },
      [](PairTotals<Sums>& a, const PairTotals<Sums>& b) {
        a.sums += b.sums;
        a.sq_error += b.sq_error;
        a.kept += b.kept;
      });
}

// Per candidate direction of the system, the part of its eigenvalue held by pairs aligned with it
// (degeneracy.hpp).
struct AlignedSupport {
  Vector6d sum = Vector6d::Zero();
  AlignedSupport& operator+=(const AlignedSupport& o) {
    sum += o.sum;
    return *this;
  }
};

// Evaluates the kept pairs at pose T and solves for the update (in coordinates about `centre`).
Step solve_step(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                const std::vector<Eigen::Vector3d>& normals, const Correspondences& c,
                const Eigen::Isometry3d& T, const Eigen::Vector3d& centre, double threshold,
                const IcpSettings& s) {
  Step step;
  auto weight = [&](double d) { return geman_mcclure_weight(d, s.robust_scale); };
  auto finish = [&](const auto& totals, std::size_t min_pairs) {
    step.kept = totals.kept;
    step.rms = totals.kept ? std::sqrt(totals.sq_error / static_cast<double>(totals.kept)) : 0.0;
    step.solvable = totals.kept >= min_pairs;
  };
  if (s.method == IcpMethod::kPointToPoint) {
    const auto totals =
        reduce_pairs<KabschAccumulator>(source, target, c, T, centre, threshold, s.threads,
                                        [&](KabschAccumulator& sums, const Eigen::Vector3d& p,
                                            const Eigen::Vector3d& q, std::size_t, double d) {
                                          sums.add(p, q, weight(d));
                                          return d * d;
                                        });
    finish(totals, 3);
    if (step.solvable) step.delta = solve_kabsch(totals.sums);
    return step;
  }
  const auto totals = reduce_pairs<LinearSystem6>(
      source, target, c, T, centre, threshold, s.threads,
      [&](LinearSystem6& sums, const Eigen::Vector3d& p, const Eigen::Vector3d& q, std::size_t j,
          double) {
        const Eigen::Vector3d& normal = normals[j];
        const double r = PointToPlaneFactor::residual(p, q, normal);
        sums.add(PointToPlaneFactor::jacobian(p, normal), r, weight(std::abs(r)));
        return r * r;
      });
  finish(totals, 6);
  step.hessian = totals.sums.H;
  if (step.solvable) {
    // Solve H·x = −b in the directions the data constrains; the pose does not drift along the
    // others (degeneracy.hpp).
    const SystemAnalysis a = analyse_system(totals.sums.H);
    Vector6d aligned = Vector6d::Zero();
    if (a.usable && a.candidate(0)) {
      const auto support = reduce_pairs<AlignedSupport>(
          source, target, c, T, centre, threshold, s.threads,
          [&](AlignedSupport& sums, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
              std::size_t j, double) {
            const Eigen::Vector3d& normal = normals[j];
            const double r = PointToPlaneFactor::residual(p, q, normal);
            const Vector6d J = a.scale.cwiseProduct(PointToPlaneFactor::jacobian(p, normal));
            const double w = weight(std::abs(r));
            for (int i = 0; i < 6 && a.candidate(i); ++i) {
              const double d = J.dot(a.vectors.col(i));
              if (d * d >= kAlignedCosine * kAlignedCosine * J.squaredNorm())
                sums.sum(i) += w * d * d;
            }
            return 0.0;
          });
      aligned = support.sums.sum;
    }
    ConstrainedSolve solved = solve_constrained(a, -totals.sums.b, aligned);
    step.weak = std::move(solved.weak);
    const Vector6d x = solved.x;
    step.solvable = x.allFinite();
    // The small-angle model is re-orthonormalised through the exponential map (se3.hpp).
    if (step.solvable) step.delta = se3_exp(x);
  }
  return step;
}

// The convergence criteria (termination.hpp), checked on the pass just evaluated (the last entry of
// `history`, whose update is `delta`); true, with the reason, when the loop should stop there.
bool stop_before_update(const std::vector<IterationRecord>& history, double previous_rms,
                        const Eigen::Isometry3d& delta, double diagonal,
                        const TerminationSettings& term, StopReason& reason) {
  const IterationRecord& now = history.back();
  // A state seen in the last 4 passes again: the loop is periodic.
  const std::size_t seen = history.size() - 1;
  for (std::size_t back = 2; back <= 4 && back <= seen; ++back) {
    const IterationRecord& then = history[seen - back];
    if (then.kept == now.kept && std::abs(then.rms - now.rms) <= 1e-12 * now.rms) {
      reason = StopReason::kCycle;
      return true;
    }
  }
  const double rms_tolerance = term.rms_change * (term.rms_change_relative ? previous_rms : 1.0);
  if (std::abs(now.rms - previous_rms) < rms_tolerance) {
    reason = StopReason::kRmsChange;
    return true;
  }
  if (term.rotation > 0 && rotation_angle(delta.linear()) < term.rotation &&
      delta.translation().norm() < term.translation * diagonal) {
    reason = StopReason::kTransformChange;
    return true;
  }
  return false;
}

// The target points of the kept pairs whose normal `cache` does not know yet (in source order,
// with repeats).
std::vector<std::uint32_t> missing_normals(const Correspondences& c, double threshold,
                                           const NormalCache& cache, int threads) {
  return parallel_reduce(
      c.target.size(), threads, std::vector<std::uint32_t>{},
      [&](std::vector<std::uint32_t>& missing, std::size_t i) {
        const std::size_t j = c.target[i];
        if (j != kNone && c.distance[i] <= threshold && !cache.known(j))
          missing.push_back(static_cast<std::uint32_t>(j));
      },
      [](std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
        a.insert(a.end(), b.begin(), b.end());
      });
}

// The loop; point-to-plane takes its normals from `cache` when there is one (estimating those the
// kept pairs need first), from target.normals otherwise.
IcpResult run_icp(const PointCloud& source, const PointCloud& target, const KdTree& tree,
                  const Eigen::Isometry3d& init, const IcpSettings& s, NormalCache* cache) {
  const std::vector<Eigen::Vector3d>& normals = cache ? cache->normals() : target.normals;
  const Eigen::Vector3d centre = centroid(target);
  const Eigen::Translation3d to_world(centre);
  const double diagonal = bounding_box_diagonal(target);
  const TerminationSettings& term = s.termination;
  const std::size_t min_pairs = s.method == IcpMethod::kPointToPoint ? 3 : 6;

  // The source in spatial order (spatial_order, kdtree.hpp): consecutive queries and their target
  // partners are close in space, so the search and the sums stay in cache on large clouds.
  std::vector<Eigen::Vector3d> moving(source.size());
  {
    const std::vector<std::uint32_t> order = spatial_order(source.positions);
    for (std::size_t k = 0; k < moving.size(); ++k) moving[k] = source.positions[order[k]];
  }

  // Each pass evaluates the pose reached so far and, unless a criterion stops the loop there,
  // applies the update it solved for. The pose returned is the last one evaluated, so its RMS,
  // pairs and system are exact without a separate final pass: n updates cost n + 1 searches.
  IcpResult result;
  result.T_target_source = init;
  Correspondences c;
  double previous_rms = std::numeric_limits<double>::quiet_NaN();
  for (;;) {
    find_correspondences(moving, target, tree, result.T_target_source, s.rejection.search_bound(),
                         s.threads, c);
    const double threshold = threshold_for(s.rejection, c);
    if (cache && s.method == IcpMethod::kPointToPlane)
      cache->require(missing_normals(c, threshold, *cache, s.threads));
    Step step =
        solve_step(moving, target, normals, c, result.T_target_source, centre, threshold, s);
    result.history.push_back({step.rms, step.kept, threshold});
    result.rms = step.rms;
    result.correspondences = step.kept;
    result.hessian = step.hessian;
    result.degenerate_directions = std::move(step.weak);
    if (!step.solvable || step.kept < min_pairs) {
      result.stop_reason = StopReason::kTooFewCorrespondences;
      break;
    }
    if (stop_before_update(result.history, previous_rms, step.delta, diagonal, term,
                           result.stop_reason))
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
  result.fitness = source.empty() ? 0.0
                                  : static_cast<double>(result.correspondences) /
                                        static_cast<double>(source.size());
  result.converged = is_convergence(result.stop_reason);
  return result;
}

}  // namespace

IcpResult icp(const PointCloud& source, const PointCloud& target, const KdTree& tree,
              const Eigen::Isometry3d& init, const IcpSettings& s) {
  if (s.method == IcpMethod::kPointToPlane && !target.has_normals())
    throw std::invalid_argument("icp: point-to-plane needs target normals");
  if (tree.size() != target.size())
    throw std::invalid_argument("icp: the kd-tree does not index the target");
  return run_icp(source, target, tree, init, s, nullptr);
}

IcpResult icp(const PointCloud& source, NormalCache& target, const Eigen::Isometry3d& init,
              const IcpSettings& s) {
  return run_icp(source, target.cloud(), target.tree(), init, s, &target);
}

}  // namespace align3d
