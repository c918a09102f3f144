// A grid of candidate triangles for closest-point queries near a surface (mesh_index.cpp): each
// cell lists every triangle that comes within `reach` of it, so a query point in the cell whose
// nearest candidate is within `reach` has its exact answer among the cell's candidates; farther
// points fall back to the hierarchy. Why a grid on top of the hierarchy: scan points lie on the
// surface, a few tenths of a millimetre off at most; the grid replaces a descent through ~15 levels
// of boxes by one cell lookup and a handful of plane tests (bench/mesh_bench.cpp).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <vector>

#include "align3d/mesh.hpp"
#include "detail/uninitialized.hpp"

namespace align3d::detail {

class CandidateGrid {
 public:
  CandidateGrid() = default;
  // The triangles mesh.triangles[order[i]]; the grid lists their positions i. Cells
  // are cubes of side about 0.7 √(area / triangles) (a few triangles a cell), and the reach an
  // eighth of a cell; the grid stays below kMaxCells cells (coarser cells otherwise) and below
  // kMaxEntries listed candidates (no grid otherwise: every query then uses the hierarchy).
  // `box`: bounding_box(mesh).
  CandidateGrid(const TriangleMesh& mesh, const std::vector<std::uint32_t>& order,
                const Eigen::AlignedBox3d& box, double area, int threads);

  double reach() const { return reach_; }
  double cell() const { return cell_; }
  bool empty() const { return offsets_.empty(); }
  // The candidates of the cell holding q; false when q lies outside the grid (or there is none).
  bool candidates(const Eigen::Vector3d& q, std::span<const std::uint32_t>& out) const;
  std::size_t memory_bytes() const {
    return (block_first_.capacity() + offsets_.capacity() + entries_.capacity()) *
           sizeof(std::uint32_t);
  }

  static constexpr std::size_t kMaxCells = std::size_t{1} << 24;
  static constexpr std::size_t kMaxEntries = std::size_t{1} << 27;

 private:
  static constexpr std::size_t kSlices = 16;  // slabs of blocks laid out in parallel
  // The (cell key, triangle position) pairs of the listing, by chunk of triangles and slice.
  struct Pairs {
    std::size_t blocks = 0, chunks = 0, slices = 0, per_slice = 0, total = 0;
    std::vector<std::vector<std::uint32_t>> of;  // [chunk × slices + slice]: key, triangle, ...
    std::size_t slice(std::uint32_t key) const { return key / kBlockCells / per_slice; }
  };
  void size_cells(const Eigen::AlignedBox3d& box, double mean_area);
  Pairs list(const TriangleMesh& mesh, const std::vector<std::uint32_t>& order, int threads) const;
  void lay_out(const Pairs& pairs, int threads);

  // Cells are stored by blocks of kBlock³, only the blocks a triangle reaches (a surface meets a
  // few percent of its bounding box's cells): a cell's key is its block's number × kBlockCells +
  // its place in the block.
  static constexpr std::int64_t kBlock = 4;
  static constexpr std::uint32_t kBlockCells = kBlock * kBlock * kBlock;
  static constexpr std::uint32_t kNoBlock = 0xffffffffu;
  std::uint32_t key(std::int64_t x, std::int64_t y, std::int64_t z) const {
    const std::int64_t block = ((z / kBlock) * blocks_[1] + y / kBlock) * blocks_[0] + x / kBlock;
    const std::int64_t local = ((z % kBlock) * kBlock + y % kBlock) * kBlock + x % kBlock;
    return static_cast<std::uint32_t>(block * kBlockCells + local);
  }
  // Calls f(key) for every cell whose cube of half-size `half` (about its centre) triangle abc
  // meets.
  template <class F>
  void list_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     double half, F&& f) const;

  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  double cell_ = 0, inv_cell_ = 0, reach_ = 0;
  std::int64_t dims_[3] = {0, 0, 0};        // cells per axis
  std::int64_t blocks_[3] = {0, 0, 0};      // blocks per axis
  std::vector<std::uint32_t> block_first_;  // a block's first cell in offsets_, or kNoBlock
  // cell k's candidates: entries_[offsets_[k], offsets_[k+1])
  UninitializedVector<std::uint32_t> offsets_, entries_;
};

}  // namespace align3d::detail
