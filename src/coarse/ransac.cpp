// FPFH + RANSAC (coarse/global.hpp). The steps follow Open3D's
// RegistrationRANSACBasedOnFeatureMatching with its edge-length (0.9) and distance checkers, made
// deterministic for any thread count: hypothesis k draws its sample from a counter-based stream
// seeded by (seed, k), blocks of hypotheses are scored in parallel and merged in index order, and
// the stopping rule is evaluated at block boundaries that do not depend on the thread count.
// Departures from Open3D, each measured on the synthetic scenes (tests/ransac_test.cpp): isolated
// points are dropped after downsampling (drop_isolated); normals are oriented by
// orient_normals_consistently, which moves with the cloud (Open3D's sign does not, so its
// features change under a large rotation); sliver samples are rejected; descriptors are matched
// from the object's points (global.hpp); every remembered pose is refined on its inliers and the
// winner is the one that lays most of the object onto the other cloud's surface (surface_fit), not
// the one with most inliers; and distinct runner-up poses are kept for the ambiguity report.
#include "align3d/coarse/ransac.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "align3d/cloud_stats.hpp"
#include "align3d/coarse/fpfh.hpp"
#include "align3d/coarse/target_cache.hpp"
#include "align3d/error.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/kabsch.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/voxel.hpp"
#include "detail/number.hpp"
#include "detail/parallel.hpp"
#include "detail/random.hpp"

namespace align3d {
namespace {

constexpr double kFeatureRadius = 5.0;        // FPFH radius, voxels (Open3D's usual choice)
constexpr double kInlierDistance = 1.5;       // inlier / distance-checker threshold, voxels
constexpr double kEdgeRatio = 0.9;            // Open3D's CorrespondenceCheckerBasedOnEdgeLength
constexpr double kDistinctTranslation = 2.0;  // voxels (global.hpp)
constexpr int kFpfhNormalNeighbours = 20;
constexpr double kSupportRadius = 2.0;  // isolated-point filter: radius in spacings (voxels) ...
constexpr std::size_t kMinSupport = 3;  // ... and the fewest other points it must hold
constexpr std::size_t kBlock = 4096;    // hypotheses per parallel block: few, cheap regions
constexpr std::size_t kMaxPoses = 16;   // distinct poses remembered for the ambiguity report
constexpr int kRefineRounds = 3;
constexpr int kPolishIterations = 5;  // point-to-plane iterations of each remembered pose (step 6)
constexpr std::size_t kMinInliers = 9;  // 3 × the minimal sample
constexpr double kTwinSupport = 0.5;    // ambiguity: own inliers of the runner-up / winner's
constexpr double kSameBasin = 0.25;     // share of the distinct bounds: one basin (refine_and_rank)

// Squared inlier / distance-checker radius for a voxel.
double sq_inlier_radius(double voxel) {
  return (kInlierDistance * voxel) * (kInlierDistance * voxel);
}

// The stream of hypothesis k: independent of which thread evaluates it.
class HypothesisStream {
 public:
  HypothesisStream(std::uint64_t seed, std::uint64_t k) : state_(seed ^ splitmix64(k)) {}
  std::size_t below(std::size_t n) {
    state_ += 0x9e3779b97f4a7c15ULL;
    return static_cast<std::size_t>(splitmix64(state_) % n);
  }

