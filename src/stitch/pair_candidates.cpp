#include "stitch/pair_candidates.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "align3d/coarse/global.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/icp/information.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/se3.hpp"

namespace align3d::detail {

namespace {

constexpr std::size_t kHypotheses = 40;   // step 1: pose clusters refined
constexpr std::size_t kVotingStride = 3;  // step 1: every 3rd thinned point of scan j votes
constexpr std::size_t kFineKept = 6;      // step 3: refined again and tested
constexpr std::size_t kKept = 3;          // step 4: returned
constexpr std::size_t kProbePoints = 400, kFineSamples = 1000;
constexpr int kCoarseIterations = 10, kFineIterations = 10;
// Step 2: a hypothesis that after this many of its first round's iterations lies where an earlier
// one ended stops there (it was heading for a place already met).
constexpr int kEarlyIterations = 3;
constexpr double kMaxPairFreeSpace = 0.01;
constexpr double kMaxFitRms = 10;  // step 3 (fits)
constexpr double kCoarseDistinctDeg = 5, kFineDistinctDeg = 2;
// The sweep (step 2b, sweep()): turns about a common axis in steps of kSweepStepDeg, the
// kSweepKept least contradicted kept.
constexpr double kSweepStepDeg = 3;
constexpr std::size_t kSweepKept = 4;
constexpr double kMinTurnDeg = 10;
constexpr std::size_t kFreeSpacePoints = 2000;

// What every step of one pair reads.
struct Pair {
  std::size_t i, j;
  const ScanData &si, &sj;
  const PairSearchScan &a, &b;
  const DepthMap &mi, &mj;
  double voxel, reach;
  Eigen::Vector3d c;  // centroid of the source's thinned points: where poses are compared
  bool source_smaller;
};

// Step 2's ICP of the probe onto scan j's thinned points at one reach.
Eigen::Isometry3d coarse_icp(const Pair& p, const Eigen::Isometry3d& T, double reach,
                             int iterations = kCoarseIterations) {
  return icp_rounds(p.a.probe, p.b.down, *p.b.down_tree, T, {reach}, iterations);
}

// Geman-McClure at the pair's reach: without it, a box's plain faces let a partial overlap slide
// (measured on the bracket's 50°/25° ring: true coarse poses slid by up to 9 mm, one by 18°;
// with it every one ended within 0.7° and 4 mm).
Eigen::Isometry3d fine_icp(const Pair& p, const Eigen::Isometry3d& T) {
  return icp_rounds(p.a.sample, p.sj.cloud, *p.sj.tree, T, {p.voxel, 2 * p.reach}, kFineIterations,
                    p.reach);
}

// The share of the smaller scan (by robust extent) on the other's surface, as the global stage's
// (coarse/global.hpp): a large cloud's few points near a small one say nothing.
double overlap(const Pair& p, const Eigen::Isometry3d& T) {
  return p.source_smaller
             ? surface_fit(p.a.down, p.b.down, *p.b.down_tree, T, p.voxel, 1)
             : surface_fit(p.b.down, p.a.down, *p.a.down_tree, T.inverse(), p.voxel, 1);
}

// Whether the pose lays scan i onto scan j's surface at the noise: the point-to-plane RMS of its
// sample's pairs within the reach at most kMaxFitRms × the pair's noise floor (refine.hpp). A
// view of a box laid on a wavy sheet overlaps it as much as a true pair at the coarse voxel, but
// not at the noise. Measured (2026-11-28): the CLI test's sheet 21-25 ×, a true pair of the bracket
// 1.8 ×; at 5 × the 12-view flange set lost true candidates (7 of 13 scans right, 12 at 10 ×).
bool fits(const Pair& p, const Eigen::Isometry3d& T) {
  const PairInformation fit =
      point_to_plane_information(p.a.sample, p.sj.cloud, *p.sj.tree, T, p.reach, 1);
  const double floor = noise_floor(std::hypot(p.si.scale.noise, p.sj.scale.noise),
                                   std::max(p.si.scale.spacing, p.sj.scale.spacing));
  return fit.rms <= kMaxFitRms * floor;
}

double free_space(const Pair& p, const Eigen::Isometry3d& T, std::size_t points, double margin) {
  return facing_free_space(p.si, p.sj, p.mi, p.mj, T, margin, points);
}

// Keeps the first of each group of candidates within `degrees` and `distance` of a kept one.
void keep_distinct(std::vector<PairCandidate>& list, const Eigen::Vector3d& c, double degrees,
                   double distance) {
  std::vector<PairCandidate> kept;
  for (const PairCandidate& e : list)
    if (std::none_of(kept.begin(), kept.end(), [&](const PairCandidate& k) {
          return same_pose(k.T_target_source, e.T_target_source, c, degrees, distance);
        }))
      kept.push_back(e);
  list.swap(kept);
}

// A line: a turn's axis.
struct Line {
  Eigen::Vector3d direction, point;
};

// The line D turns about, when D is a turn by at least kMinTurnDeg that slides less than
// `max_slide` along its axis: D x = R (x − q) + q with q on the line, so (I − R) q = t − (u·t) u,
// solved in the plane normal to u (where I − R is invertible for a turn).
std::optional<Line> turn_axis(const Eigen::Isometry3d& D, double max_slide) {
  const Eigen::AngleAxisd aa(D.linear());
  if (rad_to_deg(aa.angle()) < kMinTurnDeg) return std::nullopt;
  const Eigen::Vector3d u = aa.axis(), t = D.translation();
  if (std::abs(u.dot(t)) > max_slide) return std::nullopt;
  Eigen::Matrix<double, 3, 2> E;
  E.col(0) = u.unitOrthogonal();
  E.col(1) = u.cross(E.col(0));
  const Eigen::Matrix2d M = E.transpose() * (Eigen::Matrix3d::Identity() - D.linear()) * E;
  const Eigen::Vector2d x = M.inverse() * (E.transpose() * (t - u.dot(t) * u));
  return Line{u, E * x};
}

// Whether two lines are one near c: directions within `degrees`, c's feet within `distance`.
bool same_line(const Line& a, const Line& b, const Eigen::Vector3d& c, double degrees,
               double distance) {
  if (std::abs(a.direction.dot(b.direction)) < std::cos(deg_to_rad(degrees))) return false;
  auto foot = [&](const Line& l) {
    return Eigen::Vector3d(l.point + l.direction.dot(c - l.point) * l.direction);
  };
  return (foot(a) - foot(b)).norm() < distance;
}

// The turn by `degrees` about `line`.
Eigen::Isometry3d turn(const Line& line, double degrees) {
  Eigen::Isometry3d R = rigid_transform(degrees, line.direction);
  R.translation() = line.point - R.linear() * line.point;
  return R;
}

}  // namespace

Eigen::Isometry3d icp_rounds(const PointCloud& source, const PointCloud& target, const KdTree& tree,
                             Eigen::Isometry3d T, std::initializer_list<double> reaches,
                             int iterations, double kernel_scale) {
  IcpSettings s;
  s.termination.max_iterations = iterations;
  s.threads = 1;
  if (kernel_scale > 0) s.kernel = RobustKernel::kGemanMcClure, s.kernel_scale = kernel_scale;
  for (const double reach : reaches) {
    s.rejection = RejectionRule::max_distance(reach);
    T = icp(source, target, tree, T, s).T_target_source;
  }
  return T;
}

bool same_pose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const Eigen::Vector3d& c,
               double degrees, double distance) {
  return rad_to_deg(rotation_angle(a.linear().transpose() * b.linear())) < degrees &&
         (a * c - b * c).norm() < distance;
}

