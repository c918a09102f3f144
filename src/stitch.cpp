#include "align3d/stitch.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>

#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/error.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/icp/information.hpp"
#include "align3d/icp/sampling.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/stitch/multiview_icp.hpp"
#include "align3d/stitch/pose_graph.hpp"
#include "align3d/voxel.hpp"
#include "detail/parallel.hpp"
#include "detail/timing.hpp"
#include "stitch/pair_candidates.hpp"
#include "stitch/selection.hpp"
#include "stitch/views.hpp"

namespace align3d {

namespace {

// The multi-view ICP pairs at most kPullSamples points of each scan (every m-th) in its first stage
// (the pairs' reach: it only pulls the graph's poses in). Its second, at the noise, pairs the
// kStableShare of each scan's points (at most kMultiviewSamples) that hold its pose best: the
// kStableTop share of most leverage and every m-th of the others (icp/sampling.hpp). Every m-th
// alone loses what few points hold a near-symmetric part's turn: measured on the flange's 8-view
// ring (2026-11-28), the scans' turn about the axis came within 0.022° with all of their ~27 000
// points, 0.041° with 20 000 every m-th, 0.016° with half of them so (2 × faster), and the 12-view
// ring's worst scan from 0.103 % of the diameter to 0.089 %.
constexpr std::size_t kPullSamples = 5000, kMultiviewSamples = 100000;
constexpr double kStableShare = 0.5, kStableTop = 0.25;
// Whether two scans overlap at the optimised poses is measured on about this many points of each.
constexpr std::size_t kLinkSamples = 2000;
// The multi-view ICP stops when no pose moves the scans' centre, or a point at the diameter by
// turning, by more than this share of the diameter. Its creep is linear, each step ~0.8 of the
// last at worst (the flange's ring): what is left is then within 4 × this, 0.004 % of the diameter.
constexpr double kMultiviewTolerance = 1e-5;
// The pair search thins every scan to this share of the object's diameter (stitch/pair_candidates).
constexpr double kPairVoxelShare = 1.0 / 40;
// An edge's ICP (refine_edge): at most this many points of its source, iterations a round. The
// multi-view ICP refines every pose with all points after the graph, which needs the edges only
// well within its pruning bounds: measured on the generated sets (2026-11-28), 3 000 and 15 left
// every final pose where 10 000 and 30 did (within 0.003°), the edges in a third of the time.
constexpr std::size_t kEdgeSamples = 3000;
constexpr int kEdgeIterations = 15;

using detail::Clock;
using detail::DepthMap;
using detail::facing_free_space;
using detail::ms_since;
using detail::pair_reach;
using detail::PairCandidate;
using detail::PairSearchScan;
using detail::ScanData;

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
  for (const std::optional<Eigen::Vector3d>& v : s.viewpoints)
    if (v && !v->allFinite()) bad("viewpoints must be finite");
  if (s.threads < 0) bad("threads must not be negative");
}

// Step 1: every pair's candidates (stitch/pair_candidates.hpp), each scan prepared once. Pairs run
// in parallel, one thread each, in chunks of 16 a thread between which the progress is told (pairs
// differ in cost several-fold: with 4 a thread, the threads waited at the chunks' ends, the stage
// 5-10 % slower on the generated sets); the result does not depend on the thread count.
std::vector<PairCandidate> search_pairs(const std::vector<ScanData>& scans,
                                        const std::vector<PairSearchScan>& search,
                                        const std::vector<DepthMap>& maps,
                                        const StitchSettings& s) {
  const std::size_t n = scans.size();
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t j = 1; j < n; ++j)
    for (std::size_t i = 0; i < j; ++i) pairs.emplace_back(i, j);
  std::vector<std::vector<PairCandidate>> found(pairs.size());
  const std::size_t chunk = 16 * static_cast<std::size_t>(thread_count(s.threads));
  for (std::size_t first = 0; first < pairs.size(); first += chunk) {
    if (s.progress) s.progress({"pairs", first, pairs.size()});
    parallel_tasks(std::min(chunk, pairs.size() - first), s.threads, [&](std::size_t t) {
      const auto [i, j] = pairs[first + t];
      found[first + t] = detail::pair_candidates(i, j, scans, search, maps, s.min_overlap);
    });
  }
  std::vector<PairCandidate> all;
  for (const auto& f : found) all.insert(all.end(), f.begin(), f.end());
  return all;
}

