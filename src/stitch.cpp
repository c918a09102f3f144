#include "align3d/stitch.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>

#include "align3d/align.hpp"
#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/coarse/target_cache.hpp"
#include "align3d/coarse/voxel.hpp"
#include "align3d/error.hpp"
#include "align3d/icp/information.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/stitch/multiview_icp.hpp"
#include "align3d/stitch/pose_graph.hpp"
#include "detail/timing.hpp"

namespace align3d {

namespace {

// The multi-view ICP pairs at most this many points of each scan (every m-th).
constexpr std::size_t kMultiviewSamples = 20000;

using detail::Clock;
using detail::ms_since;

// A scan as every step uses it: its points with normals towards its sensor, its tree and scale,
// and where its sensor was (its frame).
struct ScanData {
  PointCloud cloud;
  std::unique_ptr<KdTree> tree;
  CloudScale scale;
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
};

void check_settings(const StitchSettings& s, std::size_t scans) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("stitch: " + what); };
  if (!(s.min_overlap > 0 && s.min_overlap <= 1)) bad("min_overlap must lie in (0, 1]");
  if (!(s.prune_rotation_deg > 0) || !std::isfinite(s.prune_rotation_deg))
    bad("prune_rotation_deg must be positive");
  if (!(s.prune_translation > 0) || !std::isfinite(s.prune_translation))
    bad("prune_translation must be positive");
  if (s.multiview_iterations < 0) bad("multiview_iterations must not be negative");
  if (!(s.voxel >= 0) || !std::isfinite(s.voxel)) bad("voxel must be 0 (automatic) or positive");
  if (!s.viewpoints.empty() && s.viewpoints.size() != scans)
    bad("viewpoints: one per scan, or none");
  for (const Eigen::Vector3d& v : s.viewpoints)
    if (!v.allFinite()) bad("viewpoints must be finite");
  if (s.threads < 0) bad("threads must not be negative");
}

std::vector<ScanData> prepare_scans(const std::vector<PointCloud>& scans, const StitchSettings& s) {
  std::vector<ScanData> out(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) {
    check_registrable(scans[k], "scan " + std::to_string(k));
    ScanData& d = out[k];
    d.cloud = scans[k];
    d.tree = std::make_unique<KdTree>(d.cloud.positions, s.threads);
    if (!s.viewpoints.empty()) d.viewpoint = s.viewpoints[k];
    NormalSettings ns;
    ns.viewpoint = d.viewpoint;
    ns.threads = s.threads;
    estimate_normals(d.cloud, *d.tree, ns);  // the file's normals may point anywhere
    d.scale = measure_scale(d.cloud, *d.tree);
  }
  return out;
}

double largest_extent(const std::vector<ScanData>& scans) {
  double e = 0;
  for (const ScanData& d : scans) e = std::max(e, d.scale.extent);
  return e;
}

// The pair's reach: a few spacings and noise levels of the coarser of the two.
double pair_reach(const ScanData& a, const ScanData& b) {
  return 3 * std::max(a.scale.spacing, b.scale.spacing) +
         3 * std::hypot(a.scale.noise, b.scale.noise);
}

AlignSettings align_settings(const StitchSettings& s, InitPolicy init) {
  AlignSettings as;
  as.init = init;
  static_cast<CostSettings&>(as.refine) = s.cost;
  as.threads = s.threads;
  as.seed = s.seed;
  return as;
}

// What a scan's sensor saw, as a depth map: the scan's points binned by direction from the
// viewpoint (a virtual pinhole along their mean direction, bins of about two point spacings at the
// median depth), each bin holding the nearest depth seen in it.
struct DepthMap {
  Eigen::Vector3d viewpoint, e1, e2, axis;
  double bin = 1;
  std::unordered_map<std::uint64_t, double> nearest;

