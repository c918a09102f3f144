#include "align3d/voxel.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace align3d {

namespace {

// The label most of order[begin, end) carry, the smallest on a tie.
std::int32_t majority(const std::vector<std::pair<std::uint64_t, std::uint32_t>>& order,
                      std::size_t begin, std::size_t end, const std::vector<std::int32_t>& labels) {
  std::vector<std::int32_t> seen;
  for (std::size_t i = begin; i < end; ++i) seen.push_back(labels[order[i].second]);
  std::sort(seen.begin(), seen.end());
  std::int32_t best = seen.front();
  std::size_t best_run = 0;
  for (std::size_t i = 0; i < seen.size();) {
    std::size_t j = i;
    while (j < seen.size() && seen[j] == seen[i]) ++j;
    if (j - i > best_run) best = seen[i], best_run = j - i;
    i = j;
  }
  return best;
}

PointCloud downsample(const PointCloud& cloud, double voxel,
                      const std::vector<std::int32_t>* labels,
                      std::vector<std::int32_t>* out_labels) {
  if (!(voxel > 0) || !std::isfinite(voxel))
    throw std::invalid_argument("voxel_downsample: voxel size must be positive");
  PointCloud out;
  if (cloud.empty()) return out;
  Eigen::AlignedBox3d box;
  for (const auto& p : cloud.positions) box.extend(p);
  const Eigen::Vector3d cells = (box.sizes() / voxel).array().floor() + 1;
  constexpr double kMaxCells = 1 << 21;  // 21 bits per axis packed into one 64-bit key
  if ((cells.array() > kMaxCells).any())
    throw std::invalid_argument("voxel_downsample: voxel too small for the cloud's extent");
  auto key = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d c = ((p - box.min()) / voxel).array().floor();
    return (static_cast<std::uint64_t>(c.x()) << 42) | (static_cast<std::uint64_t>(c.y()) << 21) |
           static_cast<std::uint64_t>(c.z());
  };
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    order[i] = {key(cloud.positions[i]), static_cast<std::uint32_t>(i)};
  std::sort(order.begin(), order.end());
  const bool normals = cloud.has_normals();
  for (std::size_t begin = 0; begin < order.size();) {
    std::size_t end = begin;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), nsum = Eigen::Vector3d::Zero();
    for (; end < order.size() && order[end].first == order[begin].first; ++end) {
      sum += cloud.positions[order[end].second];
      if (normals) nsum += cloud.normals[order[end].second];
    }
    out.positions.push_back(sum / static_cast<double>(end - begin));
    if (normals)
      out.normals.push_back(nsum.norm() > 0 ? Eigen::Vector3d(nsum.normalized())
                                            : cloud.normals[order[begin].second]);
    if (labels) out_labels->push_back(majority(order, begin, end, *labels));
    begin = end;
  }
  return out;
}

}  // namespace

PointCloud voxel_downsample(const PointCloud& cloud, double voxel) {
  return downsample(cloud, voxel, nullptr, nullptr);
}

PointCloud voxel_downsample(const PointCloud& cloud, double voxel,
                            const std::vector<std::int32_t>& labels,
                            std::vector<std::int32_t>& out_labels) {
  if (labels.size() != cloud.size())
    throw std::invalid_argument("voxel_downsample: one label per point is needed");
  out_labels.clear();
  return downsample(cloud, voxel, &labels, &out_labels);
}

}  // namespace align3d