// An edge's ICP: pairs within 2, 1 and ½ of the pair's reach in turn, weighted by Geman-McClure at
// half the reach (or the settings' kernel). One wide run without a kernel left the keyed flange's
// edges up to 4° off about its axis (pairs across its lugs' edges pull, and only the lugs hold
// that turn); measured on the flange's 12-view ring from the truth: 0.01–0.3° this way, 0.07–1.7°
// so.
Eigen::Isometry3d refine_edge(const PointCloud& sample, const ScanData& target, Eigen::Isometry3d T,
                              double reach, double noise, const StitchSettings& s) {
  IcpSettings is;
  is.method = s.cost.method;
  is.termination.max_iterations = kEdgeIterations;
  is.threads = 1;  // the edges run in parallel (make_edges)
  for (const double r : {2 * reach, reach, reach / 2}) {
    is.rejection = RejectionRule::max_distance(r);
    is.kernel = s.cost.kernel.value_or(RobustKernel::kGemanMcClure);
    is.kernel_scale = s.cost.kernel ? kernel_scale_or_tuned(is.kernel, s.cost.kernel_scale,
                                                            std::sqrt(2.0) * noise)
                                    : r / 2;
    T = icp(sample, target.cloud, *target.tree, T, is).T_target_source;
  }
  return T;
}

// An agreeing edge refined at full resolution (single-threaded) with its information, or "weak".
void refine_and_weigh(const std::vector<ScanData>& scans, StitchEdge& e, const StitchSettings& s) {
  const ScanData &a = scans[e.source], &b = scans[e.target];
  const double reach = pair_reach(a, b);
  const PointCloud sample = detail::every_mth(a.cloud, kEdgeSamples);
  e.transformation =
      refine_edge(sample, b, e.transformation, reach, std::max(a.scale.noise, b.scale.noise), s);
  const PairInformation info =
      point_to_plane_information(a.cloud, b.cloud, *b.tree, e.transformation, reach, 1);
  if (info.pairs < 6) {
    e.status = "weak";
    return;
  }
  e.information = info.information;
  e.rms = info.rms;
  e.pairs = info.pairs;
  e.centroid = info.centroid;
  e.kept = true;
}

// Step 3's edges: per pair with candidates, the one the chosen poses agree with, refined at full
// resolution with the settings' cost, with its information (icp/information.hpp); or, when none
// agrees, the pair's best, not kept ("inconsistent").
std::vector<StitchEdge> make_edges(const std::vector<ScanData>& scans,
                                   const std::vector<PairCandidate>& candidates,
                                   const detail::Selection& selection, const StitchSettings& s) {
  std::vector<StitchEdge> edges;
  for (std::size_t e = 0; e < candidates.size(); ++e) {
    const PairCandidate& c = candidates[e];
    const bool agrees = selection.agrees[e];
    auto same_pair = [&](const StitchEdge& x) {
      return x.source == c.source && x.target == c.target;
    };
    auto it = std::find_if(edges.begin(), edges.end(), same_pair);
    // A pair's candidates come best first: the first, or the one that agrees.
    if (it != edges.end() && (it->status.empty() || !agrees)) continue;
    StitchEdge edge;
    edge.source = c.source, edge.target = c.target;
    edge.transformation = c.T_target_source;
    edge.overlap = c.overlap;
    edge.free_space = c.free_space;
    edge.status = agrees ? "" : "inconsistent";
    if (it != edges.end())
      *it = edge;
    else
      edges.push_back(edge);
  }
  // The agreeing ones refined, in parallel, one thread each, in chunks between which the progress
  // is told (as search_pairs; with 4 a thread, the bracket's ring's 17 edges ran in chunks of 8,
  // 8 and 1 and the step took 210 ms on 2 threads instead of 179).
  std::vector<std::size_t> todo;
  for (std::size_t k = 0; k < edges.size(); ++k)
    if (edges[k].status.empty()) todo.push_back(k);
  const std::size_t chunk = 16 * static_cast<std::size_t>(thread_count(s.threads));
  for (std::size_t first = 0; first < todo.size(); first += chunk) {
    if (s.progress) s.progress({"edges", first, todo.size()});
    parallel_tasks(std::min(chunk, todo.size() - first), s.threads,
                   [&](std::size_t t) { refine_and_weigh(scans, edges[todo[first + t]], s); });
  }
  std::sort(edges.begin(), edges.end(), [](const StitchEdge& a, const StitchEdge& b) {
    return std::tie(a.source, a.target) < std::tie(b.source, b.target);
  });
  return edges;
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

// Step 4's links: the kept edges, and every other two connected scans that overlap at the
// optimised poses (of either's sample, about kLinkSamples points, at least min_overlap on the
// other's surface within the pair's reach: coarse/global.hpp's surface_fit). A pair none of whose
// candidates agreed with the choice (a near-symmetric part's views fit each other turned) may
// still hold what fixes the turn: measured on the flange's 8-view ring (2026-11-28), the pairs
// 0–1 and 1–7, "inconsistent", held 3/4 of the information about the axis between two halves of
// the ring, and without them one half settled 0.05–0.07° off about it.
std::vector<std::pair<std::size_t, std::size_t>> overlapping_links(
    const std::vector<ScanData>& scans, const std::vector<StitchEdge>& edges,
    const std::vector<StitchScan>& out, double min_overlap) {
  const std::size_t n = scans.size();
  std::vector<PointCloud> samples(n);
  for (std::size_t k = 0; k < n; ++k) samples[k] = detail::every_mth(scans[k].cloud, kLinkSamples);
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = a + 1; b < n; ++b) {
      if (!out[a].connected || !out[b].connected) continue;
      auto is_edge = [&](const StitchEdge& e) { return e.kept && e.source == a && e.target == b; };
      const Eigen::Isometry3d T = out[b].transformation.inverse() * out[a].transformation;
      const double reach = pair_reach(scans[a], scans[b]);
      if (std::any_of(edges.begin(), edges.end(), is_edge) ||
          surface_fit(samples[a], scans[b].cloud, *scans[b].tree, T, reach, 1) >= min_overlap ||
          surface_fit(samples[b], scans[a].cloud, *scans[a].tree, T.inverse(), reach, 1) >=
              min_overlap)
        links.emplace_back(a, b);
    }
  return links;
}