  std::optional<std::uint64_t> key(const Eigen::Vector3d& x, double& depth) const {
    const Eigen::Vector3d v = x - viewpoint;
    depth = v.dot(axis);
    if (depth <= 0) return std::nullopt;
    const double u = std::floor(v.dot(e1) / depth / bin), w = std::floor(v.dot(e2) / depth / bin);
    if (std::abs(u) > 1e6 || std::abs(w) > 1e6) return std::nullopt;
    return (static_cast<std::uint64_t>(u + 2e6) << 32) | static_cast<std::uint64_t>(w + 2e6);
  }
};

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

// Which points a free-space count takes: all, or those whose surface faces the other sensor at
// less than 70° from its line of sight (kFacingCosine), every `stride`-th.
struct FreeSpacePoints {
  bool facing_only = false;
  std::size_t stride = 1;
};
constexpr double kFacingCosine = 0.34;  // cos 70°

// The share of `scan`'s points, moved by T into the frame of the scan `map` was made of, that
// lie in front of what that sensor saw (by more than `margin`): the sensor would have seen them
// there, so the pose is wrong. Only points in directions the sensor saw anything count.
double free_space_share(const ScanData& scan, const Eigen::Isometry3d& T, const DepthMap& map,
                        double margin, FreeSpacePoints which = {}) {
  std::size_t seen = 0, violations = 0;
  for (std::size_t i = 0; i < scan.cloud.size(); i += which.stride) {
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
  return seen ? static_cast<double>(violations) / static_cast<double>(seen) : 0.0;
}

// The larger of the two shares of a pair's points in front of what the other sensor saw.
double pair_free_space(const ScanData& a, const ScanData& b, const DepthMap& map_a,
                       const DepthMap& map_b, const Eigen::Isometry3d& T, double margin,
                       FreeSpacePoints which = {}) {
  return std::max(free_space_share(a, T, map_b, margin, which),
                  free_space_share(b, T.inverse(), map_a, margin, which));
}

// Step 1: every pair registered by the global stage alone; those it lays onto each other become
// edges (not yet refined). Each scan's descriptors, as a target, are kept across its pairs.
std::vector<StitchEdge> find_pairs(const std::vector<ScanData>& scans,
                                   const std::vector<DepthMap>& maps, const StitchSettings& s) {
  std::vector<StitchEdge> edges;
  const std::size_t n = scans.size(), total = n * (n - 1) / 2;
  std::size_t done = 0;
  GlobalSettings gs;
  gs.seed = s.seed;
  gs.threads = s.threads;
  for (std::size_t j = 1; j < n; ++j) {
    GlobalTargetCache cache(scans[j].cloud);
    for (std::size_t i = 0; i < j; ++i, ++done) {
      if (s.progress) s.progress({"pairs", done, total});
      const GlobalContext context{&scans[i].scale, &scans[j].scale, &cache};
      const GlobalResult g = global_register(scans[i].cloud, scans[j].cloud, gs, context);
      if (!g.success || g.overlap < s.min_overlap) continue;
      // A pose far in the other's free space already at the global stage's accuracy (a few of its
      // voxels) is not worth refining.
      if (pair_free_space(scans[i], scans[j], maps[i], maps[j], g.T_target_source, 3 * g.voxel) >
          2 * kMaxFreeSpace)
        continue;
      StitchEdge e;
      e.source = i, e.target = j;
      e.transformation = g.T_target_source;
      e.overlap = g.overlap;
      edges.push_back(e);
    }
  }
  std::sort(edges.begin(), edges.end(), [](const StitchEdge& a, const StitchEdge& b) {
    return std::tie(a.source, a.target) < std::tie(b.source, b.target);
  });
  return edges;
}

// Step 2: each edge refined at full resolution from the pair search's pose, with its information.
void refine_edges(const std::vector<ScanData>& scans, const std::vector<DepthMap>& maps,
                  std::vector<StitchEdge>& edges, const StitchSettings& s) {
  for (std::size_t k = 0; k < edges.size(); ++k) {
    if (s.progress) s.progress({"edges", k, edges.size()});
    StitchEdge& e = edges[k];
    const ScanData& a = scans[e.source];
    const ScanData& b = scans[e.target];
    AlignSettings as = align_settings(s, InitPolicy::kPose);
    as.initial_pose = e.transformation;
    const AlignResult r = align(a.cloud, b.cloud, as);
    e.warnings = r.warnings;
    if (!r.success) {
      e.status = "weak";
      continue;
    }
    e.transformation = r.transformation;
    e.overlap = r.support.overlap;
    const PairInformation info = point_to_plane_information(
        a.cloud, b.cloud, *b.tree, e.transformation, pair_reach(a, b), s.threads);
    if (info.pairs < 6) {
      e.status = "weak";
      continue;
    }
    e.free_space = pair_free_space(a, b, maps[e.source], maps[e.target], e.transformation,
                                   2 * pair_reach(a, b));
    if (e.free_space > kMaxFreeSpace) {
      e.status = "contradicted";
      continue;
    }
    e.information = info.information;
    e.rms = info.rms;
    e.pairs = info.pairs;
    e.centroid = info.centroid;
    e.kept = true;
  }
}

// Step 3: the pose graph over the refined edges; `kept`, the residuals and the poses written back.
PoseGraphResult optimise_graph(std::size_t nodes, std::vector<StitchEdge>& edges,
                               const StitchSettings& s, double diameter, double noise) {
  std::vector<PoseGraphEdge> graph;
  std::vector<std::size_t> index;  // graph edge → StitchEdge
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const StitchEdge& e = edges[k];
    if (!e.kept) continue;
    graph.push_back({e.source, e.target, e.transformation, e.information, e.pairs,
                     std::max(e.rms, 1e-12 * diameter), e.centroid, e.overlap});
    index.push_back(k);
  }
  PoseGraphSettings gs;
  gs.prune_rotation_deg = s.prune_rotation_deg;
  gs.prune_translation = s.prune_translation * diameter;
  // The loss's knee: a few noise levels, but well inside the pruning bound.
  gs.robust_distance = std::max(3 * noise, gs.prune_translation / 4);
  PoseGraphResult g = optimize_pose_graph(nodes, graph, gs);
  for (std::size_t k = 0; k < graph.size(); ++k)
    if (!g.kept[k]) edges[index[k]].kept = false, edges[index[k]].status = "pruned";
  return g;
}

