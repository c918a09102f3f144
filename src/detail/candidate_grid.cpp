#include "detail/candidate_grid.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "detail/parallel.hpp"

namespace align3d::detail {
namespace {

constexpr double kCellsPerTriangleSide = 0.7;  // cell side = this × √(mean triangle area)
constexpr double kReachFraction = 0.125;       // reach = this × cell side
// Triangles are listed for a slightly larger cube than the reach queries trust, so a triangle
// that rounding would place just outside is never missing from a cell.
constexpr double kListingMargin = 1e-9;
constexpr double kRowSlack = 1e-6;
constexpr std::size_t kChunk = 1024;  // triangles a listing task takes

// The separating-axis test of a triangle against axis-aligned cubes of half-size h (Akenine-Möller
// 2001), prepared once per triangle: its normal and the nine products of a cube axis with an edge,
// each with the interval the triangle projects to. The cube's own three axes are the caller's box
// range. A cube centred at c misses the triangle when, on some axis d, the triangle's interval
// minus d·c lies beyond ±h·|d|₁.
class SeparatingAxes {
 public:
  SeparatingAxes(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                 double h) {
    add(a, b, c, h, (b - a).cross(c - a));
    const Eigen::Vector3d edges[3] = {b - a, c - b, a - c};
    for (const Eigen::Vector3d& e : edges)
      for (int k = 0; k < 3; ++k) add(a, b, c, h, Eigen::Vector3d::Unit(k).cross(e));
  }
  // The cubes centred at row0 + x·step·e_axis meet the triangle for x in [from, to] (continuous;
  // empty when from > to): on each axis d the test lo − r ≤ d·centre ≤ hi + r is linear in x, so
  // a row of cells costs ten interval intersections instead of ten dot products a cell. `step`
  // and the row's axis must be the ones given to prepare_rows.
  void row(const Eigen::Vector3d& row0, double& from, double& to) const {
    for (int i = 0; i < count_ && from <= to; ++i) {
      const double p0 = axes_[i].dot(row0);
      const double low = lo_[i] - r_[i] - p0, high = hi_[i] + r_[i] - p0;
      if (inv_dp_[i] > 0) {
        from = std::max(from, low * inv_dp_[i]);
        to = std::min(to, high * inv_dp_[i]);
      } else if (inv_dp_[i] < 0) {
        from = std::max(from, high * inv_dp_[i]);
        to = std::min(to, low * inv_dp_[i]);
      } else if (low > 0 || high < 0) {
        to = -std::numeric_limits<double>::infinity();
      }
    }
  }
  void prepare_rows(double step, int axis) {
    for (int i = 0; i < count_; ++i) {
      const double dp = axes_[i][axis] * step;
      inv_dp_[i] = dp != 0 ? 1 / dp : 0;
    }
  }