PairSearchScan prepare_pair_search(const ScanData& scan, double voxel, bool table) {
  PairSearchScan s;
  // The scan's normals point to its sensor: the outward side of the surface it saw.
  if (table)
    s.model = build_ppf_model(scan.cloud, voxel, 1, true);
  else
    s.model.voxel = ppf_model_voxel(scan.cloud, voxel);
  s.down = ppf_scene(scan.cloud, s.model.voxel, scan.viewpoint, 1);
  s.down_tree = std::make_unique<KdTree>(s.down.positions, 1);
  s.probe = every_mth(s.down, kProbePoints);
  s.sample = every_mth(scan.cloud, kFineSamples);
  return s;
}

namespace {

// Steps 1 and 2: the hypotheses refined on the thinned clouds, of at least min_overlap, distinct,
// by overlap.
std::vector<PairCandidate> coarse_candidates(const Pair& p, double min_overlap) {
  std::vector<PairCandidate> list;
  const std::vector<PpfHypothesis> hyps = ppf_hypotheses(
      p.a.model, every_mth(p.b.down, p.b.down.size() / kVotingStride), Symmetry{}, kHypotheses, 1);
  // ICP at 2 voxels, then at 1. Many hypotheses meet after the first round (one face's votes
  // spread over nearby poses): each meeting place goes on once, and a hypothesis already there
  // after kEarlyIterations stops (2-4 % of the CPU time on the generated sets, every scan's
  // outcome the same).
  std::vector<Eigen::Isometry3d> met;
  auto was_met = [&](const Eigen::Isometry3d& T) {
    return std::any_of(met.begin(), met.end(), [&](const Eigen::Isometry3d& M) {
      return same_pose(M, T, p.c, kCoarseDistinctDeg, p.voxel);
    });
  };
  for (const PpfHypothesis& h : hyps) {
    Eigen::Isometry3d T = coarse_icp(p, h.T_scene_model, 2 * p.voxel, kEarlyIterations);
    if (was_met(T)) continue;
    T = coarse_icp(p, T, 2 * p.voxel, kCoarseIterations - kEarlyIterations);
    if (was_met(T)) continue;
    met.push_back(T);
    PairCandidate e{p.i, p.j};
    e.T_target_source = coarse_icp(p, T, p.voxel);
    e.overlap = overlap(p, e.T_target_source);
    if (e.overlap >= min_overlap) list.push_back(e);
  }
  std::stable_sort(list.begin(), list.end(), [](const PairCandidate& x, const PairCandidate& y) {
    return x.overlap > y.overlap;
  });
  keep_distinct(list, p.c, kCoarseDistinctDeg, 2 * p.voxel);
  return list;
}

// The axis most of the best candidates turn about from the first (a part of revolution seen by
// both scans: its scans fit each other turned about the axis), when two or more agree.
std::optional<Line> common_turn(const Pair& p, const std::vector<PairCandidate>& list) {
  std::vector<Line> axes;
  for (std::size_t k = 1; k < list.size(); ++k)
    if (auto l = turn_axis(list[k].T_target_source * list[0].T_target_source.inverse(), p.voxel))
      axes.push_back(*l);
  std::optional<Line> best;
  std::size_t best_support = 1;
  for (const Line& l : axes) {
    const auto support = static_cast<std::size_t>(std::count_if(
        axes.begin(), axes.end(), [&](const Line& m) { return same_line(l, m, p.c, 5, p.voxel); }));
    if (support > best_support) best = l, best_support = support;
  }
  return best;
}

// The sweep: when two or more of the best candidates turn about one axis from the first (a part
// of revolution, or nearly, seen by both scans), the first refined and turned about that axis in
// kSweepStepDeg steps; the kSweepKept turns of least free space (local minima) of at least
// min_overlap. The first candidate keeps its refined pose.
std::vector<PairCandidate> sweep(const Pair& p, std::vector<PairCandidate>& list,
                                 double min_overlap) {
  std::vector<PairCandidate> swept;
  if (list.size() < 3) return swept;
  const std::optional<Line> axis = common_turn(p, list);
  if (!axis) return swept;
  const Eigen::Isometry3d A = fine_icp(p, list[0].T_target_source);
  const int steps = static_cast<int>(std::lround(360 / kSweepStepDeg));
  std::vector<double> fs(steps);
  for (int k = 0; k < steps; ++k)
    fs[k] = free_space(p, turn(*axis, k * 360.0 / steps) * A, 1000, 2 * p.reach);
  std::vector<std::pair<double, int>> minima;
  for (int k = 1; k < steps; ++k)
    if (fs[k] <= fs[(k + steps - 1) % steps] && fs[k] <= fs[(k + 1) % steps])
      minima.emplace_back(fs[k], k);
  std::sort(minima.begin(), minima.end());
  for (std::size_t m = 0; m < std::min(kSweepKept, minima.size()); ++m) {
    PairCandidate e{p.i, p.j};
    e.T_target_source = turn(*axis, minima[m].second * 360.0 / steps) * A;
    e.overlap = overlap(p, e.T_target_source);
    if (e.overlap >= min_overlap) swept.push_back(e);
  }
  list[0].T_target_source = A;
  return swept;
}

}  // namespace