 private:
  std::uint64_t state_;
};

using detail::fixed;

// Drops points with fewer than kMinSupport others within kSupportRadius spacings (the spacing: the
// voxel, or the median neighbour distance when the data are sparser). Downsampling keeps an
// isolated outlier as one point while it thins the surfaces, so outliers gain weight; inside a
// descriptor's radius they carry random normals into every histogram around them.
PointCloud drop_isolated(const PointCloud& down, double voxel, int threads) {
  const KdTree tree(down.positions, threads);
  const double radius = kSupportRadius * std::max(voxel, point_spacing(down, tree));
  std::vector<unsigned char> keep(down.size());
  parallel_for(down.size(), threads, [&](std::size_t i) {
    thread_local std::vector<Neighbor> nb;
    tree.radius(down.positions[i], radius * radius, nb);
    keep[i] = nb.size() >= kMinSupport + 1;
  });
  PointCloud out;
  for (std::size_t i = 0; i < down.size(); ++i)
    if (keep[i]) out.positions.push_back(down.positions[i]);
  return out;
}

}  // namespace

std::shared_ptr<const FpfhCloud> prepare_fpfh(const PointCloud& cloud, double voxel,
                                              const char* what, int threads) {
  auto made = std::make_shared<FpfhCloud>();
  FpfhCloud& out = *made;
  out.down = drop_isolated(voxel_downsample(cloud, voxel), voxel, threads);
  const std::string after = " after downsampling to voxel " + fixed(voxel, 4) +
                            " and dropping isolated points; FPFH registration needs at least 10 "
                            "(a smaller voxel keeps more)";
  if (out.down.size() < 10)
    throw DataError(what, std::to_string(out.down.size()) + " points" + after);
  try {
    check_registrable(out.down, what);
  } catch (const DataError& e) {
    throw DataError(what, e.problem() + after);
  }
  out.tree = std::make_unique<KdTree>(out.down.positions, threads);
  NormalSettings ns;
  ns.k = kFpfhNormalNeighbours;
  ns.threads = threads;
  estimate_normals(out.down, *out.tree, ns);
  const FpfhSettings fs{kFeatureRadius * voxel};
  const Neighbourhoods nb =
      radius_neighbourhoods(out.down, *out.tree, fs.radius, fs.max_neighbors, threads);
  orient_normals_consistently(out.down, nb, threads);
  out.features = compute_fpfh(out.down, nb, threads);
  return made;
}

namespace {

// The nearest descriptor of `to` (not empty) for each of `from` (exact Euclidean; a tie goes to
// the lower index). By hand on Eigen's matrix product rather than a kd-tree (nanoflann's, used
// before): in 33 dimensions a tree prunes little, and ‖a − b‖² = ‖a‖² + ‖b‖² − 2 a·b gives the
// distances of a block of queries to every descriptor as one product, in double so that near ties
// resolve as the exact distances do. On one thread, the same descriptors of the dragon's scans
// (2026-12-03, medians of 31): 1,400 × 1,500 at the default voxel, 19 ms against the tree's 45 ms
// (its build included); 3,300 × 4,900 at half that voxel, 100 against 108 ms.
std::vector<std::uint32_t> nearest_descriptors(const std::vector<FpfhDescriptor>& from,
                                               const std::vector<FpfhDescriptor>& to, int threads) {
  constexpr std::size_t kQueries = 32;  // queries a product: a block of 32 × |to| distances
  const auto m = static_cast<Eigen::Index>(to.size());
  Eigen::MatrixXd others(33, m);
  for (Eigen::Index k = 0; k < m; ++k)
    others.col(k) = to[static_cast<std::size_t>(k)].cast<double>();
  const Eigen::VectorXd norms = others.colwise().squaredNorm().transpose();
  std::vector<std::uint32_t> nearest(from.size());
  const std::size_t blocks = (from.size() + kQueries - 1) / kQueries;
  // Each block a task: parallel_for's runs of 256 items would put the 50-150 blocks of a pair of
  // scans (0.3 ms each) on one thread.
  parallel_tasks(blocks, threads, [&](std::size_t block) {
    const std::size_t first = block * kQueries;
    const std::size_t count = std::min(kQueries, from.size() - first);
    Eigen::MatrixXd queries(33, static_cast<Eigen::Index>(count));
    for (std::size_t j = 0; j < count; ++j)
      queries.col(static_cast<Eigen::Index>(j)) = from[first + j].cast<double>();
    const Eigen::MatrixXd dots = others.transpose() * queries;  // |to| × count
    for (Eigen::Index j = 0; j < dots.cols(); ++j) {
      Eigen::Index best = 0;  // ‖a‖² is the same for every k: left out
      double least = std::numeric_limits<double>::infinity();
      for (Eigen::Index k = 0; k < m; ++k) {
        const double d = norms(k) - 2.0 * dots(k, j);
        if (d < least) {
          least = d;
          best = k;
        }
      }
      nearest[first + static_cast<std::size_t>(j)] = static_cast<std::uint32_t>(best);
    }
  });
  return nearest;
}

// Paired positions, source (p) and target (q), stored contiguously for the inlier count.
struct FeatureMatches {
  std::vector<Eigen::Vector3d> p, q;
  std::size_t size() const { return p.size(); }
};

// Each point of the object (global.hpp: the smaller cloud) paired with the nearest descriptor of
// the other cloud. Matching from the object keeps the correspondences about as many as the
// object's points and their inlier share about its visible share; matched the other way, a wide
// scene's thousands of clutter points would bury the few that lie on the object.
FeatureMatches match(const FpfhCloud& source, const FpfhCloud& target, Role object, bool mutual,
                     int threads) {
  const FpfhCloud& from = object == Role::kSource ? source : target;
  const FpfhCloud& to = object == Role::kSource ? target : source;
  const std::vector<std::uint32_t> forward =
      nearest_descriptors(from.features, to.features, threads);
  std::vector<std::uint32_t> backward;
  if (mutual) backward = nearest_descriptors(to.features, from.features, threads);
  FeatureMatches c;
  for (std::size_t i = 0; i < forward.size(); ++i) {
    if (mutual && backward[forward[i]] != i) continue;
    const Eigen::Vector3d& a = from.down.positions[i];
    const Eigen::Vector3d& b = to.down.positions[forward[i]];
    c.p.push_back(object == Role::kSource ? a : b);
    c.q.push_back(object == Role::kSource ? b : a);
  }
  return c;
}

std::size_t count_inliers(const FeatureMatches& c, const Eigen::Isometry3d& T, double sq_radius) {
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  std::size_t n = 0;
  for (std::size_t i = 0; i < c.size(); ++i)
    n += (R * c.p[i] + t - c.q[i]).squaredNorm() < sq_radius;
  return n;
}

// Inliers of `T` that are not inliers of `other`.
std::size_t count_exclusive(const FeatureMatches& c, const Eigen::Isometry3d& T,
                            const Eigen::Isometry3d& other, double sq_radius) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < c.size(); ++i)
    n += (T * c.p[i] - c.q[i]).squaredNorm() < sq_radius &&
         (other * c.p[i] - c.q[i]).squaredNorm() >= sq_radius;
  return n;
}