 private:
  void add(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, double h,
           const Eigen::Vector3d& d) {
    if (d.squaredNorm() == 0) return;  // an edge along a cube axis: no axis
    const double pa = d.dot(a), pb = d.dot(b), pc = d.dot(c);
    axes_[count_] = d;
    lo_[count_] = std::min({pa, pb, pc});
    hi_[count_] = std::max({pa, pb, pc});
    r_[count_] = h * d.cwiseAbs().sum();
    ++count_;
  }
  Eigen::Vector3d axes_[10];
  double lo_[10], hi_[10], r_[10], inv_dp_[10];
  int count_ = 0;
};

}  // namespace

CandidateGrid::CandidateGrid(const TriangleMesh& mesh, const std::vector<std::uint32_t>& order,
                             const Eigen::AlignedBox3d& box, double area, int threads) {
  if (order.empty() || !(area > 0)) return;
  size_cells(box, area / static_cast<double>(order.size()));
  const Pairs pairs = list(mesh, order, threads);
  if (pairs.total <= kMaxEntries) lay_out(pairs, threads);  // else no grid: the hierarchy answers
}

void CandidateGrid::size_cells(const Eigen::AlignedBox3d& box, double mean_area) {
  const Eigen::Vector3d lo = box.min(), hi = box.max();
  cell_ = kCellsPerTriangleSide * std::sqrt(mean_area);
  cell_ = std::max(cell_, 1e-9 * (hi - lo).norm());
  for (;;) {  // coarser cells until the grid fits
    reach_ = kReachFraction * cell_;
    std::size_t cells = 1;
    for (int k = 0; k < 3; ++k) {
      dims_[k] = static_cast<std::int64_t>(std::floor((hi[k] - lo[k] + 2 * reach_) / cell_)) + 1;
      cells *= static_cast<std::size_t>(dims_[k]);
    }
    if (cells <= kMaxCells) break;
    cell_ *= 1.05 * std::cbrt(static_cast<double>(cells) / kMaxCells);
  }
  inv_cell_ = 1.0 / cell_;
  origin_ = lo - Eigen::Vector3d::Constant(reach_);
  for (int k = 0; k < 3; ++k) blocks_[k] = (dims_[k] + kBlock - 1) / kBlock;
}

// Each triangle visits the cells its box, grown by the reach, overlaps, and is listed where it
// meets the grown cell: in parallel over fixed chunks of triangles, each chunk's (cell, triangle)
// pairs kept apart by slice (a slab of blocks), so that lay_out can give each slice to a thread.
CandidateGrid::Pairs CandidateGrid::list(const TriangleMesh& mesh,
                                         const std::vector<std::uint32_t>& order,
                                         int threads) const {
  const std::size_t n = order.size();
  const double half = (0.5 * cell_ + reach_) * (1 + kListingMargin);
  Pairs pairs;
  pairs.blocks = static_cast<std::size_t>(blocks_[0] * blocks_[1] * blocks_[2]);
  pairs.chunks = (n + kChunk - 1) / kChunk;
  pairs.slices = std::min<std::size_t>(kSlices, pairs.blocks);
  pairs.per_slice = (pairs.blocks + pairs.slices - 1) / pairs.slices;
  pairs.of.resize(pairs.chunks * pairs.slices);
  parallel_tasks(pairs.chunks, threads, [&](std::size_t chunk) {
    // Listed into a scratch array first, then copied to each slice's array at its final size:
    // growing 16 arrays a chunk touched twice the memory, and fresh pages cost as much as the
    // listing.
    thread_local std::vector<std::uint32_t> scratch;
    scratch.clear();
    for (std::size_t i = chunk * kChunk; i < std::min(n, (chunk + 1) * kChunk); ++i) {
      const auto& t = mesh.triangles[order[i]];
      list_triangle(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], half,
                    [&](std::uint32_t key) {
                      scratch.push_back(key);
                      scratch.push_back(static_cast<std::uint32_t>(i));
                    });
    }
    std::array<std::size_t, kSlices> count{};
    for (std::size_t j = 0; j < scratch.size(); j += 2) count[pairs.slice(scratch[j])] += 2;
    for (std::size_t s = 0; s < pairs.slices; ++s)
      pairs.of[chunk * pairs.slices + s].reserve(count[s]);
    for (std::size_t j = 0; j < scratch.size(); j += 2) {
      std::vector<std::uint32_t>& p = pairs.of[chunk * pairs.slices + pairs.slice(scratch[j])];
      p.push_back(scratch[j]);
      p.push_back(scratch[j + 1]);
    }
  });
  for (const auto& p : pairs.of) pairs.total += p.size() / 2;
  return pairs;
}

// The lists in CSR form. Each slice lays out its own cells, reading the chunks in order: the
// lists do not depend on the threads, and the layout, sequential before, runs in parallel too (a
// third of the grid's time on 200 k triangles). Only blocks holding a candidate get cells,
// numbered block after block: first within each slice, then shifted by the slices before it.
void CandidateGrid::lay_out(const Pairs& pairs, int threads) {
  const std::size_t slices = pairs.slices;
  auto for_pairs = [&](std::size_t slice, auto&& f) {  // a slice's pairs, chunk after chunk
    for (std::size_t chunk = 0; chunk < pairs.chunks; ++chunk) {
      const std::vector<std::uint32_t>& p = pairs.of[chunk * slices + slice];
      for (std::size_t j = 0; j < p.size(); j += 2) f(p[j], p[j + 1]);
    }
  };
  auto slice_blocks = [&](std::size_t s, auto&& f) {
    for (std::size_t k = s * pairs.per_slice; k < std::min(pairs.blocks, (s + 1) * pairs.per_slice);
         ++k)
      if (block_first_[k] != kNoBlock) f(block_first_[k]);
  };
  block_first_.assign(pairs.blocks, kNoBlock);
  std::vector<std::uint32_t> cell_base(slices + 1, 0), entry_base(slices + 1, 0);
  parallel_tasks(slices, threads, [&](std::size_t s) {
    for_pairs(s, [&](std::uint32_t key, std::uint32_t) {
      block_first_[key / kBlockCells] = 0;
      ++entry_base[s + 1];
    });
    std::uint32_t used = 0;
    slice_blocks(s, [&](std::uint32_t& first) { first = std::exchange(used, used + kBlockCells); });
    cell_base[s + 1] = used;
  });
  for (std::size_t s = 0; s < slices; ++s) {
    cell_base[s + 1] += cell_base[s];
    entry_base[s + 1] += entry_base[s];
  }
  auto cell_of = [&](std::uint32_t key) {
    return block_first_[key / kBlockCells] + key % kBlockCells;
  };
  // Sized uninitialised: each slice zeroes and fills its own cells, in parallel.
  UninitializedVector<std::uint32_t> next(cell_base[slices]);  // counts, then each next slot
  offsets_.resize(std::size_t{cell_base[slices]} + 1);
  offsets_[0] = 0;
  entries_.resize(pairs.total);
  parallel_tasks(slices, threads, [&](std::size_t s) {
    std::fill(next.begin() + cell_base[s], next.begin() + cell_base[s + 1], 0);
    slice_blocks(s, [&](std::uint32_t& first) { first += cell_base[s]; });
    for_pairs(s, [&](std::uint32_t key, std::uint32_t) { ++next[cell_of(key)]; });
    std::uint32_t start = entry_base[s];
    for (std::uint32_t k = cell_base[s]; k < cell_base[s + 1]; ++k) {
      const std::uint32_t count = next[k];
      next[k] = start;
      start += count;
    }
    for_pairs(s, [&](std::uint32_t key, std::uint32_t t) { entries_[next[cell_of(key)]++] = t; });
    for (std::uint32_t k = cell_base[s]; k < cell_base[s + 1]; ++k) offsets_[k + 1] = next[k];
  });
}

