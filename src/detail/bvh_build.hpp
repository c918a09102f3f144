// The bounding-volume hierarchy MeshIndex searches (mesh_index.cpp), built by binned SAH (Wald
// 2007, "On fast construction of SAH-based bounding volume hierarchies"). Our own builder: the
// ranges move through one contiguous array of 32-byte float boxes (no indirection); a node's
// bounds come from the bins that chose its parent's split and its centres' bounds from the
// partition, so each level reads the boxes twice, not three times; the subtrees below the top
// levels are built in parallel and spliced in a fixed order, so the tree is the same at any
// thread count (bench/README.md, "The mesh hierarchy").
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "detail/float_round.hpp"

namespace align3d::detail {

// A node's box in float, rounded outwards, so it still contains its primitives: 24 bytes instead
// of 48, and every lower bound computed from it stays a lower bound.
struct BvhNode {
  float lo[3], hi[3];
  std::uint32_t first;  // leaf: first primitive (in `order`); internal: left child (right = +1)
  std::uint32_t count;  // leaf: its primitives; 0: internal
};

// A primitive's bounds in float, rounded outwards (round_down, round_up: detail/float_round.hpp).
struct BvhBox {
  float lo[3], hi[3];
};

struct Bvh {
  std::vector<BvhNode> nodes;        // nodes[0]: the root
  std::vector<std::uint32_t> order;  // leaf order → the primitive's index in `boxes`
};

// At most `leaf_size` primitives a leaf, unless their centres coincide beyond kMaxSahDepth levels;
// the tree is at most kMaxDepth deep, so fixed query stacks of kMaxDepth + 1 entries suffice.
// `threads`: 0 for all cores; the tree does not depend on it. `boxes` must not be empty.
Bvh build_bvh(std::span<const BvhBox> boxes, std::uint32_t leaf_size, int threads);

constexpr int kMaxSahDepth = 64;              // deeper ranges are halved by count
constexpr int kMaxDepth = kMaxSahDepth + 32;  // halving 2^32 primitives takes 32 more levels

}  // namespace align3d::detail