// Kabsch on the pairs within the radius, centred for conditioning (kabsch.hpp).
Eigen::Isometry3d fit_inliers(const FeatureMatches& c, const Eigen::Isometry3d& T, double sq_radius,
                              std::size_t& used) {
  std::vector<Eigen::Vector3d> p, q;
  for (std::size_t i = 0; i < c.size(); ++i) {
    if ((T * c.p[i] - c.q[i]).squaredNorm() < sq_radius) {
      p.push_back(c.p[i]);
      q.push_back(c.q[i]);
    }
  }
  used = p.size();
  return used >= 3 ? kabsch(p, q) : T;
}

struct Pose {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  std::size_t score = 0;    // inlier correspondences
  std::uint64_t index = 0;  // hypothesis index (ties: the lower wins)
  double fit = 0;           // surface_fit of the object once refined (step 6)
};

bool better(const Pose& a, const Pose& b) {
  return a.score != b.score ? a.score > b.score : a.index < b.index;
}

// Re-estimates T on its inliers while that does not lose support (step 6).
Pose refine(const FeatureMatches& c, Pose pose, double sq_radius) {
  for (int round = 0; round < kRefineRounds; ++round) {
    std::size_t used = 0;
    const Eigen::Isometry3d T = fit_inliers(c, pose.T, sq_radius, used);
    if (used < 3) break;
    const std::size_t score = count_inliers(c, T, sq_radius);
    if (score < pose.score) break;
    pose.T = T;
    pose.score = score;
  }
  return pose;
}

// One hypothesis: a 3-sample with the edge-length check, Kabsch, the distance check, the count.
// Returns false when a checker rejects it.
bool evaluate(const FeatureMatches& c, std::uint64_t seed, std::uint64_t k, double voxel,
              double sq_radius, Pose& out) {
  HypothesisStream rng(seed, k);
  const std::size_t n = c.size();
  std::size_t s[3];
  s[0] = rng.below(n);
  do s[1] = rng.below(n);
  while (s[1] == s[0]);
  do s[2] = rng.below(n);
  while (s[2] == s[0] || s[2] == s[1]);
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      const double ds = (c.p[s[a]] - c.p[s[b]]).norm();
      const double dt = (c.q[s[a]] - c.q[s[b]]).norm();
      if (ds < kEdgeRatio * dt || dt < kEdgeRatio * ds) return false;
    }
  }
  // A sliver triangle leaves the rotation about its long side undetermined.
  if ((c.p[s[1]] - c.p[s[0]]).cross(c.p[s[2]] - c.p[s[0]]).norm() < voxel * voxel) return false;
  const Eigen::Vector3d p0 = (c.p[s[0]] + c.p[s[1]] + c.p[s[2]]) / 3.0;
  const Eigen::Vector3d q0 = (c.q[s[0]] + c.q[s[1]] + c.q[s[2]]) / 3.0;
  KabschAccumulator acc;
  for (std::size_t i : s) acc.add(c.p[i] - p0, c.q[i] - q0);
  Eigen::Isometry3d T = solve_kabsch(acc);
  T.translation() += q0 - T.linear() * p0;
  for (std::size_t i : s)
    if ((T * c.p[i] - c.q[i]).squaredNorm() >= sq_radius) return false;
  out.T = T;
  out.score = count_inliers(c, T, sq_radius);
  out.index = k;
  return true;
}