std::vector<PairCandidate> pair_candidates(std::size_t i, std::size_t j,
                                           const std::vector<ScanData>& scans,
                                           const std::vector<PairSearchScan>& search,
                                           const std::vector<DepthMap>& maps, double min_overlap) {
  const Pair p{i,
               j,
               scans[i],
               scans[j],
               search[i],
               search[j],
               maps[i],
               maps[j],
               search[i].model.voxel,
               pair_reach(scans[i], scans[j]),
               centroid(search[i].down),
               scans[i].scale.extent <= scans[j].scale.extent};
  std::vector<PairCandidate> list = coarse_candidates(p, min_overlap);
  const std::vector<PairCandidate> swept = sweep(p, list, min_overlap);
  // Step 3: the best kFineKept by overlap and the swept ones refined.
  std::vector<PairCandidate> tested(list.begin(), list.begin() + std::min(kFineKept, list.size()));
  tested.insert(tested.end(), swept.begin(), swept.end());
  std::vector<PairCandidate> out;
  for (PairCandidate e : tested) {
    e.T_target_source = fine_icp(p, e.T_target_source);
    if (!fits(p, e.T_target_source)) continue;
    e.free_space = free_space(p, e.T_target_source, kFreeSpacePoints * 2, 2 * p.reach);
    if (e.free_space > kMaxPairFreeSpace) continue;
    e.score = e.overlap - kFreeSpaceWeight * e.free_space;
    out.push_back(e);
  }
  std::stable_sort(out.begin(), out.end(), [](const PairCandidate& x, const PairCandidate& y) {
    return x.score > y.score;
  });
  keep_distinct(out, p.c, kFineDistinctDeg, p.voxel);
  if (out.size() > kKept) out.resize(kKept);
  return out;
}

}  // namespace align3d::detail
