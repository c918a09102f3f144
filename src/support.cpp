#include "align3d/support.hpp"

#include <algorithm>
#include <cmath>

#include "align3d/cloud_stats.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr double kReachSpacings = 1.5, kReachSigmas = 3.0;  // support.hpp
constexpr double kBandSigmas = 3.0, kBandSpacings = 0.1;
constexpr std::size_t kMaxTested = 50000;

// Every m-th index of [0, n), at most kMaxTested of them.
std::vector<std::uint32_t> evenly(std::size_t n) {
  const std::size_t step = (n + kMaxTested - 1) / kMaxTested;
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < n; i += std::max<std::size_t>(1, step))
    out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

}  // namespace

SupportMeter::SupportMeter(const PointCloud& source, RefineTarget& target, int threads)
    : source_(source), target_(target), threads_(threads) {
  source_tree_ = std::make_unique<KdTree>(source.positions, threads);
  const PointCloud& t = target.cloud();
  const double noise_s = surface_noise(source, *source_tree_);
  const double noise_t = surface_noise(t, target.tree());
  base_.noise = std::sqrt(noise_s * noise_s + noise_t * noise_t);
  base_.spacing = std::max(point_spacing(source, *source_tree_), target.spacing());
  base_.reach = kReachSpacings * base_.spacing + kReachSigmas * base_.noise;
  base_.band = std::max(kBandSigmas * base_.noise, kBandSpacings * base_.spacing);
  base_.object = object_role(source, t);
}

SupportMeter::~SupportMeter() = default;

Support SupportMeter::measure(const Eigen::Isometry3d& T) {
  Support out = base_;
  const PointCloud& t = target_.cloud();
  const bool source_object = base_.object == Role::kSource;
  const std::vector<std::uint32_t> tested = evenly(source_object ? source_.size() : t.size());
  const double sq_reach = out.reach * out.reach;
  const Eigen::Isometry3d T_inv = T.inverse();
  // Pairs (source index, target index) of the tested object points with a partner within reach.
  std::vector<std::uint32_t> src(tested.size()), tgt(tested.size());
  std::vector<unsigned char> found(tested.size(), 0);
  parallel_for(tested.size(), threads_, [&](std::size_t k) {
    Neighbor nb;
    if (source_object) {
      src[k] = tested[k];
      found[k] = t.size() && target_.tree().nearest(T * source_.positions[tested[k]], nb, sq_reach);
      tgt[k] = static_cast<std::uint32_t>(nb.index);
    } else {
      tgt[k] = tested[k];
      found[k] = source_tree_->nearest(T_inv * t.positions[tested[k]], nb, sq_reach);
      src[k] = static_cast<std::uint32_t>(nb.index);
    }
  });
  std::vector<std::uint32_t> partners;
  for (std::size_t k = 0; k < tested.size(); ++k)
    if (found[k]) partners.push_back(tgt[k]);
  const std::vector<Eigen::Vector3d>& normals = target_.normals(partners);
  const std::size_t on = parallel_reduce(
      tested.size(), threads_, std::size_t{0},
      [&](std::size_t& n, std::size_t k) {
        if (!found[k]) return;
        const Eigen::Vector3d d = T * source_.positions[src[k]] - t.positions[tgt[k]];
        n += std::abs(normals[tgt[k]].dot(d)) <= out.band;
      },
      [](std::size_t& a, std::size_t b) { a += b; });
  out.overlap = tested.empty() ? 0.0 : static_cast<double>(on) / static_cast<double>(tested.size());
  return out;
}

}  // namespace align3d
