// The scans of a stitch as every step uses them, and the test that two scans at a relative pose do
// not contradict each other: what one sensor saw through, the other must not put a surface in.
// Internal to the stitch engine (stitch.hpp describes the steps).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "align3d/cloud_stats.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/stitch.hpp"

namespace align3d::detail {

// A scan: its points with normals towards its sensor, its tree and scale, and where its sensor
// was (in its own frame) and how that is known.
struct ScanData {
  PointCloud cloud;
  std::unique_ptr<KdTree> tree;
  CloudScale scale;
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();
  SensorSource sensor = SensorSource::kGiven;
};

// Checks each scan (DataError "scan k" when one cannot be registered), places its sensor (the
// viewpoint given; else the frame's origin unless hidden_share says the scan was not seen from
// there; else estimated_viewpoint, normals.hpp), estimates its normals towards it and measures its
// scale. `viewpoints`: one per scan, or empty (none known).
std::vector<ScanData> prepare_scans(const std::vector<PointCloud>& scans,
                                    const std::vector<std::optional<Eigen::Vector3d>>& viewpoints,
                                    int threads);

// The share of a scan's points its sensor (ScanData::viewpoint) could not have seen: behind it, or
// more than a few spacings behind another of the scan's points in the same direction (a bin of
// depth_map). Near 0 for the sensor that made the scan; large for a point under or inside the
// object (a turntable scanner's coordinates). Over every m-th point, at most ~2000.
double hidden_share(const ScanData& scan);

// The object's size: the largest robust extent of a scan (cloud_stats.hpp).
double largest_extent(const std::vector<ScanData>& scans);

// The least m ≥ 1 such that every m-th of `size` points are at most `count` (≥ 1).
std::size_t every_mth_step(std::size_t size, std::size_t count);
// Every m-th point (and normal) of `cloud`, m = every_mth_step(cloud.size(), count).
PointCloud every_mth(const PointCloud& cloud, std::size_t count);

// A pair's reach: a few spacings and noise levels of the coarser of the two.
double pair_reach(const ScanData& a, const ScanData& b);

// What a scan's sensor saw, as a depth map: the scan's points binned by direction from the
// viewpoint (a virtual pinhole along their mean direction, bins of about two point spacings at the
// median depth), each bin holding the nearest depth seen in it.
struct DepthMap {
  Eigen::Vector3d viewpoint, e1, e2, axis;
  double bin = 1;
  std::unordered_map<std::uint64_t, double> nearest;
  // The bin of x and its depth along the axis; nothing when x is behind the sensor or far off.
  std::optional<std::uint64_t> key(const Eigen::Vector3d& x, double& depth) const;
};
DepthMap depth_map(const ScanData& scan);

// Which points a free-space count takes: all, or those whose surface faces the other sensor at
// less than 70° from its line of sight, every `stride`-th.
struct FreeSpacePoints {
  bool facing_only = false;
  std::size_t stride = 1;
};

// The share of `scan`'s points, moved by T into the frame of the scan `map` was made of, that lie
// in front of what that sensor saw (by more than `margin`): the sensor would have seen them
// there, so the pose is wrong. Only points in directions the sensor saw anything count.
double free_space_share(const ScanData& scan, const Eigen::Isometry3d& T, const DepthMap& map,
                        double margin, FreeSpacePoints which = {});

// What a share of points in front of what `seen_by`'s sensor saw counts for is divided by: 1 for
// a sensor given or at the origin, kEstimatedSlack (3) for an estimated one, whose lines of sight
// are off by up to some 30° (every free-space test of the engine reads shares through this).
double free_space_slack(const ScanData& seen_by);

// The larger of the two shares of a pair's points in front of what the other sensor saw, each
// divided by that sensor's free_space_slack; T maps a into b's frame.
double pair_free_space(const ScanData& a, const ScanData& b, const DepthMap& map_a,
                       const DepthMap& map_b, const Eigen::Isometry3d& T, double margin,
                       FreeSpacePoints which = {});

// pair_free_space over the points that face the other sensor, every m-th, m such that the larger
// scan gives at most about `points` (the engine's steps test a pair this way, each with its own
// budget and margin).
double facing_free_space(const ScanData& a, const ScanData& b, const DepthMap& map_a,
                         const DepthMap& map_b, const Eigen::Isometry3d& T, double margin,
                         std::size_t points);

}  // namespace align3d::detail
