#include "align3d/kdtree.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "detail/bucket_scatter.hpp"
#include "detail/float_round.hpp"
#include "detail/parallel.hpp"

namespace align3d {

// A balanced kd-tree written for this library's queries. bench/core_bench.cpp runs it against
// the nanoflann tree it replaced on the same points (KdTreeBuild, KdTreeNearest, KdTreeKnn);
// bench/README.md has the numbers. What it does differently:
// - splits are at the median of the widest side of the node's bounding box (nth_element over
//   contiguous {point, index} entries), so the depth is log2(n / 16) whatever the data and the
//   subtrees are built in parallel (build_all);
// - the points are stored once, in leaf order, so a leaf is one contiguous run of up to 16
//   points, scanned distances first and inserts after (the scan has no branches);
// - nodes are 56 bytes in one array in depth-first order (the left child follows its parent);
//   each inner node keeps the gap between its children (left child's maximum and right child's
//   minimum along the split), which prunes the empty space between surfaces;
// - the search is nanoflann's (Arya & Mount): the squared distance from the query to the current
//   cell is updated one coordinate at a time, and a subtree is entered only if that lower bound
//   beats the current worst result, and so does the distance to the subtree's own bounding box.
//   The split planes alone never bound a flat patch along its normal (no split runs that way),
//   so a query hovering above a plane would visit every cell under it: on the 10M-point work cell
//   an unbounded query cost 7.8 µs without the box test and 0.43 µs with it;
// - results are added straight into a fixed-size sorted array (knn) or, when the order does not
//   matter, into an unsorted one whose worst entry is replaced (knn_unsorted).
// Distances are summed as dx² + dy² + dz² in double, the same bits as a brute-force scan.
struct KdTree::Impl {
  static constexpr std::uint32_t kLeafSize = 16;
  static constexpr std::uint32_t kLeaf = 3;  // Node::dim of a leaf

  struct Node {
    double low = 0;   // inner: largest coordinate of the left child along dim
    double high = 0;  // inner: smallest coordinate of the right child along dim
    // The node's bounding box in float, rounded outward (never farther than the true box).
    std::array<float, 3> min{}, max{};
    std::uint32_t begin = 0, end = 0;  // the points under this node: [begin, end) in leaf order
    std::uint32_t right = 0;           // inner: the right child (the left one is this + 1)
    std::uint32_t dim = kLeaf;
    double sq_distance(const Eigen::Vector3d& q) const {
      double sum = 0;
      for (int d = 0; d < 3; ++d) {
        const double gap = std::max(0.0, std::max(min[d] - q[d], q[d] - max[d]));
        sum += gap * gap;
      }
      return sum;
    }
  };

  std::vector<Eigen::Vector3d> points;  // in leaf order
  std::vector<std::uint32_t> original;  // point k of the leaf order is input[original[k]]
  std::vector<Node> nodes;
  Eigen::AlignedBox3d box;

  Impl(const std::vector<Eigen::Vector3d>& input, int threads) {
    const auto n = static_cast<std::uint32_t>(input.size());
    std::vector<Entry> entries(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      entries[i] = {input[i], i};
      box.extend(input[i]);
    }
    nodes.resize(n > 0 ? node_count(n) : 0);
    if (n > 0) build_all(entries, {0, n, 0, box}, n > 2 * kTaskSize ? threads : 1);
    original.resize(n);
    points.resize(n);
    for (std::uint32_t k = 0; k < n; ++k) {
      original[k] = entries[k].index;
      points[k] = entries[k].p;
    }
  }

  // Subtrees are built in parallel down to this size: a subtree's work (~0.2 ms) dwarfs its
  // hand-off, and a 5 000-point cloud still uses both cores.
  static constexpr std::uint32_t kTaskSize = 1024;

  struct Entry {
    Eigen::Vector3d p;
    std::uint32_t index;
  };

  // A subtree to build: entries[begin, end), whose bounding box is `cell`, into
  // nodes[self, self + node_count(end - begin)).
  struct Subtree {
    std::uint32_t begin = 0, end = 0, self = 0;
    Eigen::AlignedBox3d cell;
  };