// Poses are distinct when their rotations differ by more than distinct_rotation_deg or they send
// the source centroid more than 2 voxels apart (global.hpp).
struct Distinct {
  double max_angle, sq_max_offset;
  Eigen::Vector3d centre;
  bool operator()(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) const {
    return rotation_angle(a.linear().transpose() * b.linear()) > max_angle ||
           (a * centre - b * centre).squaredNorm() > sq_max_offset;
  }
};

// The best pose of each distinct region seen so far, best first, at most kMaxPoses. Fed in
// hypothesis order, so its content does not depend on the thread count.
void remember(std::vector<Pose>& poses, const Pose& pose, const Distinct& distinct) {
  for (Pose& p : poses) {
    if (!distinct(p.T, pose.T)) {
      if (better(pose, p)) p = pose;
      std::sort(poses.begin(), poses.end(), better);
      return;
    }
  }
  poses.push_back(pose);
  std::sort(poses.begin(), poses.end(), better);
  if (poses.size() > kMaxPoses) poses.pop_back();
}

// Step 5: RANSAC in blocks; the confidence bound k = log(1 − conf) / log(1 − w³) is checked
// between blocks, w the best inlier share so far. Returns the best pose of each distinct region
// (remember), counts the accepted hypotheses in `candidates` and the drawn ones in `drawn`.
std::vector<Pose> ransac(const FeatureMatches& corr, const GlobalSettings& settings, double voxel,
                         const Distinct& distinct, std::size_t& candidates, std::uint64_t& drawn) {
  const double sq_radius = sq_inlier_radius(voxel);
  const auto max_iterations = static_cast<std::uint64_t>(std::max(0, settings.ransac_iterations));
  std::uint64_t needed = max_iterations;
  std::vector<Pose> poses;
  std::vector<Pose> block(kBlock);
  std::vector<unsigned char> accepted(kBlock);
  while (drawn < needed) {
    const std::size_t count =
        static_cast<std::size_t>(std::min<std::uint64_t>(kBlock, needed - drawn));
    parallel_for(count, settings.threads, [&](std::size_t i) {
      accepted[i] = evaluate(corr, settings.seed, drawn + i, voxel, sq_radius, block[i]);
    });
    for (std::size_t i = 0; i < count; ++i) {
      if (!accepted[i]) continue;
      ++candidates;
      remember(poses, block[i], distinct);
    }
    drawn += count;
    if (!poses.empty()) {
      const double w = static_cast<double>(poses.front().score) / static_cast<double>(corr.size());
      const double w3 = w * w * w;
      const double k = w3 >= 1 ? 0.0 : std::log(1 - settings.ransac_confidence) / std::log1p(-w3);
      if (k < static_cast<double>(needed))
        needed = std::max(drawn, static_cast<std::uint64_t>(std::ceil(k)));
    }
  }
  return poses;
}

// Throws DataError unless both clouds hold the 10 points FPFH registration needs at least.
void check_sizes(const PointCloud& source, const PointCloud& target) {
  for (const auto& [cloud, role] :
       {std::pair{&source, Role::kSource}, std::pair{&target, Role::kTarget}})
    if (cloud->size() < 10)
      throw DataError(to_string(role), std::to_string(cloud->size()) +
                                           " points; FPFH registration needs at least 10");
}