// Step 4: multi-view ICP over the connected scans and their links.
MultiviewResult refine_views(const std::vector<ScanData>& scans,
                             const std::vector<StitchEdge>& edges,
                             const std::vector<StitchScan>& out, const StitchSettings& s,
                             double diameter, double noise) {
  std::vector<Eigen::Isometry3d> poses(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) poses[k] = out[k].transformation;
  // Every m-th point of each connected scan, at most `count` (as detail::every_mth); or, `stable`,
  // the kStableShare of its points that hold its pose best (at most `count`).
  auto sampled = [&](std::size_t count, bool stable) {
    std::vector<MultiviewScan> views(scans.size());
    parallel_tasks(scans.size(), s.threads, [&](std::size_t k) {
      views[k].cloud = &scans[k].cloud;
      views[k].tree = scans[k].tree.get();
      if (!out[k].connected) return;
      const std::size_t size = scans[k].cloud.size();
      if (stable) {
        const double share =
            std::min(kStableShare, static_cast<double>(count) / static_cast<double>(size));
        views[k].sample = stable_sample(scans[k].cloud, share, share * kStableTop / kStableShare);
        return;
      }
      const std::size_t m = detail::every_mth_step(size, count);
      for (std::size_t i = 0; i < size; i += m)
        views[k].sample.push_back(static_cast<std::uint32_t>(i));
    });
    return views;
  };
  double reach = 0;
  const auto links = overlapping_links(scans, edges, out, s.min_overlap);
  double spacing = 0;
  for (const auto& [a, b] : links) {
    reach = std::max(reach, pair_reach(scans[a], scans[b]));
    spacing = std::max({spacing, scans[a].scale.spacing, scans[b].scale.spacing});
  }
  MultiviewSettings ms;
  ms.max_distance = reach;
  ms.max_iterations = s.multiview_iterations;
  ms.length = diameter;
  ms.tolerance = kMultiviewTolerance * diameter;
  ms.threads = s.threads;
  ms.method = s.cost.method == IcpMethod::kPointToPoint ? IcpMethod::kPointToPlane : s.cost.method;
  if (s.cost.kernel) {
    ms.kernel = *s.cost.kernel;
    ms.kernel_scale = kernel_scale_or_tuned(ms.kernel, s.cost.kernel_scale, std::sqrt(2.0) * noise);
  }
  MultiviewResult r = multiview_icp(sampled(kPullSamples, false), links, poses, ms);
  // The second stage: pairs within a spacing or three noise levels. Pairs across the edges of a
  // feature pull the poses aside: measured on the keyed flange's 12-view ring from the true poses,
  // at the first stage's reach a group of scans settled 0.3° off about the axis (1.2° at twice
  // that reach), at this one within 0.07°.
  ms.max_distance = std::max(spacing, 3 * std::sqrt(2.0) * noise);
  const int first = r.iterations;
  r = multiview_icp(sampled(kMultiviewSamples, true), links, r.poses, ms);
  r.iterations += first;
  return r;
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
      const Eigen::Isometry3d T = out[b].transformation.inverse() * out[a].transformation;
      const double share = facing_free_space(scans[a], scans[b], maps[a], maps[b], T,
                                             2 * pair_reach(scans[a], scans[b]), 5000);
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

// The result's warning `code` with `message`, also listed in each of `scans`' own warnings.
void warn(StitchResult& r, const std::string& code, const std::string& message,
          const std::vector<std::size_t>& scans) {
  r.warnings.push_back({code, message});
  for (std::size_t k : scans) r.scans[k].warnings.push_back(code);
}

// "3, 5, 7".
std::string scan_list(const std::vector<std::size_t>& scans) {
  std::string list;
  for (std::size_t k : scans) list += (list.empty() ? "" : ", ") + std::to_string(k);
  return list;
}

void add_warnings(StitchResult& r, const std::vector<StitchEdge>& edges,
                  const std::vector<std::size_t>& ambiguous,
                  const std::vector<std::tuple<double, std::size_t, std::size_t>>& inconsistent) {
  for (std::size_t k = 0; k < r.scans.size(); ++k) {
    const StitchScan& s = r.scans[k];
    if (!s.connected)
      warn(r, "unconnected_scan",
           "scan " + std::to_string(k) +
               " overlaps no scan joined to the first; left out of the merge",
           {k});
    else if (k > 0 && s.edges == 1)
      warn(r, "single_edge_scan",
           "scan " + std::to_string(k) + " is held by one edge only: no loop checks its pose", {k});
  }
  if (!ambiguous.empty())
    warn(r, "ambiguous_scans",
         "scan(s) " + scan_list(ambiguous) +
             " fit the others as well or better at other poses: the data do not decide "
             "where they lie",
         ambiguous);
  if (!inconsistent.empty()) {
    const auto& [share, a, b] = inconsistent.front();
    std::vector<std::size_t> named;
    for (const auto& [_, x, y] : inconsistent) named.insert(named.end(), {x, y});
    std::sort(named.begin(), named.end());
    named.erase(std::unique(named.begin(), named.end()), named.end());
    warn(r, "inconsistent_scans",
         std::to_string(inconsistent.size()) +
             " pair(s) of stitched scans contradict each other, the worst scans " +
             std::to_string(a) + " and " + std::to_string(b) + " (" + format_share(share) +
             " of one lies where the other's sensor saw through it): some pose is wrong, e.g. a "
             "scan turned onto a look-alike face of the part",
         named);
  }
  for (const StitchEdge& e : edges)
    if (e.status == "pruned")
      r.warnings.push_back({"pruned_edge", "the registration of scan " + std::to_string(e.source) +
                                               " onto scan " + std::to_string(e.target) +
                                               " disagreed with the other scans (" +
                                               format_residual(e) + ") and was left out"});
}

}  // namespace