  static std::uint32_t node_count(std::uint32_t n) {
    return n <= kLeafSize ? 1 : 1 + node_count(n / 2) + node_count(n - n / 2);
  }

  // Subtrees are independent (each writes its own nodes and entries), and every node is placed
  // where node_count puts it, so the tree does not depend on which thread builds what. The top
  // levels are split one level at a time, the nodes of a level in parallel, until there are
  // enough subtrees to keep the threads busy (4 per thread: their sizes differ by at most one
  // point, their cost a little) or they are down to kTaskSize; then the subtrees are built in
  // parallel. The critical path is the one of the recursive split: n + n/2 + n/4 + ...
  void build_all(std::vector<Entry>& entries, const Subtree& root, int threads) {
    const auto enough = 4 * static_cast<std::size_t>(thread_count(threads));
    std::vector<Subtree> level{root};
    // The sizes within a level differ by at most one point, so while the last is above
    // kTaskSize every node of the level splits (none is a leaf).
    while (level.size() < enough && level.back().end - level.back().begin > kTaskSize) {
      std::vector<Subtree> next(2 * level.size());
      parallel_tasks(level.size(), threads, [&](std::size_t k) {
        split(entries, level[k], next[2 * k], next[2 * k + 1]);
      });
      level = std::move(next);
    }
    parallel_tasks(level.size(), threads, [&](std::size_t k) { build(entries, level[k]); });
  }

  void build(std::vector<Entry>& entries, const Subtree& tree) {
    Subtree left, right;
    if (!split(entries, tree, left, right)) return;
    build(entries, left);
    build(entries, right);
  }

  // Writes the subtree's root node; returns false for a leaf, else true with its two children.
  bool split(std::vector<Entry>& entries, const Subtree& tree, Subtree& left, Subtree& right) {
    const auto& [begin, end, self, cell] = tree;
    Node& node = nodes[self];
    node.begin = begin;
    node.end = end;
    for (int d = 0; d < 3; ++d) {
      node.min[d] = detail::round_down(cell.min()[d]);
      node.max[d] = detail::round_up(cell.max()[d]);
    }
    if (end - begin <= kLeafSize) return false;
    int dim = 0;
    cell.sizes().maxCoeff(&dim);
    const std::uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(entries.begin() + begin, entries.begin() + mid, entries.begin() + end,
                     [dim](const Entry& a, const Entry& b) {
                       return a.p[dim] < b.p[dim] || (a.p[dim] == b.p[dim] && a.index < b.index);
                     });
    node.dim = static_cast<std::uint32_t>(dim);
    left = {begin, mid, self + 1, {}};
    right = {mid, end, self + 1 + node_count(mid - begin), {}};
    for (std::uint32_t k = begin; k < mid; ++k) left.cell.extend(entries[k].p);
    for (std::uint32_t k = mid; k < end; ++k) right.cell.extend(entries[k].p);
    node.low = left.cell.max()[dim];
    node.high = right.cell.min()[dim];
    node.right = right.self;
    return true;
  }

  // Result sets: worst() is the bound a point must beat (strictly) to be added; add(sq_d, k)
  // receives every such point with its leaf-order index.
  template <class Result>
  void search(const Eigen::Vector3d& q, Result& result) const {
    if (nodes.empty()) return;
    std::array<double, 3> offset{};  // per coordinate: squared distance from q to the cell
    double sq_cell = 0;
    for (int d = 0; d < 3; ++d) {
      const double below = box.min()[d] - q[d], above = q[d] - box.max()[d];
      const double gap = below > 0 ? below : above > 0 ? above : 0;
      offset[d] = gap * gap;
      sq_cell += offset[d];
    }
    if (sq_cell < result.worst()) descend(0, q, sq_cell, offset, result);
  }