// The edges' disagreement with the final poses.
void measure_edges(std::vector<StitchEdge>& edges, const std::vector<StitchScan>& scans) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (StitchEdge& e : edges) {
    e.rotation_residual_deg = e.translation_residual = nan;
    if (!scans[e.source].connected || !scans[e.target].connected) continue;
    const EdgeResidual r =
        edge_residual(e.transformation, e.centroid, scans[e.source].transformation,
                      scans[e.target].transformation);
    e.rotation_residual_deg = r.rotation_deg;
    e.translation_residual = r.translation;
  }
}

// Step 4: multi-view ICP over the connected scans and kept edges.
MultiviewResult refine_views(const std::vector<ScanData>& scans,
                             const std::vector<StitchEdge>& edges,
                             const std::vector<StitchScan>& out, const StitchSettings& s,
                             double diameter, double noise) {
  std::vector<MultiviewScan> views(scans.size());
  std::vector<Eigen::Isometry3d> poses(scans.size());
  double reach = 0;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    views[k].cloud = &scans[k].cloud;
    views[k].tree = scans[k].tree.get();
    poses[k] = out[k].transformation;
    if (!out[k].connected) continue;
    // Every m-th point, at most kMultiviewSamples a scan: enough pairs for six unknowns each.
    const std::size_t m = (scans[k].cloud.size() + kMultiviewSamples - 1) / kMultiviewSamples;
    for (std::size_t i = 0; i < scans[k].cloud.size(); i += m)
      views[k].sample.push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (const StitchEdge& e : edges)
    if (e.kept) {
      links.emplace_back(e.source, e.target);
      reach = std::max(reach, pair_reach(scans[e.source], scans[e.target]));
    }
  MultiviewSettings ms;
  ms.max_distance = reach;
  ms.max_iterations = s.multiview_iterations;
  ms.length = diameter;
  ms.tolerance = 1e-6 * diameter;
  ms.threads = s.threads;
  ms.method = s.cost.method == IcpMethod::kPointToPoint ? IcpMethod::kPointToPlane : s.cost.method;
  if (s.cost.kernel) {
    ms.kernel = *s.cost.kernel;
    ms.kernel_scale = kernel_scale_or_tuned(ms.kernel, s.cost.kernel_scale, std::sqrt(2.0) * noise);
  }
  return multiview_icp(views, links, poses, ms);
}