// Step 6: refine every remembered pose (a 3-point estimate ranks poses only roughly), measure how
// much of the object each lays onto the other cloud's surface, and sort them best fit first:
// inlier counts rank poses of a box-like part poorly (its flat faces give many alike descriptors,
// and a pose that slides one face onto another gathers as many inliers as the truth), the fit
// does not. The overlap is a share of the object's points (global.hpp): the source's on the
// target's surface, or the target's on the moved source's.
void refine_and_rank(std::vector<Pose>& poses, const FeatureMatches& corr, const FpfhCloud& src,
                     const FpfhCloud& tgt, Role object, double voxel, const Distinct& distinct,
                     int threads) {
  const double sq_radius = sq_inlier_radius(voxel);
  // Then a few point-to-plane iterations of the downsampled clouds within the inlier distance: a
  // pose estimated from a few dozen matched voxels is off by about a voxel across the object,
  // which on a curved object moves much of it out of surface_fit's quarter-voxel band (the
  // Stanford dragon's scans 48° apart: 0.13-0.21 of the object at the RANSAC pose, 0.42 at the
  // reference, and a wrong pose ranked first).
  IcpSettings polish;
  polish.rejection = RejectionRule::max_distance(kInlierDistance * voxel);
  polish.termination.max_iterations = kPolishIterations;
  polish.threads = threads;
  // The poses come best first (remember). One that its inliers' fit puts within a quarter of the
  // distinct bounds of a pose polished before it would be polished to where that one was (the
  // remembered poses of one basin differ by the noise of their 3-point samples: on the dragon's
  // scans 24° apart, all 16 polished to one pose, 11 of them from within 2.2° and 0.5 voxel of
  // the first): it takes over that pose and its fit instead. Not within the whole bounds: the
  // pair 312° → 48° had poses 7.5° and 1.7 voxels apart that polished to fits of 0.09 and 0.23.
  const Distinct apart{kSameBasin * distinct.max_angle,
                       kSameBasin * kSameBasin * distinct.sq_max_offset, distinct.centre};
  for (std::size_t i = 0; i < poses.size(); ++i) {
    Pose& pose = poses[i];
    pose = refine(corr, pose, sq_radius);
    const auto basin = std::find_if(poses.begin(), poses.begin() + static_cast<std::ptrdiff_t>(i),
                                    [&](const Pose& done) { return !apart(done.T, pose.T); });
    if (basin != poses.begin() + static_cast<std::ptrdiff_t>(i)) {
      pose.T = basin->T;
      pose.fit = basin->fit;
      continue;
    }
    const IcpResult r = icp(src.down, tgt.down, *tgt.tree, pose.T, polish);
    if (r.stop_reason != StopReason::kTooFewCorrespondences) pose.T = r.T_target_source;
    pose.fit = object == Role::kSource
                   ? surface_fit(src.down, tgt.down, *tgt.tree, pose.T, voxel, threads)
                   : surface_fit(tgt.down, src.down, *src.tree, pose.T.inverse(), voxel, threads);
  }
  std::sort(poses.begin(), poses.end(), [](const Pose& a, const Pose& b) {
    return a.fit != b.fit ? a.fit > b.fit : better(a, b);
  });
}

// Step 7: the result succeeds when the winner's overlap and inlier count reach their minimums;
// otherwise its message says which fell short.
void judge_success(const Pose& best, const GlobalSettings& settings, GlobalResult& result) {
  if (result.overlap < settings.min_overlap) {
    result.message = "no pose with enough support: best overlap " + fixed(result.overlap) + " < " +
                     fixed(settings.min_overlap);
  } else if (best.score < kMinInliers) {
    result.message = "no pose with enough support: " + std::to_string(best.score) +
                     " inlier correspondences < " + std::to_string(kMinInliers);
  } else {
    result.success = true;
  }
}

