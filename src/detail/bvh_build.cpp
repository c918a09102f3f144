#include "detail/bvh_build.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "detail/parallel.hpp"
#include "detail/uninitialized.hpp"

namespace align3d::detail {
namespace {

constexpr int kBins = 16;  // SAH bins per axis
// Ranges of at most this many primitives are halved by count: binning them cost more than the
// rest of the build (a node's 48 bins and their sweeps), for no measurable gain in the queries.
constexpr std::uint32_t kSmall = 16;
// Levels split on the calling thread; the 2^kSerialDepth subtrees below them are built in parallel.
constexpr int kSerialDepth = 3;

constexpr float kInf = std::numeric_limits<float>::infinity();

// Four lanes for three coordinates (the fourth stays 0): one SIMD min and max a box.
struct FloatBox {
  Eigen::Array4f lo = Eigen::Array4f(kInf, kInf, kInf, 0);
  Eigen::Array4f hi = Eigen::Array4f(-kInf, -kInf, -kInf, 0);
  void grow(const Eigen::Array4f& l, const Eigen::Array4f& h) {
    lo = lo.min(l);
    hi = hi.max(h);
  }
  void grow(const Eigen::Array4f& p) { grow(p, p); }
  void grow(const FloatBox& b) { grow(b.lo, b.hi); }
  double half_area() const {
    if (!(hi.x() >= lo.x())) return 0;
    const Eigen::Array4d d = (hi - lo).cast<double>();
    return d.x() * d.y() + d.y() * d.z() + d.z() * d.x();
  }
};

// A primitive as the builder moves it: its box (32 bytes); its index moves alongside, in its own
// array. lo + hi, twice its centre, is what the bins and the fallback split compare.
struct Ref {
  Eigen::Array4f lo, hi;  // fourth lanes 0
  Eigen::Array4f centre2() const { return lo + hi; }
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

// A range of refs with its box and the box of its centres (twice the centres, as centre2).
struct Range {
  std::uint32_t begin, end;
  FloatBox box, centres;
};

struct Pending {  // a subtree left for the parallel stage
  std::uint32_t node;
  Range range;
  int depth;
};

class Builder {
 public:
  Builder(UninitializedVector<Ref>& refs, std::vector<std::uint32_t>& index,
          std::uint32_t leaf_size)
      : refs_(refs), index_(index), leaf_size_(leaf_size) {}

  // Builds range r into nodes[node] and below. With `pending`, a range at depth `stop` is not
  // built but recorded there (nodes[node] then waits for it).
  void build(std::vector<BvhNode>& nodes, std::uint32_t node, const Range& r, int depth, int stop,
             std::vector<Pending>* pending) const {
    if (pending && depth == stop) {
      pending->push_back({node, r, depth});
      return;
    }
    for (int k = 0; k < 3; ++k) {
      nodes[node].lo[k] = r.box.lo[k];
      nodes[node].hi[k] = r.box.hi[k];
    }
    Range left, right;
    if (!split(r, depth, left, right)) {
      nodes[node].first = r.begin;
      nodes[node].count = r.end - r.begin;
      return;
    }
    const auto first = static_cast<std::uint32_t>(nodes.size());
    nodes.push_back({});
    nodes.push_back({});
    nodes[node].first = first;
    nodes[node].count = 0;
    build(nodes, first, left, depth + 1, stop, pending);
    build(nodes, first + 1, right, depth + 1, stop, pending);
  }

 private:
  // Splits r in two by the surface-area heuristic over kBins bins of the centres on each axis,
  // or by count along the centres' longest axis for kSmall refs or fewer, when no bin split exists
  // (coincident centres) or below kMaxSahDepth. False for a leaf.
  bool split(const Range& r, int depth, Range& left, Range& right) const {
    const std::uint32_t count = r.end - r.begin;
    if (count <= leaf_size_) return false;
    if (count <= kSmall) {
      split_by_count(r, left, right);
      return true;
    }
    const Eigen::Array4f scale = bin_scale(r.centres);  // an axis without extent has scale 0
    if (depth < kMaxSahDepth) {
      // One pass bins every primitive on all three axes.
      std::array<std::array<FloatBox, kBins>, 3> bin_box;
      std::array<std::array<std::uint32_t, kBins>, 3> bin_count{};
      for (std::uint32_t i = r.begin; i < r.end; ++i) {
        const Eigen::Array4i b = bins(refs_[i], r.centres, scale);
        for (int axis = 0; axis < 3; ++axis) {
          bin_box[axis][b[axis]].grow(refs_[i].lo, refs_[i].hi);
          ++bin_count[axis][b[axis]];
        }
      }
      int axis = -1, at = 0;
      best_split(bin_box, bin_count, count, scale, axis, at);
      if (axis >= 0) {
        left.box = right.box = FloatBox();
        for (int b = 0; b < kBins; ++b) (b <= at ? left : right).box.grow(bin_box[axis][b]);
        partition(
            r, [&](const Ref& ref) { return bins(ref, r.centres, scale)[axis] <= at; }, left,
            right);
        return true;
      }
    }
    split_by_count(r, left, right);
    return true;
  }

