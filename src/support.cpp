#include "align3d/support.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "align3d/cloud_stats.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr double kReachSpacings = 1.5, kReachSigmas = 3.0;  // support.hpp
constexpr double kBandSigmas = 3.0, kBandSpacings = 0.1;
constexpr std::size_t kMaxTested = 50000;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();  // no partner

// Every m-th index of [0, n), at most kMaxTested of them.
std::vector<std::uint32_t> evenly(std::size_t n) {
  const std::size_t step = std::max<std::size_t>(1, (n + kMaxTested - 1) / kMaxTested);
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < n; i += step) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

// `given`, or a tree built into `own`.
const KdTree* tree_for(const PointCloud& cloud, const KdTree* given, std::unique_ptr<KdTree>& own,
                       int threads) {
  if (given) return given;
  own = std::make_unique<KdTree>(cloud.positions, threads);
  return own.get();
}

}  // namespace

SupportMeter::SupportMeter(const PointCloud& source, const PointCloud& target, int threads,
                           const KdTree* source_tree, const KdTree* target_tree,
                           const CloudScale* source_scale, const CloudScale* target_scale,
                           NormalCache* target_normals)
    : source_(source), target_(target), threads_(threads) {
  source_tree_ = tree_for(source, source_tree, own_source_tree_, threads);
  target_tree_ = tree_for(target, target_tree, own_target_tree_, threads);
  const CloudScale s = source_scale ? *source_scale : measure_scale(source, *source_tree_, threads);
  const CloudScale t = target_scale ? *target_scale : measure_scale(target, *target_tree_, threads);
  base_.noise = std::sqrt(s.noise * s.noise + t.noise * t.noise);
  base_.spacing = std::max(s.spacing, t.spacing);
  base_.reach = kReachSpacings * base_.spacing + kReachSigmas * base_.noise;
  base_.band = std::max(kBandSigmas * base_.noise, kBandSpacings * base_.spacing);
  base_.object = object_role(s, t);
  NormalSettings ns;
  ns.threads = threads;
  if (target_normals && &target_normals->cloud() == &target &&
      target_normals->settings().k == ns.k) {
    target_normals_ = target_normals;
    return;
  }
  own_normals_ = std::make_unique<NormalCache>(target, *target_tree_, ns);
  target_normals_ = own_normals_.get();
}

SupportMeter::~SupportMeter() = default;

Support SupportMeter::measure(const Eigen::Isometry3d& T, double structured) {
  Support out = base_;
  if (structured > 0) {
    out.structured = structured;
    const double noise = std::hypot(out.noise, structured);
    out.reach = kReachSpacings * out.spacing + kReachSigmas * noise;
    out.band = std::max(kBandSigmas * noise, kBandSpacings * out.spacing);
  }
  const bool source_object = base_.object == Role::kSource;
  const PointCloud& object = source_object ? source_ : target_;
  const PointCloud& other = source_object ? target_ : source_;
  const KdTree& other_tree = source_object ? *target_tree_ : *source_tree_;
  // The object's points in the other cloud's frame.
  const Eigen::Isometry3d M = source_object ? T : T.inverse();
  const std::vector<std::uint32_t> tested = evenly(object.size());
  const double sq_reach = out.reach * out.reach;
  // Each tested point's nearest point of the other cloud within reach.
  std::vector<std::uint32_t> partner(tested.size(), kNone);
  parallel_for(tested.size(), threads_, [&](std::size_t k) {
    Neighbor nb;
    if (other_tree.nearest(M * object.positions[tested[k]], nb, sq_reach)) partner[k] = nb.index;
  });
  // The tangent plane is the target's, at the object point or at its partner: the normals the
  // ICP's point-to-plane pairs already estimated (the shared cache), not a second set of the
  // source's (a 40k-point scan: ~10 % of a registration).
  std::vector<std::uint32_t> planes;
  if (source_object) {
    for (std::uint32_t i : partner)
      if (i != kNone) planes.push_back(i);
  } else {
    for (std::size_t k = 0; k < tested.size(); ++k)
      if (partner[k] != kNone) planes.push_back(tested[k]);
  }
  target_normals_->require(planes);
  const std::vector<Eigen::Vector3d>& normals = target_normals_->normals();
  const std::size_t on = parallel_reduce(
      tested.size(), threads_, std::size_t{0},
      [&](std::size_t& n, std::size_t k) {
        if (partner[k] == kNone) return;
        const Eigen::Vector3d x = M * object.positions[tested[k]];
        // In the other cloud's frame: the partner's is there already, the object point's turns.
        const Eigen::Vector3d normal =
            source_object ? normals[partner[k]] : Eigen::Vector3d(M.linear() * normals[tested[k]]);
        n += std::abs(normal.dot(other.positions[partner[k]] - x)) <= out.band;
      },
      [](std::size_t& a, std::size_t b) { a += b; });
  out.overlap = tested.empty() ? 0.0 : static_cast<double>(on) / static_cast<double>(tested.size());
  return out;
}

}  // namespace align3d