// Step 8: the refined poses distinct from the winner (poses[0]), best fit first; the first that
// explains the geometry about as well (overlap within ambiguity_ratio of the winner's) with its own
// evidence (at least half the winner's inlier count among correspondences that are not inliers of
// the winner) makes the result ambiguous. The second condition tells a symmetric twin (disjoint
// support) from a poor estimate of the winner's own basin just past distinct_rotation_deg (shared
// support); overlap alone cannot tell a twin from a pose that lays only the dominant plane, and
// raw inlier counts split unevenly between twins (a descriptor matches one of the symmetric
// copies at random).
void note_ambiguity(const std::vector<Pose>& poses, const FeatureMatches& corr,
                    const Distinct& distinct, double voxel, const GlobalSettings& settings,
                    GlobalResult& result) {
  const Pose& best = poses.front();
  const double sq_radius = sq_inlier_radius(voxel);
  for (std::size_t i = 1; result.success && i < poses.size(); ++i) {
    if (!distinct(poses[i].T, best.T)) continue;  // refinement joined the winner
    const Pose& second = poses[i];
    const std::size_t own = count_exclusive(corr, second.T, best.T, sq_radius);
    const double overlap = second.fit;
    if (overlap >= settings.ambiguity_ratio * result.overlap &&
        static_cast<double>(own) >= kTwinSupport * result.score && own >= kMinInliers) {
      result.ambiguous = true;
      result.second_T_target_source = second.T;
      result.second_score = static_cast<double>(second.score);
      const double angle =
          rad_to_deg(rotation_angle(best.T.linear().transpose() * second.T.linear()));
      const std::string note = "ambiguous: a pose " + fixed(angle, 1) + " deg away has overlap " +
                               fixed(overlap) + " (best " + fixed(result.overlap) + ") and " +
                               std::to_string(second.score) + " inliers (best " +
                               std::to_string(best.score) + ")";
      result.message = note;
      break;
    }
  }
}

}  // namespace

GlobalResult fpfh_ransac_register(const PointCloud& source, const PointCloud& target,
                                  const GlobalSettings& settings, const GlobalContext& context) {
  const auto start = std::chrono::steady_clock::now();
  GlobalResult result;
  result.method = GlobalMethod::kFpfh;
  check_sizes(source, target);
  const GlobalPlan plan = plan_global(source, target, settings, context);
  const double voxel = plan.voxel;
  result.object = plan.object;
  result.voxel = voxel;
  const int threads = settings.threads;

  // Steps 1-3: downsample, normals, descriptors. The clouds at the voxel hold a few thousand
  // points (scale.cpp), whose loops keep two threads only two-thirds busy: on two threads the two
  // sides are prepared side by side instead, each on one (the same bits either way). On the
  // dragon's scans 24° apart, the stage's time from 60 to 53 ms.
  // A side's error is kept and the source's rethrown first, as when they ran in turn.
  std::shared_ptr<const FpfhCloud> src_ptr, tgt_ptr;
  std::array<std::exception_ptr, 2> failed;
  const bool side_by_side = thread_count(threads) == 2;
  parallel_tasks(2, side_by_side ? 2 : 1, [&](std::size_t side) {
    const int inner = side_by_side ? 1 : threads;
    try {
      if (side == 0)
        src_ptr = prepare_fpfh(source, voxel, "source", inner);
      else
        tgt_ptr = context.target_cache ? context.target_cache->fpfh(voxel, inner)
                                       : prepare_fpfh(target, voxel, "target", inner);
    } catch (...) {
      failed[side] = std::current_exception();
    }
  });
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
  const FpfhCloud &src = *src_ptr, &tgt = *tgt_ptr;
  // Step 4: descriptor nearest neighbours.
  const FeatureMatches corr = match(src, tgt, result.object, settings.mutual_filter, threads);

  const Distinct distinct{deg_to_rad(settings.distinct_rotation_deg),
                          (kDistinctTranslation * voxel) * (kDistinctTranslation * voxel),
                          centroid(src.down)};
  auto finish = [&](GlobalResult& r) {
    r.time_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return r;
  };
  if (corr.size() < 3) {
    result.message = "only " + std::to_string(corr.size()) + " descriptor correspondences";
    return finish(result);
  }

  // Step 5: RANSAC.
  std::uint64_t drawn = 0;
  std::vector<Pose> poses = ransac(corr, settings, voxel, distinct, result.candidates, drawn);
  if (poses.empty()) {
    result.message = "no pose with enough support: none of " + std::to_string(drawn) +
                     " hypotheses passed the consistency checks";
    return finish(result);
  }

  refine_and_rank(poses, corr, src, tgt, result.object, voxel, distinct, threads);
  const Pose& best = poses.front();
  result.T_target_source = best.T;
  result.score = static_cast<double>(best.score);
  result.overlap = best.fit;
  judge_success(best, settings, result);
  note_ambiguity(poses, corr, distinct, voxel, settings, result);
  return finish(result);
}

}  // namespace align3d