  template <class Result>
  void descend(std::uint32_t index, const Eigen::Vector3d& q, double sq_cell,
               std::array<double, 3>& offset, Result& result) const {
    const Node& node = nodes[index];
    if (node.dim == kLeaf) {
      scan(node.begin, node.end, q, result);
      return;
    }
    const std::uint32_t d = node.dim;
    const double to_low = q[d] - node.low, to_high = q[d] - node.high;
    std::uint32_t near = index + 1, far = node.right;
    double cut = to_high * to_high;
    if (to_low + to_high >= 0) {  // nearer the right child
      std::swap(near, far);
      cut = to_low * to_low;
    }
    descend(near, q, sq_cell, offset, result);
    const double saved = offset[d];
    const double sq_far = sq_cell + cut - saved;
    if (sq_far < result.worst() && nodes[far].sq_distance(q) < result.worst()) {
      offset[d] = cut;
      descend(far, q, sq_far, offset, result);
      offset[d] = saved;
    }
  }

  template <class Result>
  void scan(std::uint32_t begin, std::uint32_t end, const Eigen::Vector3d& q,
            Result& result) const {
    std::array<double, kLeafSize> sq_d;
    const std::uint32_t n = end - begin;
    const Eigen::Vector3d* p = points.data() + begin;
    for (std::uint32_t i = 0; i < n; ++i) {
      const double dx = q.x() - p[i].x(), dy = q.y() - p[i].y(), dz = q.z() - p[i].z();
      sq_d[i] = dx * dx + dy * dy + dz * dz;
    }
    for (std::uint32_t i = 0; i < n; ++i)
      if (sq_d[i] < result.worst()) result.add(sq_d[i], begin + i);
  }
};

namespace {

struct NearestResult {
  double sq_best;
  std::uint32_t index = 0;
  bool found = false;
  double worst() const { return sq_best; }
  void add(double sq_d, std::uint32_t k) {
    sq_best = sq_d;
    index = k;
    found = true;
  }
};

// The nearest and the second nearest distance: worst() is the second's, so the search visits every
// cell that could hold a point nearer than it. The nearest is replaced only by a strictly nearer
// point, as in NearestResult, and the cells that search visits are among these, in the same order:
// the same nearest point, ties included.
struct NearestTwoResult {
  double sq_best, sq_second;
  std::uint32_t index = 0;
  bool found = false;
  double worst() const { return sq_second; }
  void add(double sq_d, std::uint32_t k) {
    if (sq_d < sq_best) {
      sq_second = sq_best;
      sq_best = sq_d;
      index = k;
      found = true;
    } else {
      sq_second = sq_d;
    }
  }
};

// The k best so far, sorted, in caller-provided storage of k entries (insertion: k is small, and
// after the first leaves few points beat the k-th).
struct KnnResult {
  Neighbor* best;
  std::size_t k;
  std::size_t count = 0;
  double worst() const {
    return count < k ? std::numeric_limits<double>::infinity() : best[k - 1].sq_distance;
  }
  void add(double sq_d, std::uint32_t index) {
    std::size_t i = count < k ? count++ : k - 1;
    for (; i > 0 && best[i - 1].sq_distance > sq_d; --i) best[i] = best[i - 1];
    best[i] = {index, sq_d};
  }
};

// The k best so far in no particular order: the worst is overwritten and the new worst found by a
// scan of the k entries. For k ≈ 20 this is ~20 % cheaper than keeping them sorted: a sorted
// insertion shifts ~170 entries per search and mispredicts where each shift loop ends.
struct KnnSetResult {
  Neighbor* best;
  std::size_t k;
  std::size_t count = 0;
  std::size_t worst_at = 0;
  double sq_worst = std::numeric_limits<double>::infinity();  // while count < k: anything goes
  double worst() const { return sq_worst; }
  void add(double sq_d, std::uint32_t index) {
    if (count < k) {
      best[count++] = {index, sq_d};
      if (count == k) find_worst();
      return;
    }
    best[worst_at] = {index, sq_d};
    find_worst();
  }
  void find_worst() {
    std::size_t at = 0;
    double sq_max = best[0].sq_distance;
    for (std::size_t i = 1; i < k; ++i) {  // branch-free: compiled to conditional moves
      const double sq_d = best[i].sq_distance;
      at = sq_d > sq_max ? i : at;
      sq_max = sq_d > sq_max ? sq_d : sq_max;
    }
    worst_at = at;
    sq_worst = sq_max;
  }
};

struct RadiusResult {
  double sq_bound;
  std::vector<Neighbor>& found;
  double worst() const { return sq_bound; }
  void add(double sq_d, std::uint32_t index) { found.push_back({index, sq_d}); }
};

}  // namespace

KdTree::KdTree(const std::vector<Eigen::Vector3d>& points, int threads) : size_(points.size()) {
  if (points.size() >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("KdTree: more than 2^32 - 1 points");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite())
      throw std::invalid_argument("KdTree: point " + std::to_string(i) +
                                  " has a NaN or infinite coordinate");
  impl_ = std::make_unique<Impl>(points, threads);
}

KdTree::~KdTree() = default;

namespace {

// The k nearest into `out` with the result type of knn (ranked) or knn_unsorted, indices mapped
// back to the input order.
template <class Result, class Impl>
void k_nearest(const Impl& impl, const Eigen::Vector3d& query, std::size_t k,
               std::vector<Neighbor>& out) {
  out.resize(k);
  if (out.empty()) return;
  Result result{out.data(), out.size()};
  impl.search(query, result);
  out.resize(result.count);  // fewer only for a NaN query
  for (auto& nb : out) nb.index = impl.original[nb.index];
}

}  // namespace

const std::vector<std::uint32_t>& KdTree::leaf_order() const { return impl_->original; }

bool KdTree::nearest(const Eigen::Vector3d& query, Neighbor& out, double sq_max_distance) const {
  NearestResult result{sq_max_distance};
  impl_->search(query, result);
  if (!result.found) return false;
  out = {impl_->original[result.index], result.sq_best};
  return true;
}

bool KdTree::nearest_two(const Eigen::Vector3d& query, Neighbor& out, double& sq_second,
                         double sq_max_distance) const {
  NearestTwoResult result{sq_max_distance, sq_max_distance};
  impl_->search(query, result);
  sq_second = result.sq_second;
  if (!result.found) return false;
  out = {impl_->original[result.index], result.sq_best};
  return true;
}

void KdTree::knn(const Eigen::Vector3d& query, std::size_t k, std::vector<Neighbor>& out) const {
  k_nearest<KnnResult>(*impl_, query, std::min(k, size_), out);
}

void KdTree::knn_unsorted(const Eigen::Vector3d& query, std::size_t k,
                          std::vector<Neighbor>& out) const {
  k_nearest<KnnSetResult>(*impl_, query, std::min(k, size_), out);
}

void KdTree::radius(const Eigen::Vector3d& query, double sq_radius,
                    std::vector<Neighbor>& out) const {
  radius_unsorted(query, sq_radius, out);
  std::sort(out.begin(), out.end(), [](const Neighbor& a, const Neighbor& b) {
    return a.sq_distance < b.sq_distance || (a.sq_distance == b.sq_distance && a.index < b.index);
  });
}

void KdTree::radius_unsorted(const Eigen::Vector3d& query, double sq_radius,
                             std::vector<Neighbor>& out) const {
  out.clear();
  // Points with d == r belong to the result: the bound to beat is one ulp above r.
  RadiusResult result{std::nextafter(sq_radius, std::numeric_limits<double>::infinity()), out};
  impl_->search(query, result);
  for (auto& nb : out) nb.index = impl_->original[nb.index];
}

namespace {

// Spreads the low 10 bits of x so that bit i lands at bit 3i.
constexpr std::uint32_t spread_bits(std::uint32_t x) {
  x = (x | x << 16) & 0x030000FFu;
  x = (x | x << 8) & 0x0300F00Fu;
  x = (x | x << 4) & 0x030C30C3u;
  x = (x | x << 2) & 0x09249249u;
  return x;
}

// spread_bits of every cell number: three lookups make a key.
constexpr std::array<std::uint32_t, 1024> kSpread = [] {
  std::array<std::uint32_t, 1024> t{};
  for (std::uint32_t x = 0; x < 1024; ++x) t[x] = spread_bits(x);
  return t;
}();

// The bounding box of the finite points, by chunks: each chunk's extremes are held in registers
// (a box extended in place through a reference is stored back at every point).
Eigen::AlignedBox3d finite_bounding_box(const std::vector<Eigen::Vector3d>& points, int threads) {
  constexpr std::size_t kChunk = std::size_t{1} << 14;
  const std::size_t chunks = (points.size() + kChunk - 1) / kChunk;
  std::vector<Eigen::AlignedBox3d> part(chunks);
  parallel_tasks(chunks, threads, [&](std::size_t c) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (std::size_t i = c * kChunk; i < std::min(points.size(), (c + 1) * kChunk); ++i) {
      if (!points[i].allFinite()) continue;
      lo = lo.cwiseMin(points[i]);
      hi = hi.cwiseMax(points[i]);
    }
    part[c] = Eigen::AlignedBox3d(lo, hi);
  });
  Eigen::AlignedBox3d box;
  for (const Eigen::AlignedBox3d& b : part)
    if (!b.isEmpty()) box.extend(b);
  return box.isEmpty() ? Eigen::AlignedBox3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero())
                       : box;
}

