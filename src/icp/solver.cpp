#include "align3d/icp/solver.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "align3d/kabsch.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

// One kept pair in coordinates about the centre: the moved source point p, its partner q, the
// partner's unit normal n (zero when there is none), the source normal m turned by T (zero when
// the source has none; for the symmetric cost flipped to face n's side), and their distance.
struct Pair {
  Eigen::Vector3d p, q, n, m;
  double distance;
  std::uint64_t partner;  // the target point (a mesh target: the source point; no two share)
};

// GICP and symmetric pair two surfaces by their normals: a pair whose normals differ by more than
// 60° (kCompatibleCosine) joins different surfaces (a side face to the floor at a coarse stage)
// and is left out of the sums (Godin, Rioux and Baribeau 1994's compatibility test). Without it,
// on the chapter's scene (a conveyor plane under the part) both drifted off the truth at the
// coarse stages (symmetric 64° from the true pose at τ = L/8).
constexpr double kCompatibleCosine = 0.2;
bool compatible(IcpMethod method, const Pair& pair) {
  return !needs_source_normals(method) || pair.m.dot(pair.n) >= kCompatibleCosine;
}

// The pair's distance from the partner's tangent plane.
double plane_distance(const Pair& pair) { return (pair.p - pair.q).dot(pair.n); }

// Point-to-point onto a point cloud's surface (IcpSettings::tangent_planes): the partner moves to
// the source point's foot on its tangent plane (none without a normal).
bool on_planes(const StepInput& in, IcpMethod method) {
  return method == IcpMethod::kPointToPoint && in.tangent_planes && in.pairs.point.empty();
}
void onto_tangent_plane(Pair& pair) {
  if (pair.n.squaredNorm() == 0) return;
  pair.q += (pair.p - pair.q) - plane_distance(pair) * pair.n;
  pair.distance = (pair.p - pair.q).norm();
}

template <class Sums>
struct PairTotals {
  Sums sums;
  double sq_error = 0;
  std::size_t kept = 0;
  std::size_t aside = 0;  // of the kept, those set aside (Correspondences::aside)
  std::size_t used() const { return kept - aside; }  // the pairs in `sums`
};

// Folds every kept pair (within the threshold, and compatible for `method`) into Sums:
// `add(sums, pair)` returns the pair's squared residual. A pair set aside counts in the squared
// error and the kept pairs only (added to sums thrown away).
template <class Sums, class Add>
PairTotals<Sums> reduce_pairs(const StepInput& in, IcpMethod method, int threads, Add add) {
  const Correspondences& c = in.pairs;
  const bool surface = !c.point.empty();  // a mesh target: the partners themselves are given
  const bool planes = on_planes(in, method);
  const Eigen::Matrix3d R = in.T.linear();
  return parallel_reduce(
      in.source.size(), threads, PairTotals<Sums>{},
      [&](PairTotals<Sums>& a, std::size_t i) {
        if (!is_kept(c, i, in.threshold)) return;
        const std::size_t j = c.target[i];
        Pair pair;
        pair.p = in.T * in.source[i] - in.centre;
        pair.q = (surface ? c.point[i] : in.target.positions[j]) - in.centre;
        pair.n = surface              ? c.normal[i]
                 : in.normals.empty() ? Eigen::Vector3d::Zero()
                                      : in.normals[j];
        pair.m = in.source_normals.empty() ? Eigen::Vector3d::Zero()
                                           : Eigen::Vector3d(R * in.source_normals[i]);
        if (pair.m.dot(pair.n) < 0) pair.m = -pair.m;
        pair.distance = c.distance[i];
        if (planes) onto_tangent_plane(pair);
        pair.partner = surface ? i : j;
        if (!compatible(method, pair)) return;
        ++a.kept;
        if (!c.aside.empty() && c.aside[i]) {
          Sums unused;
          a.sq_error += add(unused, pair);
          ++a.aside;
          return;
        }
        a.sq_error += add(a.sums, pair);
      },
      [](PairTotals<Sums>& a, const PairTotals<Sums>& b) {
        a.sums += b.sums;
        a.sq_error += b.sq_error;
        a.kept += b.kept;
        a.aside += b.aside;
      });
}

