#include "stitch/views.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>

#include "align3d/normals.hpp"
#include "detail/parallel.hpp"

namespace align3d::detail {

namespace {

constexpr double kFacingCosine = 0.34;  // cos 70°: FreeSpacePoints::facing_only
// The least share of a scan's tested points a free-space share is taken of. The keyed flange's
// opposite views (12-view ring, 180° apart) see 7 of each other's points; one of them a little in
// front made 14 % at the true poses.
constexpr double kMinSeenShare = 0.02;

// prepare_scans keeps a frame's origin as its scan's sensor unless more than kMaxHiddenShare of
// the scan could not have been seen from there (hidden_share): lying behind the origin, or more
// than kHiddenSpacings spacings behind another point of the scan in its direction. Measured: the
// generated rings' and views' true origins 0.001-0.11; the Stanford dragon's scans, whose origin
// lies under the statuette, 0.25-0.51 (their estimated sensors 0.02-0.11).
constexpr double kMaxHiddenShare = 0.2;
constexpr double kHiddenSpacings = 3.0;
constexpr std::size_t kSensorSamples = 2000;
// free_space_slack. Seen from an estimated sensor, right poses of the Stanford dragon's neighbours
// put up to 2 % of a scan in front of what the other saw (the estimate is off by up to ~30°);
// from the true sensors of the generated sets, 0-0.6 %, and a wrong turn 1-2.3 %.
constexpr double kEstimatedSlack = 3.0;

}  // namespace

std::vector<ScanData> prepare_scans(const std::vector<PointCloud>& scans,
                                    const std::vector<std::optional<Eigen::Vector3d>>& viewpoints,
                                    int threads) {
  for (std::size_t k = 0; k < scans.size(); ++k)
    check_registrable(scans[k], "scan " + std::to_string(k));
  // The scans in parallel, one thread each, when there are enough of them to keep the threads
  // busy; else one after another, each on all threads (a scan's tree, normals and scale are the
  // same at any thread count).
  const bool across = scans.size() >= static_cast<std::size_t>(thread_count(threads));
  const int inner = across ? 1 : threads;
  std::vector<ScanData> out(scans.size());
  parallel_tasks(scans.size(), across ? threads : 1, [&](std::size_t k) {
    ScanData& d = out[k];
    d.cloud = scans[k];
    d.tree = std::make_unique<KdTree>(d.cloud.positions, inner);
    const bool given = !viewpoints.empty() && viewpoints[k];
    NormalSettings ns;
    ns.viewpoint = given ? *viewpoints[k] : Eigen::Vector3d::Zero();
    ns.threads = inner;
    estimate_normals(d.cloud, *d.tree, ns);  // the file's normals may point anywhere
    d.scale = measure_scale(d.cloud, *d.tree, inner);
    d.viewpoint = *ns.viewpoint;
    if (given || hidden_share(d) <= kMaxHiddenShare) {
      d.sensor = given ? SensorSource::kGiven : SensorSource::kOrigin;
      return;
    }
    d.sensor = SensorSource::kEstimated;
    d.viewpoint = estimated_viewpoint(d.cloud, d.scale.extent);
    orient_normals(d.cloud, d.viewpoint, inner);
  });
  return out;
}

double hidden_share(const ScanData& scan) {
  const DepthMap map = depth_map(scan);
  const double margin = kHiddenSpacings * scan.scale.spacing;
  const std::size_t m = every_mth_step(scan.cloud.size(), kSensorSamples);
  std::size_t hidden = 0, tested = 0;
  for (std::size_t i = 0; i < scan.cloud.size(); i += m, ++tested) {
    double depth = 0;
    const auto key = map.key(scan.cloud.positions[i], depth);
    hidden += !key || depth > map.nearest.at(*key) + margin;
  }
  return tested ? static_cast<double>(hidden) / static_cast<double>(tested) : 0.0;
}

double largest_extent(const std::vector<ScanData>& scans) {
  double e = 0;
  for (const ScanData& d : scans) e = std::max(e, d.scale.extent);
  return e;
}

std::size_t every_mth_step(std::size_t size, std::size_t count) {
  count = std::max<std::size_t>(count, 1);
  return std::max<std::size_t>(1, (size + count - 1) / count);
}

PointCloud every_mth(const PointCloud& cloud, std::size_t count) {
  PointCloud out;
  const std::size_t m = every_mth_step(cloud.size(), count);
  for (std::size_t q = 0; q < cloud.size(); q += m) {
    out.positions.push_back(cloud.positions[q]);
    out.normals.push_back(cloud.normals[q]);
  }
  return out;
}

double pair_reach(const ScanData& a, const ScanData& b) {
  return 3 * std::max(a.scale.spacing, b.scale.spacing) +
         3 * std::hypot(a.scale.noise, b.scale.noise);
}

std::optional<std::uint64_t> DepthMap::key(const Eigen::Vector3d& x, double& depth) const {
  const Eigen::Vector3d v = x - viewpoint;
  depth = v.dot(axis);
  if (depth <= 0) return std::nullopt;
  const double u = std::floor(v.dot(e1) / depth / bin), w = std::floor(v.dot(e2) / depth / bin);
  if (std::abs(u) > 1e6 || std::abs(w) > 1e6) return std::nullopt;
  return (static_cast<std::uint64_t>(u + 2e6) << 32) | static_cast<std::uint64_t>(w + 2e6);
}

DepthMap depth_map(const ScanData& scan) {
  const Eigen::Vector3d& viewpoint = scan.viewpoint;
  DepthMap m;
  m.viewpoint = viewpoint;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::vector<double> depths;
  for (const Eigen::Vector3d& p : scan.cloud.positions) {
    sum += (p - viewpoint).normalized();
    depths.push_back((p - viewpoint).norm());
  }
  m.axis = sum.normalized();
  m.e1 = m.axis.unitOrthogonal();
  m.e2 = m.axis.cross(m.e1);
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  m.bin = 2 * scan.scale.spacing / depths[depths.size() / 2];
  for (const Eigen::Vector3d& p : scan.cloud.positions) {
    double depth = 0;
    if (const auto k = m.key(p, depth)) {
      auto [it, fresh] = m.nearest.emplace(*k, depth);
      if (!fresh) it->second = std::min(it->second, depth);
    }
  }
  return m;
}

double free_space_share(const ScanData& scan, const Eigen::Isometry3d& T, const DepthMap& map,
                        double margin, FreeSpacePoints which) {
  std::size_t seen = 0, violations = 0, tested = 0;
  for (std::size_t i = 0; i < scan.cloud.size(); i += which.stride) {
    ++tested;
    const Eigen::Vector3d p = T * scan.cloud.positions[i];
    if (which.facing_only &&
        (T.linear() * scan.cloud.normals[i]).dot((map.viewpoint - p).normalized()) < kFacingCosine)
      continue;
    double depth = 0;
    const auto k = map.key(p, depth);
    if (!k) continue;
    const auto it = map.nearest.find(*k);
    if (it == map.nearest.end()) continue;
    ++seen;
    if (depth < it->second - margin) ++violations;
  }
  // A share of a few points seen says nothing: at least kMinSeenShare of the points tested count.
  const double floor = kMinSeenShare * static_cast<double>(tested);
  return violations ? static_cast<double>(violations) / std::max(static_cast<double>(seen), floor)
                    : 0.0;
}

double free_space_slack(const ScanData& seen_by) {
  return seen_by.sensor == SensorSource::kEstimated ? kEstimatedSlack : 1.0;
}

double pair_free_space(const ScanData& a, const ScanData& b, const DepthMap& map_a,
                       const DepthMap& map_b, const Eigen::Isometry3d& T, double margin,
                       FreeSpacePoints which) {
  return std::max(free_space_share(a, T, map_b, margin, which) / free_space_slack(b),
                  free_space_share(b, T.inverse(), map_a, margin, which) / free_space_slack(a));
}

double facing_free_space(const ScanData& a, const ScanData& b, const DepthMap& map_a,
                         const DepthMap& map_b, const Eigen::Isometry3d& T, double margin,
                         std::size_t points) {
  FreeSpacePoints facing;
  facing.facing_only = true;
  facing.stride = std::max<std::size_t>(1, std::max(a.cloud.size(), b.cloud.size()) / points);
  return pair_free_space(a, b, map_a, map_b, T, margin, facing);
}

}  // namespace align3d::detail