void residual_statistics(const MultiviewPairs& pairs, StitchScan& scan) {
  std::vector<double> d = pairs.distances;
  scan.pairs = d.size();
  if (d.empty()) return;
  double sq = 0;
  for (double x : d) sq += x * x;
  scan.rms = std::sqrt(sq / static_cast<double>(d.size()));
  auto at = [&](double q) {
    const auto k = static_cast<std::size_t>(q * static_cast<double>(d.size() - 1));
    std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k), d.end());
    return d[k];
  };
  scan.median = at(0.5);
  scan.p95 = at(0.95);
}

// Step 5: the connected scans in the first one's frame, one point per voxel.
void merge(const std::vector<ScanData>& scans, StitchResult& r, const StitchSettings& s) {
  PointCloud all;
  std::vector<std::int32_t> labels;
  std::vector<double> spacings;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    if (!r.scans[k].connected) continue;
    const PointCloud moved = transformed(scans[k].cloud, r.scans[k].transformation);
    all.positions.insert(all.positions.end(), moved.positions.begin(), moved.positions.end());
    all.normals.insert(all.normals.end(), moved.normals.begin(), moved.normals.end());
    labels.insert(labels.end(), moved.size(), static_cast<std::int32_t>(k));
    spacings.push_back(scans[k].scale.spacing);
  }
  std::nth_element(spacings.begin(), spacings.begin() + spacings.size() / 2, spacings.end());
  r.voxel = s.voxel > 0 ? s.voxel : kMergeVoxelSpacings * spacings[spacings.size() / 2];
  r.merged = voxel_downsample(all, r.voxel, labels, r.merged_scan);
}

// Step 6: every two connected scans at their final poses, whether or not an edge joins them, must
// not contradict each other: no more than kMaxInconsistency of one's points (facing the other
// sensor; at most ~5000 a scan) in front of what the other saw. Wrong edges that agree with each
// other (a box's side views turned by a half, each fitting) pass every pairwise test and the pose
// graph, and only show here, between scans no edge joined. Returns the worst pairs, worst first.
std::vector<std::tuple<double, std::size_t, std::size_t>> inconsistent_pairs(
    const std::vector<ScanData>& scans, const std::vector<DepthMap>& maps,
    const std::vector<StitchScan>& out) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> bad;
  for (std::size_t a = 0; a < scans.size(); ++a)
    for (std::size_t b = a + 1; b < scans.size(); ++b) {
      if (!out[a].connected || !out[b].connected) continue;
      FreeSpacePoints which;
      which.facing_only = true;
      which.stride =
          std::max<std::size_t>(1, std::max(scans[a].cloud.size(), scans[b].cloud.size()) / 5000);
      const Eigen::Isometry3d T = out[b].transformation.inverse() * out[a].transformation;
      const double share = pair_free_space(scans[a], scans[b], maps[a], maps[b], T,
                                           2 * pair_reach(scans[a], scans[b]), which);
      if (share > kMaxInconsistency) bad.emplace_back(share, a, b);
    }
  std::sort(bad.rbegin(), bad.rend());
  return bad;
}

std::string format_residual(const StitchEdge& e) {
  char text[96];
  std::snprintf(text, sizeof text, "%.3g° and %.3g apart", e.rotation_residual_deg,
                e.translation_residual);
  return text;
}

