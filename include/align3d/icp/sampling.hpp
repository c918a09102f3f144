// Which of a cloud's points an ICP pairs when not every one: geometrically stable sampling
// (Gelfand, Ikemoto, Rusinkiewicz and Levoy 2003, "Geometrically stable sampling for the ICP
// algorithm"), by leverage. Each point with its normal gives the point-to-plane row
// J = ((p − c) × n, n) about the points' centroid c; its leverage Jᵀ·H⁺·J (H = Σ J·Jᵀ, H⁺ its
// pseudo-inverse) is the share of the cloud's information about the pose that point holds, the
// same in any units. Where the surface leaves a direction nearly free (a turned part's rotation
// about its axis) only a few points hold it (the faces of a key or a lug): an every-m-th sample
// keeps few of them, this one all.
#pragma once

#include <cstdint>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d {

// Ascending indices into `cloud`: the `top` share of its points of most leverage (ties: the lower
// index first), then every m-th of the others in index order, about `share` of the points in all
// (at least the top ones; every point when share ≥ 1). std::invalid_argument for shares outside
// [0, 1] (share below top is taken as top) and a cloud of points without normals.
std::vector<std::uint32_t> stable_sample(const PointCloud& cloud, double share, double top);

}  // namespace align3d
