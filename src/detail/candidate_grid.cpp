#include "detail/candidate_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "detail/parallel.hpp"

namespace align3d::detail {
namespace {

constexpr double kCellsPerTriangleSide = 0.7;  // cell side = this × √(mean triangle area)
constexpr double kReachFraction = 0.25;        // reach = this × cell side
// Triangles are listed for a slightly larger cube than the reach queries trust, so a triangle
// that rounding would place just outside is never missing from a cell.
constexpr double kListingMargin = 1e-9;
constexpr double kRowSlack = 1e-6;

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
  // The cubes centred at row0 + x·(step, 0, 0) meet the triangle for x in [from, to] (continuous;
  // empty when from > to): on each axis d the test lo − r ≤ d·centre ≤ hi + r is linear in x, so
  // a row of cells costs ten interval intersections instead of ten dot products a cell. `step`
  // must be the one given to prepare_rows.
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
  void prepare_rows(double step) {
    for (int i = 0; i < count_; ++i) {
      const double dp = axes_[i].x() * step;
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

CandidateGrid::CandidateGrid(const std::vector<Eigen::Vector3d>& a,
                             const std::vector<Eigen::Vector3d>& b,
                             const std::vector<Eigen::Vector3d>& c, double area, int threads) {
  const std::size_t n = a.size();
  if (n == 0 || !(area > 0)) return;
  Eigen::Vector3d lo = a[0], hi = a[0];
  for (std::size_t i = 0; i < n; ++i) {
    lo = lo.cwiseMin(a[i]).cwiseMin(b[i]).cwiseMin(c[i]);
    hi = hi.cwiseMax(a[i]).cwiseMax(b[i]).cwiseMax(c[i]);
  }
  cell_ = kCellsPerTriangleSide * std::sqrt(area / static_cast<double>(n));
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
  const double half = (0.5 * cell_ + reach_) * (1 + kListingMargin);

  // Each triangle visits the cells its box, grown by the reach, overlaps, and is listed where it
  // meets the grown cell: in parallel over fixed chunks of triangles, whose (cell, triangle) pairs
  // are then counted and placed in chunk order (CSR), so the lists do not depend on the threads.
  for (int k = 0; k < 3; ++k) blocks_[k] = (dims_[k] + kBlock - 1) / kBlock;
  constexpr std::size_t kChunk = 1024;
  std::vector<std::vector<std::uint32_t>> pairs((n + kChunk - 1) / kChunk);  // key, triangle, ...
  parallel_tasks(pairs.size(), threads, [&](std::size_t chunk) {
    pairs[chunk].reserve(32 * kChunk);
    for (std::size_t i = chunk * kChunk; i < std::min(n, (chunk + 1) * kChunk); ++i)
      list_triangle(a[i], b[i], c[i], half, [&](std::uint32_t key) {
        pairs[chunk].push_back(key);
        pairs[chunk].push_back(static_cast<std::uint32_t>(i));
      });
  });
  std::size_t total = 0;
  for (const auto& p : pairs) total += p.size() / 2;
  if (total > kMaxEntries) return;  // no grid: the hierarchy answers everything
  // Only blocks holding a candidate get cells: their offsets, block after block.
  block_first_.assign(static_cast<std::size_t>(blocks_[0] * blocks_[1] * blocks_[2]), kNoBlock);
  for (const auto& p : pairs)
    for (std::size_t j = 0; j < p.size(); j += 2) block_first_[p[j] / kBlockCells] = 0;
  std::uint32_t used = 0;
  for (std::uint32_t& first : block_first_)
    if (first != kNoBlock) first = std::exchange(used, used + kBlockCells);
  auto cell_of = [&](std::uint32_t key) {
    return block_first_[key / kBlockCells] + key % kBlockCells;
  };
  std::vector<std::uint32_t> offsets(std::size_t{used} + 1, 0);
  for (const auto& p : pairs)
    for (std::size_t j = 0; j < p.size(); j += 2) ++offsets[cell_of(p[j]) + 1];
  for (std::size_t k = 0; k < used; ++k) offsets[k + 1] += offsets[k];
  entries_.resize(total);
  std::vector<std::uint32_t> next(offsets.begin(), offsets.end() - 1);
  for (const auto& p : pairs)
    for (std::size_t j = 0; j < p.size(); j += 2) entries_[next[cell_of(p[j])]++] = p[j + 1];
  offsets_ = std::move(offsets);
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
  SeparatingAxes sat(a, b, c, half);
  sat.prepare_rows(cell_);
  for (std::int64_t z = from[2]; z <= to[2]; ++z)
    for (std::int64_t y = from[1]; y <= to[1]; ++y) {
      const Eigen::Vector3d row0 = origin_ + cell_ * Eigen::Vector3d(0.5, y + 0.5, z + 0.5);
      double lo = static_cast<double>(from[0]), hi = static_cast<double>(to[0]);
      sat.row(row0, lo, hi);
      if (!(lo <= hi)) continue;
      // The interval's ends widened by kRowSlack cells: rounding never drops a cell that meets
      // the triangle (an extra one only costs a candidate).
      const auto first = std::max(from[0], static_cast<std::int64_t>(std::ceil(lo - kRowSlack)));
      const auto last = std::min(to[0], static_cast<std::int64_t>(std::floor(hi + kRowSlack)));
      for (std::int64_t x = first; x <= last; ++x) f(key(x, y, z));
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