  static void best_split(const std::array<std::array<FloatBox, kBins>, 3>& bin_box,
                         const std::array<std::array<std::uint32_t, kBins>, 3>& bin_count,
                         std::uint32_t count, const Eigen::Array4f& scale, int& best_axis,
                         int& best_at) {
    double best_cost = std::numeric_limits<double>::infinity();
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
          best_at = b;
        }
      }
    }
  }

  // Moves the refs (and their indices) that go left before the others, growing each side's
  // centre bounds on the way; the sides' boxes are the caller's.
  template <class GoesLeft>
  void partition(const Range& r, GoesLeft&& goes_left, Range& left, Range& right) const {
    std::uint32_t i = r.begin, j = r.end;
    left.centres = right.centres = FloatBox();
    for (;;) {
      while (i < j && goes_left(refs_[i])) left.centres.grow(refs_[i++].centre2());
      while (i < j && !goes_left(refs_[j - 1])) right.centres.grow(refs_[--j].centre2());
      if (i == j) break;
      std::swap(refs_[i], refs_[j - 1]);
      std::swap(index_[i], index_[j - 1]);
    }
    left.begin = r.begin;
    left.end = right.begin = i;
    right.end = r.end;
  }

  // Halves r by count along its centres' longest axis (ties by index: the same tree every time):
  // a few refs sorted in place (insertion sort), many through a permutation (nth_element).
  void split_by_count(const Range& r, Range& left, Range& right) const {
    Eigen::Index axis = 0;
    (r.centres.hi - r.centres.lo).head<3>().maxCoeff(&axis);
    auto before = [&](std::uint32_t a, std::uint32_t b) {
      const float ca = refs_[a].centre2()[axis], cb = refs_[b].centre2()[axis];
      return ca < cb || (ca == cb && index_[a] < index_[b]);
    };
    const std::uint32_t count = r.end - r.begin, mid = r.begin + count / 2;
    if (count <= kSmall) {
      for (std::uint32_t i = r.begin + 1; i < r.end; ++i)
        for (std::uint32_t j = i; j > r.begin && before(j, j - 1); --j) {
          std::swap(refs_[j], refs_[j - 1]);
          std::swap(index_[j], index_[j - 1]);
        }
    } else {
      std::vector<std::uint32_t> at(count);
      std::iota(at.begin(), at.end(), r.begin);
      std::nth_element(at.begin(), at.begin() + (mid - r.begin), at.end(), before);
      std::vector<Ref> refs(count);
      std::vector<std::uint32_t> index(count);
      for (std::size_t k = 0; k < count; ++k) {
        refs[k] = refs_[at[k]];
        index[k] = index_[at[k]];
      }
      std::copy(refs.begin(), refs.end(), refs_.begin() + r.begin);
      std::copy(index.begin(), index.end(), index_.begin() + r.begin);
    }
    left = {r.begin, mid, {}, {}};
    right = {mid, r.end, {}, {}};
    bound(left);
    bound(right);
  }

  void bound(Range& r) const {
    for (std::uint32_t i = r.begin; i < r.end; ++i) {
      r.box.grow(refs_[i].lo, refs_[i].hi);
      r.centres.grow(refs_[i].centre2());
    }
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
    return ((r.centre2() - centres.lo) * scale).cast<int>().min(kBins - 1);
  }

  UninitializedVector<Ref>& refs_;
  std::vector<std::uint32_t>& index_;
  std::uint32_t leaf_size_;
};

}  // namespace

Bvh build_bvh(std::span<const BvhBox> boxes, std::uint32_t leaf_size, int threads) {
  const std::size_t n = boxes.size();
  UninitializedVector<Ref> refs(n);  // filled below, in parallel
  Bvh bvh;
  bvh.order.resize(n);
  Range root{0, static_cast<std::uint32_t>(n), {}, {}};
  struct Bounds {
    FloatBox box, centres;
  };
  const Bounds all = parallel_reduce(
      n, threads, Bounds{},
      [&](Bounds& acc, std::size_t i) {
        Ref& r = refs[i];
        r.lo << boxes[i].lo[0], boxes[i].lo[1], boxes[i].lo[2], 0;
        r.hi << boxes[i].hi[0], boxes[i].hi[1], boxes[i].hi[2], 0;
        bvh.order[i] = static_cast<std::uint32_t>(i);
        acc.box.grow(r.lo, r.hi);
        acc.centres.grow(r.centre2());
      },
      [](Bounds& a, const Bounds& b) {
        a.box.grow(b.box);
        a.centres.grow(b.centres);
      });
  root.box = all.box;
  root.centres = all.centres;
  const std::uint32_t leaf = std::max<std::uint32_t>(leaf_size, 1);
  const Builder builder(refs, bvh.order, leaf);
  bvh.nodes.reserve(2 * n / leaf + 2);
  bvh.nodes.push_back({});
  std::vector<Pending> pending;
  builder.build(bvh.nodes, 0, root, 0, kSerialDepth, &pending);
  std::vector<std::vector<BvhNode>> subtrees(pending.size());
  parallel_tasks(pending.size(), threads, [&](std::size_t i) {
    const Pending& p = pending[i];
    subtrees[i].reserve(2 * (p.range.end - p.range.begin) / leaf + 2);
    subtrees[i].push_back({});
    builder.build(subtrees[i], 0, p.range, p.depth, 0, nullptr);
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
  return bvh;
}

}  // namespace align3d::detail
