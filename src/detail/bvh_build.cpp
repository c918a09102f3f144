#include "detail/bvh_build.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "detail/parallel.hpp"

namespace align3d::detail {
namespace {

constexpr int kBins = 16;  // SAH bins per axis
// Levels split on the calling thread; the 2^kSerialDepth subtrees below them are built in parallel.
constexpr int kSerialDepth = 3;

constexpr float kInf = std::numeric_limits<float>::infinity();

}  // namespace

float round_down(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) <= v ? f : std::nextafter(f, -std::numeric_limits<float>::max());
}
float round_up(double v) {
  const float f = static_cast<float>(v);
  return static_cast<double>(f) >= v ? f : std::nextafter(f, std::numeric_limits<float>::max());
}

namespace {

// Four lanes for three coordinates (the fourth stays 0): one SIMD min and max a box.
struct FloatBox {
  Eigen::Array4f lo = Eigen::Array4f(kInf, kInf, kInf, 0);
  Eigen::Array4f hi = Eigen::Array4f(-kInf, -kInf, -kInf, 0);
  void grow(const Eigen::Array4f& l, const Eigen::Array4f& h) {
    lo = lo.min(l);
    hi = hi.max(h);
  }
  void grow(const FloatBox& b) { grow(b.lo, b.hi); }
  double half_area() const {
    if (!(hi.x() >= lo.x())) return 0;
    const Eigen::Array4d d = (hi - lo).cast<double>();
    return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
  }
};

// A primitive as the builder moves it: its box, the box's centre and its index.
struct Ref {
  Eigen::Array4f lo, hi, centre;  // fourth lanes 0
  std::uint32_t index;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

struct Pending {  // a subtree left for the parallel stage
  std::uint32_t node, begin, end;
  int depth;
};

class Builder {
 public:
  Builder(std::vector<Ref>& refs, std::uint32_t leaf_size) : refs_(refs), leaf_size_(leaf_size) {}

  // Builds refs_[begin, end) into nodes[node] and below. With `pending`, a range at depth `stop`
  // is not built but recorded there (nodes[node] then waits for it).
  void build(std::vector<BvhNode>& nodes, std::uint32_t node, std::uint32_t begin,
             std::uint32_t end, int depth, int stop, std::vector<Pending>* pending) const {
    if (pending && depth == stop) {
      pending->push_back({node, begin, end, depth});
      return;
    }
    FloatBox box;
    const std::uint32_t mid = split(begin, end, depth, box);
    for (int k = 0; k < 3; ++k) {
      nodes[node].lo[k] = box.lo[k];
      nodes[node].hi[k] = box.hi[k];
    }
    if (mid == end) {
      nodes[node].first = begin;
      nodes[node].count = end - begin;
      return;
    }
    const auto left = static_cast<std::uint32_t>(nodes.size());
    nodes.push_back({});
    nodes.push_back({});
    nodes[node].first = left;
    nodes[node].count = 0;
    build(nodes, left, begin, mid, depth + 1, stop, pending);
    build(nodes, left + 1, mid, end, depth + 1, stop, pending);
  }

 private:
  // Sets `box` to the range's bounds and splits it in two by the surface-area heuristic over
  // kBins bins of the centres on each axis, returning the split position; or by count along the
  // centres' longest axis when no bin split exists (coincident centres) or below kMaxSahDepth.
  // Returns `end` for a leaf.
  std::uint32_t split(std::uint32_t begin, std::uint32_t end, int depth, FloatBox& box) const {
    FloatBox centres;
    for (std::uint32_t i = begin; i < end; ++i) {
      box.grow(refs_[i].lo, refs_[i].hi);
      centres.grow(refs_[i].centre, refs_[i].centre);
    }
    const std::uint32_t count = end - begin;
    if (count <= leaf_size_) return end;
    double best_cost = std::numeric_limits<double>::infinity();
    int best_axis = -1, best_split = 0;
    const Eigen::Array4f scale = bin_scale(centres);  // an axis without extent has scale 0
    if (depth < kMaxSahDepth) {
      // One pass bins every primitive on all three axes.
      std::array<std::array<FloatBox, kBins>, 3> bin_box;
      std::array<std::array<std::uint32_t, kBins>, 3> bin_count{};
      for (std::uint32_t i = begin; i < end; ++i) {
        const Eigen::Array4i b = bins(refs_[i], centres, scale);
        for (int axis = 0; axis < 3; ++axis) {
          bin_box[axis][b[axis]].grow(refs_[i].lo, refs_[i].hi);
          ++bin_count[axis][b[axis]];
        }
      }
      for (int axis = 0; axis < 3; ++axis) {
        if (scale[axis] == 0) continue;
        const std::array<FloatBox, kBins>& boxes = bin_box[axis];
        const std::array<std::uint32_t, kBins>& counts = bin_count[axis];
        std::array<double, kBins> right_cost{};
        FloatBox right;
        std::uint32_t right_n = 0;
        for (int b = kBins - 1; b > 0; --b) {
          right.grow(boxes[b]);
          right_n += counts[b];
          right_cost[b] = right.half_area() * right_n;
        }
        FloatBox left;
        std::uint32_t left_n = 0;
        for (int b = 0; b < kBins - 1; ++b) {
          left.grow(boxes[b]);
          left_n += counts[b];
          const double cost = left.half_area() * left_n + right_cost[b + 1];
          if (left_n > 0 && left_n < count && cost < best_cost) {
            best_cost = cost;
            best_axis = axis;
            best_split = b;
          }
        }
      }
    }
    if (best_axis >= 0) {
      const Ref* split = std::partition(
          refs_.data() + begin, refs_.data() + end,
          [&](const Ref& r) { return bins(r, centres, scale)[best_axis] <= best_split; });
      return static_cast<std::uint32_t>(split - refs_.data());
    }
    const std::uint32_t mid = begin + count / 2;
    Eigen::Index axis = 0;
    (centres.hi - centres.lo).head<3>().maxCoeff(&axis);
    std::nth_element(refs_.begin() + begin, refs_.begin() + mid, refs_.begin() + end,
                     [&](const Ref& a, const Ref& b) {
                       return a.centre[axis] < b.centre[axis] ||
                              (a.centre[axis] == b.centre[axis] && a.index < b.index);
                     });
    return mid;
  }

