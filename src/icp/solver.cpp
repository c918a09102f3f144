#include "align3d/icp/solver.hpp"

#include <cmath>

#include "align3d/icp/kernels.hpp"
#include "align3d/kabsch.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

// Sums over the kept pairs (distance <= threshold), in coordinates about `centre`: `add(sums, p, q,
// n, distance)` folds one pair into the metric's sums and returns its squared residual; n is the
// partner's normal (null when `normals` is empty and the target is not a surface).
template <class Sums>
struct PairTotals {
  Sums sums;
  double sq_error = 0;
  std::size_t kept = 0;
};

template <class Sums, class Add>
PairTotals<Sums> reduce_pairs(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                              const std::vector<Eigen::Vector3d>& normals, const Correspondences& c,
                              const Eigen::Isometry3d& T, const Eigen::Vector3d& centre,
                              double threshold, int threads, Add add) {
  const bool surface = !c.point.empty();  // a mesh target: the partners themselves are given
  return parallel_reduce(
      source.size(), threads, PairTotals<Sums>{},
      [&](PairTotals<Sums>& a, std::size_t i) {
        if (c.target[i] == kNoPartner || c.distance[i] > threshold) return;
        const std::size_t j = c.target[i];
        const Eigen::Vector3d p = T * source[i] - centre;
        const Eigen::Vector3d q = (surface ? c.point[i] : target.positions[j]) - centre;
        const Eigen::Vector3d* n = surface ? &c.normal[i] : normals.empty() ? nullptr : &normals[j];
        a.sq_error += add(a.sums, p, q, n, c.distance[i]);
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

}  // namespace

IcpStep solve_step(const std::vector<Eigen::Vector3d>& source, const PointCloud& target,
                   const std::vector<Eigen::Vector3d>& normals, const Correspondences& c,
                   const Eigen::Isometry3d& T, const Eigen::Vector3d& centre, double threshold,
                   IcpMethod method, double robust_scale, int threads) {
  IcpStep step;
  auto weight = [&](double d) { return geman_mcclure_weight(d, robust_scale); };
  auto finish = [&](const auto& totals, std::size_t min_pairs) {
    step.kept = totals.kept;
    step.rms = totals.kept ? std::sqrt(totals.sq_error / static_cast<double>(totals.kept)) : 0.0;
    step.solvable = totals.kept >= min_pairs;
  };
  if (method == IcpMethod::kPointToPoint) {
    const auto totals = reduce_pairs<KabschAccumulator>(
        source, target, normals, c, T, centre, threshold, threads,
        [&](KabschAccumulator& sums, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
            const Eigen::Vector3d*, double d) {
          sums.add(p, q, weight(d));
          return d * d;
        });
    finish(totals, 3);
    if (step.solvable) step.delta = solve_kabsch(totals.sums);
    return step;
  }
  const auto totals = reduce_pairs<LinearSystem6>(
      source, target, normals, c, T, centre, threshold, threads,
      [&](LinearSystem6& sums, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
          const Eigen::Vector3d* n, double) {
        const Eigen::Vector3d& normal = *n;
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
          source, target, normals, c, T, centre, threshold, threads,
          [&](AlignedSupport& sums, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
              const Eigen::Vector3d* n, double) {
            const Eigen::Vector3d& normal = *n;
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

}  // namespace align3d