// The residual the kernel weighs (solver.hpp, StepCost; onto a tangent plane, the distance to it).
double kernel_residual(IcpMethod method, const Pair& pair) {
  return method == IcpMethod::kPointToPoint ? pair.distance : std::abs(plane_distance(pair));
}

// The symmetric cost's normal n_p + n_q (SymmetricFactor).
Eigen::Vector3d symmetric_normal(const Pair& pair) { return pair.m + pair.n; }

// A scalar cost's residual and Jacobian (point-to-plane, symmetric).
void scalar_factor(IcpMethod method, const Pair& pair, double& r, Vector6d& J) {
  if (method == IcpMethod::kSymmetric) {
    const Eigen::Vector3d n = symmetric_normal(pair);
    r = SymmetricFactor::residual(pair.p, pair.q, n);
    J = SymmetricFactor::jacobian(pair.p, pair.q, n);
  } else {
    r = PointToPlaneFactor::residual(pair.p, pair.q, pair.n);
    J = PointToPlaneFactor::jacobian(pair.p, pair.n);
  }
}

// kernel_tuning × 1.4826 × the median kernel residual of the kept pairs (0 when none is kept).
double noise_scale(const StepInput& in, const StepCost& cost, int threads) {
  struct Residuals {
    std::vector<double> r;
    Residuals& operator+=(const Residuals& o) {
      r.insert(r.end(), o.r.begin(), o.r.end());
      return *this;
    }
  };
  auto totals =
      reduce_pairs<Residuals>(in, cost.method, threads, [&](Residuals& s, const Pair& pair) {
        s.r.push_back(kernel_residual(cost.method, pair));
        return 0.0;
      });
  std::vector<double>& r = totals.sums.r;
  if (r.empty()) return 0;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return kernel_tuning(cost.kernel) * 1.4826 * r[r.size() / 2];
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

// Σ w (J_s·v_i)² over the pairs aligned with candidate direction i (for GICP, of each pair's
// plane row).
Vector6d aligned_support(const StepInput& in, const StepCost& cost, const SystemAnalysis& a,
                         int threads) {
  const auto support = reduce_pairs<AlignedSupport>(
      in, cost.method, threads, [&](AlignedSupport& sums, const Pair& pair) {
        double r;
        Vector6d J;
        if (cost.method == IcpMethod::kGicp) {
          // GICP's strongest row: the plane constraint along n, weighed by nᵀ M n.
          scalar_factor(IcpMethod::kPointToPlane, pair, r, J);
          J *= std::sqrt(pair.n.dot(GicpFactor::weight(pair.m, pair.n) * pair.n));
        } else {
          scalar_factor(cost.method, pair, r, J);
        }
        J = a.scale.cwiseProduct(J);
        const double w =
            kernel_weight(cost.kernel, kernel_residual(cost.method, pair), cost.kernel_scale);
        for (int i = 0; i < 6 && a.candidate(i); ++i) {
          const double d = J.dot(a.vectors.col(i));
          if (d * d >= kAlignedCosine * kAlignedCosine * J.squaredNorm()) sums.sum(i) += w * d * d;
        }
        return 0.0;
      });
  return support.sums.sum;
}

// The Gauss-Newton system of the point-to-plane, symmetric or GICP cost.
PairTotals<LinearSystem6> normal_equations(const StepInput& in, const StepCost& cost, int threads) {
  return reduce_pairs<LinearSystem6>(
      in, cost.method, threads, [&](LinearSystem6& sums, const Pair& pair) {
        const double w =
            kernel_weight(cost.kernel, kernel_residual(cost.method, pair), cost.kernel_scale);
        if (cost.method == IcpMethod::kGicp) {
          const Eigen::Vector3d e = pair.p - pair.q;
          const Eigen::Matrix3d M = GicpFactor::weight(pair.m, pair.n);
          sums.add(GicpFactor::jacobian(pair.p), e, M, w);
          return plane_distance(pair) * plane_distance(pair);
        }
        double r;
        Vector6d J;
        scalar_factor(cost.method, pair, r, J);
        sums.add(J, r, w);
        if (cost.method == IcpMethod::kPointToPlane) return r * r;
        const double n = symmetric_normal(pair).norm();  // r along the mean normal, in data units
        return n > 0 ? r * r / (n * n) : 0.0;
      });
}

}  // namespace