std::string_view to_string(SensorSource s) {
  switch (s) {
    case SensorSource::kGiven:
      return "given";
    case SensorSource::kOrigin:
      return "origin";
    case SensorSource::kEstimated:
      return "estimated";
  }
  return "given";
}

StitchResult stitch(const std::vector<PointCloud>& scans, const StitchSettings& settings) {
  const auto start = Clock::now();
  if (scans.size() < 2) throw DataError("scans", "stitching needs at least two scans");
  check_settings(settings, scans.size());
  std::vector<ScanData> data = detail::prepare_scans(scans, settings.viewpoints, settings.threads);
  StitchResult r;
  r.diameter = detail::largest_extent(data);
  double noise = 0;
  for (const ScanData& d : data) noise = std::max(noise, d.scale.noise);

  auto t = Clock::now();
  const double voxel = kPairVoxelShare * r.diameter;
  std::vector<DepthMap> maps(data.size());
  std::vector<PairSearchScan> search(data.size());
  parallel_tasks(data.size(), settings.threads, [&](std::size_t k) {
    maps[k] = detail::depth_map(data[k]);
    search[k] = detail::prepare_pair_search(data[k], voxel, k + 1 < data.size());
  });
  const std::vector<PairCandidate> candidates = search_pairs(data, search, maps, settings);
  const detail::Selection selection =
      detail::select_poses(candidates, data, maps, search, r.diameter, voxel, settings.threads);
  r.timings.pairs_ms = ms_since(t);
  t = Clock::now();
  r.edges = make_edges(data, candidates, selection, settings);
  r.timings.edges_ms = ms_since(t);

  t = Clock::now();
  if (settings.progress) settings.progress({"pose graph", 0, 0});
  const PoseGraphResult graph = optimise_graph(scans.size(), r.edges, settings, r.diameter, noise);
  r.scans.resize(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) {
    r.scans[k].transformation = graph.poses[k];
    r.scans[k].connected = graph.connected[k];
    r.scans[k].points = scans[k].size();
    r.scans[k].viewpoint = data[k].viewpoint;
    r.scans[k].sensor = data[k].sensor;
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
  add_warnings(r, r.edges, selection.ambiguous, inconsistent);
  r.timings.total_ms = ms_since(start);
  return r;
}

}  // namespace align3d