  // Bins per unit length on each axis of the centres' box; 0 where it has no extent.
  static Eigen::Array4f bin_scale(const FloatBox& centres) {
    Eigen::Array4f scale = Eigen::Array4f::Zero();
    for (int k = 0; k < 3; ++k)
      if (centres.hi[k] > centres.lo[k]) scale[k] = kBins / (centres.hi[k] - centres.lo[k]);
    return scale;
  }
  // The primitive's bin on each axis (the binning and the partition share it: the same bits).
  static Eigen::Array4i bins(const Ref& r, const FloatBox& centres, const Eigen::Array4f& scale) {
    return ((r.centre - centres.lo) * scale).cast<int>().min(kBins - 1);
  }

  std::vector<Ref>& refs_;
  std::uint32_t leaf_size_;
};

}  // namespace

Bvh build_bvh(const std::vector<Eigen::AlignedBox3d>& boxes, std::uint32_t leaf_size, int threads) {
  const std::size_t n = boxes.size();
  std::vector<Ref> refs(n);
  parallel_for(n, threads, [&](std::size_t i) {
    Ref& r = refs[i];
    const Eigen::Vector3d centre = 0.5 * (boxes[i].min() + boxes[i].max());
    for (int k = 0; k < 3; ++k) {
      r.lo[k] = round_down(boxes[i].min()[k]);
      r.hi[k] = round_up(boxes[i].max()[k]);
      r.centre[k] = static_cast<float>(centre[k]);
    }
    r.lo[3] = r.hi[3] = r.centre[3] = 0;
    r.index = static_cast<std::uint32_t>(i);
  });
  const std::uint32_t leaf = std::max<std::uint32_t>(leaf_size, 1);
  const Builder builder(refs, leaf);
  Bvh bvh;
  bvh.nodes.reserve(2 * n / leaf + 2);
  bvh.nodes.push_back({});
  std::vector<Pending> pending;
  builder.build(bvh.nodes, 0, 0, static_cast<std::uint32_t>(n), 0, kSerialDepth, &pending);
  std::vector<std::vector<BvhNode>> subtrees(pending.size());
  parallel_tasks(pending.size(), threads, [&](std::size_t i) {
    const Pending& p = pending[i];
    subtrees[i].reserve(2 * (p.end - p.begin) / leaf + 2);
    subtrees[i].push_back({});
    builder.build(subtrees[i], 0, p.begin, p.end, p.depth, 0, nullptr);
  });
  // Spliced in the order the top levels recorded them: subtree i's root replaces its placeholder
  // and the rest follows the nodes so far, its child links moved by the same offset.
  for (std::size_t i = 0; i < pending.size(); ++i) {
    const auto offset = static_cast<std::uint32_t>(bvh.nodes.size()) - 1;
    for (BvhNode& node : subtrees[i])
      if (node.count == 0) node.first += offset;
    bvh.nodes[pending[i].node] = subtrees[i][0];
    bvh.nodes.insert(bvh.nodes.end(), subtrees[i].begin() + 1, subtrees[i].end());
  }
  bvh.order.resize(n);
  for (std::size_t i = 0; i < n; ++i) bvh.order[i] = refs[i].index;
  return bvh;
}

}  // namespace align3d::detail