IcpStep solve_step(const StepInput& in, const StepCost& given, int threads) {
  IcpStep step;
  StepCost cost = given;
  if (cost.kernel != RobustKernel::kNone && !(cost.kernel_scale > 0))
    cost.kernel_scale = noise_scale(in, cost, threads);
  step.kernel_scale = cost.kernel == RobustKernel::kNone ? 0.0 : cost.kernel_scale;
  auto finish = [&](const auto& totals) {
    step.kept = totals.kept;
    step.rms = totals.kept ? std::sqrt(totals.sq_error / static_cast<double>(totals.kept)) : 0.0;
    step.solvable = totals.used() >= min_pairs(cost.method);
  };
  if (cost.method == IcpMethod::kPointToPoint) {
    const auto totals = reduce_pairs<KabschAccumulator>(
        in, cost.method, threads, [&](KabschAccumulator& sums, const Pair& p) {
          sums.add(p.p, p.q, kernel_weight(cost.kernel, p.distance, cost.kernel_scale));
          return p.distance * p.distance;
        });
    finish(totals);
    if (step.solvable) step.delta = solve_kabsch(totals.sums);
    return step;
  }
  const auto totals = normal_equations(in, cost, threads);
  finish(totals);
  step.hessian = totals.sums.H;
  if (!step.solvable) return step;
  // Solve H·x = −b in the directions the data constrains; the pose does not drift along the others
  // (degeneracy.hpp).
  const SystemAnalysis a = analyse_system(totals.sums.H);
  Vector6d aligned = Vector6d::Zero();
  if (a.usable && a.candidate(0)) aligned = aligned_support(in, cost, a, threads);
  ConstrainedSolve solved = solve_constrained(a, -totals.sums.b, aligned);
  step.weak = std::move(solved.weak);
  const Vector6d x = solved.x;
  step.solvable = x.allFinite();
  // The small-angle model is re-orthonormalised through the exponential map (se3.hpp); the
  // symmetric unknowns through their own parametrisation (factors.hpp).
  if (step.solvable)
    step.delta = cost.method == IcpMethod::kSymmetric ? symmetric_update(x) : se3_exp(x);
  return step;
}