// Sorts the items of one bucket of spatial_order's first pass (their keys' top 10 bits are equal)
// by the key's two lower digits, stably, each of its indices going to `order`. A bucket fits in
// cache: two counting passes through a scratch array; small buckets are sorted whole (the word
// holds the key above the index, so sorting the words is the stable order too).
void sort_bucket(std::uint64_t* first, std::uint64_t* last, std::vector<std::uint64_t>& scratch,
                 std::uint32_t* order) {
  const auto size = static_cast<std::size_t>(last - first);
  if (size <= 256) {
    std::sort(first, last);
  } else {
    scratch.resize(size);
    std::uint64_t* from = first;
    std::uint64_t* to = scratch.data();
    for (int shift = 32; shift < 52; shift += 10) {  // an even number of passes: ends in place
      std::array<std::uint32_t, 1025> start{};
      for (std::size_t k = 0; k < size; ++k) ++start[((from[k] >> shift) & 1023u) + 1];
      for (std::size_t b = 1; b <= 1024; ++b) start[b] += start[b - 1];
      for (std::size_t k = 0; k < size; ++k) to[start[(from[k] >> shift) & 1023u]++] = from[k];
      std::swap(from, to);
    }
  }
  for (std::size_t k = 0; k < size; ++k) order[k] = static_cast<std::uint32_t>(first[k]);
}

}  // namespace