std::string format_share(double share) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f %%", 100 * share);
  return text;
}

void add_warnings(StitchResult& r, const std::vector<StitchEdge>& edges,
                  const std::vector<std::tuple<double, std::size_t, std::size_t>>& inconsistent) {
  for (std::size_t k = 0; k < r.scans.size(); ++k) {
    const StitchScan& s = r.scans[k];
    if (!s.connected)
      r.warnings.push_back(
          {"unconnected_scan", "scan " + std::to_string(k) +
                                   " overlaps no scan joined to the first; left out of the merge"});
    else if (k > 0 && s.edges == 1)
      r.warnings.push_back({"single_edge_scan", "scan " + std::to_string(k) +
                                                    " is held by one edge only: no loop checks "
                                                    "its pose"});
  }
  if (!inconsistent.empty()) {
    const auto& [share, a, b] = inconsistent.front();
    r.warnings.push_back(
        {"inconsistent_scans",
         std::to_string(inconsistent.size()) +
             " pair(s) of stitched scans contradict each other, " + "the worst scans " +
             std::to_string(a) + " and " + std::to_string(b) + " (" + format_share(share) +
             " of one lies where the other's sensor saw through it): some " +
             "pose is wrong, e.g. a scan turned onto a look-alike face of the part"});
  }
  for (const StitchEdge& e : edges)
    if (e.status == "pruned")
      r.warnings.push_back({"pruned_edge", "the registration of scan " + std::to_string(e.source) +
                                               " onto scan " + std::to_string(e.target) +
                                               " disagreed with the other scans (" +
                                               format_residual(e) + ") and was left out"});
}

}  // namespace

StitchResult stitch(const std::vector<PointCloud>& scans, const StitchSettings& settings) {
  const auto start = Clock::now();
  if (scans.size() < 2) throw DataError("scans", "stitching needs at least two scans");
  check_settings(settings, scans.size());
  std::vector<ScanData> data = prepare_scans(scans, settings);
  StitchResult r;
  r.diameter = largest_extent(data);
  double noise = 0;
  for (const ScanData& d : data) noise = std::max(noise, d.scale.noise);

  auto t = Clock::now();
  std::vector<DepthMap> maps;
  for (const ScanData& d : data) maps.push_back(depth_map(d));
  r.edges = find_pairs(data, maps, settings);
  r.timings.pairs_ms = ms_since(t);
  t = Clock::now();
  refine_edges(data, maps, r.edges, settings);
  r.timings.edges_ms = ms_since(t);

  t = Clock::now();
  if (settings.progress) settings.progress({"pose graph", 0, 0});
  const PoseGraphResult graph = optimise_graph(scans.size(), r.edges, settings, r.diameter, noise);
  r.scans.resize(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) {
    r.scans[k].transformation = graph.poses[k];
    r.scans[k].connected = graph.connected[k];
    r.scans[k].points = scans[k].size();
  }
  for (const StitchEdge& e : r.edges)
    if (e.kept) ++r.scans[e.source].edges, ++r.scans[e.target].edges;
  r.timings.graph_ms = ms_since(t);

  t = Clock::now();
  if (settings.progress) settings.progress({"multi-view icp", 0, 0});
  const MultiviewResult mv = refine_views(data, r.edges, r.scans, settings, r.diameter, noise);
  r.multiview_iterations = mv.iterations;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    r.scans[k].transformation = mv.poses[k];
    residual_statistics(mv.residuals[k], r.scans[k]);
  }
  measure_edges(r.edges, r.scans);
  const auto inconsistent = inconsistent_pairs(data, maps, r.scans);
  r.timings.multiview_ms = ms_since(t);

  t = Clock::now();
  if (settings.progress) settings.progress({"merge", 0, 0});
  merge(data, r, settings);
  r.timings.merge_ms = ms_since(t);
  add_warnings(r, r.edges, inconsistent);
  r.timings.total_ms = ms_since(start);
  return r;
}

}  // namespace align3d