namespace {

// The bread Σ ψ'·JᵀMJ, and the meat Σ over partners of (Σ g)(Σ g)ᵀ, g = w·JᵀM e a pair's gradient
// in the method's unknowns about the centre: the gradients of pairs sharing a target point are
// summed first (their residuals share that point's noise: cluster-robust). A pair whose partner no
// other pair has adds g gᵀ at once; the others' gradients are kept with their partner and summed
// by partner after the reduction (clustered_meat). Hand-written: keeping every gradient and
// sorting them all cost 4 ms a registration of two 40 000-point scans, on the calling thread.
struct SandwichSums {
  Matrix6d H = Matrix6d::Zero();
  Matrix6d G = Matrix6d::Zero();
  std::vector<std::pair<std::uint64_t, Vector6d>> shared;
  SandwichSums& operator+=(const SandwichSums& o) {
    H += o.H;
    G += o.G;
    shared.insert(shared.end(), o.shared.begin(), o.shared.end());
    return *this;
  }
};

// The kept pairs' partners that more than one pair has (1), of a cloud target: the others' (0)
// gradients need no clustering. Empty for a mesh target (every partner is its own pair).
std::vector<unsigned char> shared_partners(const StepInput& in) {
  const Correspondences& c = in.pairs;
  std::vector<unsigned char> seen;
  if (!c.point.empty()) return seen;
  seen.assign(in.target.size(), 0);  // 0 none, 1 one pair, 2 more
  for (std::size_t i = 0; i < c.target.size(); ++i)
    if (is_kept(c, i, in.threshold) && (c.aside.empty() || !c.aside[i]))
      seen[c.target[i]] = static_cast<unsigned char>(std::min(2, seen[c.target[i]] + 1));
  for (unsigned char& s : seen) s = s == 2;
  return seen;
}

// G plus Σ over the shared partners of (Σ g)(Σ g)ᵀ.
Matrix6d clustered_meat(SandwichSums& sums) {
  std::vector<std::pair<std::uint64_t, Vector6d>>& g = sums.shared;
  std::stable_sort(g.begin(), g.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  Matrix6d G = sums.G;
  for (std::size_t i = 0; i < g.size();) {
    Vector6d sum = Vector6d::Zero();
    std::size_t j = i;
    for (; j < g.size() && g[j].first == g[i].first; ++j) sum += g[j].second;
    G.noalias() += sum * sum.transpose();
    i = j;
  }
  return G;
}

}  // namespace

Matrix6d pose_covariance(const StepInput& in, const StepCost& cost, const Matrix6d& hessian,
                         const std::vector<WeakDirection>& weak, double free_sigma, int threads) {
  // Onto tangent planes, point-to-point's stationary point is point-to-plane's: Σ Jᵀ(p − q') = 0
  // with p − q' along n is point-to-plane's normal equations, the kernel on the same residual.
  const IcpMethod factor = on_planes(in, cost.method) ? IcpMethod::kPointToPlane : cost.method;
  const std::vector<unsigned char> shared = shared_partners(in);
  auto gradient = [&](SandwichSums& s, std::uint64_t partner, const Vector6d& g) {
    if (!shared.empty() && shared[partner])
      s.shared.emplace_back(partner, g);
    else
      s.G.noalias() += g * g.transpose();
  };
  auto totals =
      reduce_pairs<SandwichSums>(in, cost.method, threads, [&](SandwichSums& s, const Pair& pair) {
        const double d = kernel_residual(cost.method, pair);
        const double w = kernel_weight(cost.kernel, d, cost.kernel_scale);
        const double slope = kernel_slope(cost.kernel, d, cost.kernel_scale);
        if (factor == IcpMethod::kPointToPoint || factor == IcpMethod::kGicp) {
          const Eigen::Vector3d e = pair.p - pair.q;
          const Eigen::Matrix3d M = cost.method == IcpMethod::kGicp
                                        ? GicpFactor::weight(pair.m, pair.n)
                                        : Eigen::Matrix3d::Identity();
          const Eigen::Matrix<double, 6, 3> JtM = GicpFactor::jacobian(pair.p).transpose() * M;
          s.H.noalias() += slope * JtM * GicpFactor::jacobian(pair.p);
          gradient(s, pair.partner, w * JtM * e);
        } else {
          double r;
          Vector6d J;
          scalar_factor(factor, pair, r, J);
          s.H.noalias() += slope * J * J.transpose();
          gradient(s, pair.partner, (w * r) * J);
        }
        return 0.0;
      });
  if (totals.used() < min_pairs(cost.method)) return Matrix6d::Zero();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(totals.sums.H);
  const Vector6d values = eig.eigenvalues().cwiseMax(1e-12 * eig.eigenvalues().maxCoeff());
  const Matrix6d H_inv =
      eig.eigenvectors() * values.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  Matrix6d cov = H_inv * clustered_meat(totals.sums) * H_inv;
  // The directions the step left free: the data do not fix them (GICP's tangential terms would
  // otherwise claim the axial shift of a cylinder from the samplings' offsets).
  if (!weak.empty()) {
    const SystemAnalysis a = analyse_system(hessian);
    for (const WeakDirection& w : weak) {
      Vector6d y;
      y << w.rotation, w.translation;
      const Vector6d u = a.scale.cwiseProduct(y);
      cov.noalias() += free_sigma * free_sigma * u * u.transpose();
    }
  }
  // The symmetric unknowns (ã, t̃) near the optimum: the rotation turns by 2θ ≈ 2ã (factors.hpp).
  if (cost.method == IcpMethod::kSymmetric) {
    Vector6d d;
    d << 2, 2, 2, 1, 1, 1;
    cov = d.asDiagonal() * cov * d.asDiagonal();
  }
  // About the centre c to about the origin: v_origin = v_c + c × ω.
  Matrix6d A = Matrix6d::Identity();
  A.block<3, 3>(3, 0) = skew(in.centre);
  return A * cov * A.transpose();
}

}  // namespace align3d
