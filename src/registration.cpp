#include "align3d/registration.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "align3d/error.hpp"

namespace align3d {
namespace {

// The `auto` schedule's constants (registration.hpp explains the schedule). All distances are in
// units of L (bounding-box diagonal) or s (point spacing), so the schedule is unit-free.
constexpr double kStartFraction = 1.0 / 8.0;  // τ0 = L/8
constexpr double kShrink = 0.5;               // τ ← τ/2 per stage
constexpr double kKernelFraction = 0.5;       // Geman-McClure scale = τ/2
constexpr double kFinalSpacings = 3.0;        // final τ >= 3 s
constexpr double kFinalSigmas = 4.0;          // final τ >= 4 σ̂
constexpr int kCoarseIterations = 30;
constexpr int kMaxStages = 12;  // L/8 · 2^-12 is far below any useful spacing
// Coarse-to-fine in resolution too: the coarse stages see at most this many source points (every
// m-th along the Morton curve, an even thinning), the final stage all of them.
constexpr std::size_t kCoarsePoints = 50000;

void append(RegistrationResult& out, const IcpResult& r, const IcpSettings& s) {
  StageRecord stage;
  stage.metric = to_string(s.method);
  stage.max_distance = s.rejection.kind == RejectionRule::Kind::kDistance
                           ? s.rejection.distance
                           : std::numeric_limits<double>::infinity();
  stage.first_iteration = static_cast<int>(out.history.size());
  stage.iterations = r.iterations;
  out.stages.push_back(stage);
  out.history.insert(out.history.end(), r.history.begin(), r.history.end());
  out.total_iterations += r.iterations;
}

PointCloud reordered(const PointCloud& cloud, const std::vector<std::uint32_t>& order) {
  PointCloud out;
  out.positions.reserve(order.size());
  for (std::uint32_t i : order) out.positions.push_back(cloud.positions[i]);
  if (cloud.has_normals()) {
    out.normals.reserve(order.size());
    for (std::uint32_t i : order) out.normals.push_back(cloud.normals[i]);
  }
  return out;
}

}  // namespace

double point_spacing(const PointCloud& cloud, const KdTree& tree, std::size_t samples) {
  const std::size_t n = cloud.size();
  if (n < 2) return 0.0;
  const std::size_t step = std::max<std::size_t>(1, n / std::max<std::size_t>(1, samples));
  std::vector<double> d;
  std::vector<Neighbor> nb;
  for (std::size_t i = 0; i < n; i += step) {
    tree.knn(cloud.positions[i], 2, nb);
    for (const auto& m : nb)
      if (m.index != i && m.sq_distance > 0) {
        d.push_back(std::sqrt(m.sq_distance));
        break;
      }
  }
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

void check_registrable(const PointCloud& cloud, const std::string& what) {
  if (cloud.size() < 6)
    throw DataError(what + ": " + std::to_string(cloud.size()) +
                    " points; registration needs at least 6");
  const Eigen::Vector3d c = centroid(cloud);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : cloud.positions) cov.noalias() += (p - c) * (p - c).transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();
  if (!(ev(2) > 0)) throw DataError(what + ": all points are at one spot");
  if (ev(1) <= 1e-12 * ev(2)) throw DataError(what + ": all points lie on one line");
}

RegistrationResult register_clouds(const PointCloud& source, const PointCloud& target_in,
                                   const Eigen::Isometry3d& init,
                                   const RegistrationSettings& settings) {
  check_registrable(source, "source");
  check_registrable(target_in, "target");
  RegistrationResult out;

  // A copy in spatial order (normals may be added): the search, the normals and the ICP sums then
  // touch memory in order. The result, a transform, does not depend on the order of the points.
  PointCloud target = reordered(target_in, spatial_order(target_in.positions));
  const KdTree tree(target.positions, settings.threads);
  const bool need_normals =
      settings.method == IcpMethod::kPointToPlane || !settings.rejection.has_value();
  // Missing target normals are estimated only where pairs need them (NormalCache, normals.hpp).
  std::optional<NormalCache> normals;
  if (need_normals && !target.has_normals()) {
    if (target.size() < static_cast<std::size_t>(settings.normals.k))
      throw DataError(
          "target: " + std::to_string(target.size()) + " points; point-to-plane needs " +
          "at least the normal neighbourhood k = " + std::to_string(settings.normals.k));
    NormalSettings ns = settings.normals;
    ns.threads = settings.threads;
    normals.emplace(target, tree, ns);
  }
  auto run = [&](const PointCloud& from, const Eigen::Isometry3d& T, const IcpSettings& s) {
    IcpResult r = normals ? icp(from, *normals, T, s) : icp(from, target, tree, T, s);
    if (normals) {
      out.estimated_normals = normals->estimated();
      out.undefined_normals = normals->undefined();
    }
    return r;
  };

  IcpSettings last;
  last.method = settings.method;
  last.threads = settings.threads;
  last.termination.max_iterations = settings.max_iterations;
  last.termination.rms_change = settings.tolerance;
  last.termination.rms_change_relative = settings.tolerance_relative;
  if (!settings.transform_criterion) last.termination.rotation = 0;

  if (settings.rejection) {
    last.rejection = *settings.rejection;
    out.icp = run(source, init, last);
    append(out, out.icp, last);
    return out;
  }

  const double diagonal = bounding_box_diagonal(target);
  // A cloud of duplicated points has no measurable spacing; fall back to a fine fraction of L.
  double spacing = point_spacing(target, tree);
  if (!(spacing > 0)) spacing = 1e-4 * diagonal;
  out.point_spacing = spacing;
  const double floor = kFinalSpacings * spacing;

  PointCloud thinned;
  if (source.size() > kCoarsePoints) {
    const std::vector<std::uint32_t> order = spatial_order(source.positions);
    const std::size_t step = (source.size() + kCoarsePoints - 1) / kCoarsePoints;
    for (std::size_t k = 0; k < order.size(); k += step)
      thinned.positions.push_back(source.positions[order[k]]);
  }
  const PointCloud& coarse_source = thinned.empty() ? source : thinned;

  Eigen::Isometry3d T = init;
  IcpSettings coarse = last;
  coarse.method = IcpMethod::kPointToPlane;
  coarse.termination.max_iterations = kCoarseIterations;
  coarse.termination.rms_change = 1e-4;
  coarse.termination.rms_change_relative = true;
  coarse.termination.rotation = 1e-5;
  coarse.termination.translation = 1e-6;
  double sigma = 0;
  double tau = kStartFraction * diagonal;
  for (int stage = 0; stage < kMaxStages && tau > floor; ++stage, tau *= kShrink) {
    coarse.rejection = RejectionRule::max_distance(tau);
    coarse.robust_scale = kKernelFraction * tau;
    const IcpResult r = run(coarse_source, T, coarse);
    append(out, r, coarse);
    if (r.stop_reason == StopReason::kTooFewCorrespondences) break;
    T = r.T_target_source;
    sigma = r.rms;  // point-to-plane RMS: the noise along the normal once settled
  }
  tau = std::max(floor, kFinalSigmas * sigma);
  last.rejection = RejectionRule::max_distance(tau);
  last.robust_scale = kKernelFraction * tau;
  out.icp = run(source, T, last);
  append(out, out.icp, last);
  return out;
}

}  // namespace align3d