template <class F>
void CandidateGrid::list_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& c, double half, F&& f) const {
  const Eigen::Vector3d tlo = a.cwiseMin(b).cwiseMin(c), thi = a.cwiseMax(b).cwiseMax(c);
  std::int64_t from[3], to[3];
  for (int k = 0; k < 3; ++k) {
    from[k] = std::max<std::int64_t>(
        0, static_cast<std::int64_t>(std::floor((tlo[k] - reach_ - origin_[k]) * inv_cell_)));
    to[k] = std::min<std::int64_t>(
        dims_[k] - 1,
        static_cast<std::int64_t>(std::floor((thi[k] + reach_ - origin_[k]) * inv_cell_)));
  }
  // Rows run along the axis the box is longest on: the fewest rows (a face across x, listed in
  // rows along x, took one row a cell).
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (to[k] - from[k] > to[axis] - from[axis]) axis = k;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  SeparatingAxes sat(a, b, c, half);
  sat.prepare_rows(cell_, axis);
  std::int64_t at[3];
  for (at[v] = from[v]; at[v] <= to[v]; ++at[v])
    for (at[u] = from[u]; at[u] <= to[u]; ++at[u]) {
      Eigen::Vector3d row0;
      row0[axis] = origin_[axis] + 0.5 * cell_;
      row0[u] = origin_[u] + cell_ * (static_cast<double>(at[u]) + 0.5);
      row0[v] = origin_[v] + cell_ * (static_cast<double>(at[v]) + 0.5);
      double lo = static_cast<double>(from[axis]), hi = static_cast<double>(to[axis]);
      sat.row(row0, lo, hi);
      if (!(lo <= hi)) continue;
      // The interval's ends widened by kRowSlack cells: rounding never drops a cell that meets
      // the triangle (an extra one only costs a candidate).
      const auto first = std::max(from[axis], static_cast<std::int64_t>(std::ceil(lo - kRowSlack)));
      const auto last = std::min(to[axis], static_cast<std::int64_t>(std::floor(hi + kRowSlack)));
      for (at[axis] = first; at[axis] <= last; ++at[axis]) f(key(at[0], at[1], at[2]));
    }
}

bool CandidateGrid::candidates(const Eigen::Vector3d& q,
                               std::span<const std::uint32_t>& out) const {
  if (offsets_.empty()) return false;
  std::int64_t at[3];
  for (int k = 0; k < 3; ++k) {
    const double x = std::floor((q[k] - origin_[k]) * inv_cell_);
    if (!(x >= 0 && x < static_cast<double>(dims_[k]))) return false;
    at[k] = static_cast<std::int64_t>(x);
  }
  const std::uint32_t k = key(at[0], at[1], at[2]);
  const std::uint32_t first = block_first_[k / kBlockCells];
  if (first == kNoBlock) {
    out = {};
    return true;
  }
  const std::uint32_t cell = first + k % kBlockCells;
  out = {entries_.data() + offsets_[cell], entries_.data() + offsets_[cell + 1]};
  return true;
}

}  // namespace align3d::detail