// A radix sort of our own, in parallel (std::sort and TBB's parallel_sort compare, O(n log n)):
// one stable pass on the key's top 10 bits over all the items (scatter_by_bucket), then each
// bucket sorted by the lower digits on its own, in cache. The order of the 2 M points of
// bench/compare_inspect.py takes 30 ms on 2 threads; three serial passes over all the items took
// 60.
std::vector<std::uint32_t> spatial_order(const std::vector<Eigen::Vector3d>& points, int threads) {
  const std::size_t n = points.size();
  if (n >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("spatial_order: more than 2^32 - 1 points");
  std::vector<std::uint32_t> order(n);
  if (n == 0) return order;
  const Eigen::AlignedBox3d box = finite_bounding_box(points, threads);
  const Eigen::Vector3d lo = box.min();
  const Eigen::Array3d scale = 1023.0 / box.sizes().array().max(1e-300);
  // Each item holds its key above its index, so the sort moves one word. Left uninitialised: the
  // threads that fill them touch their pages first.
  std::unique_ptr<std::uint64_t[]> item(new std::uint64_t[n]), sorted(new std::uint64_t[n]);
  parallel_for(n, threads, [&](std::size_t i) {
    std::uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {
      const double g = (points[i][k] - lo[k]) * scale[k];  // NaN: cell 0
      key |= std::uint64_t{kSpread[g >= 1023 ? 1023 : g > 0 ? static_cast<int>(g) : 0]} << k;
    }
    item[i] = key << 32 | i;
  });
  const std::vector<std::size_t> first = detail::scatter_by_bucket(
      item.get(), sorted.get(), n, 1024, threads, [](std::uint64_t v) { return v >> 52; });
  parallel_tasks(1024, threads, [&](std::size_t b) {
    thread_local std::vector<std::uint64_t> scratch;
    sort_bucket(&sorted[first[b]], &sorted[first[b + 1]], scratch, &order[first[b]]);
  });
  return order;
}

}  // namespace align3d
