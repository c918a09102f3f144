#include "align3d/mesh.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <span>

#include "align3d/error.hpp"
#include "detail/parallel.hpp"
#include "detail/random.hpp"

namespace align3d {
namespace {

using Triangle = std::array<std::uint32_t, 3>;
constexpr std::uint32_t kUnset = std::numeric_limits<std::uint32_t>::max();

Eigen::Vector3d area_vector(const TriangleMesh& m, const Triangle& t) {
  const Eigen::Vector3d& a = m.vertices[t[0]];
  return (m.vertices[t[1]] - a).cross(m.vertices[t[2]] - a);
}

// Union-find over triangles, for the pieces connected through manifold edges.
struct Components {
  explicit Components(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<std::uint32_t> parent;
};

// A hash set of item numbers (open addressing, linear probing, grown at half load), the caller
// supplying each item's hash and equality. Written by hand: std::unordered_map allocates a node
// per item, and weld looks up every corner of the mesh (3x faster on a 200 k-triangle STL).
class IndexSet {
 public:
  explicit IndexSet(std::size_t expected) : slots_(std::bit_ceil(2 * expected + 16), kEmpty) {}

  // Asks the cache for the slot where a search for hash h starts.
  void prefetch(std::uint64_t h) const { __builtin_prefetch(&slots_[h & (slots_.size() - 1)]); }

  // The item already present equal to `item` (hash h), or `item` after inserting it.
  template <class Equal>
  std::uint32_t find_or_insert(std::uint64_t h, std::uint32_t item, Equal&& equal) {
    for (std::size_t i = h;; ++i) {
      Slot& slot = slots_[i & (slots_.size() - 1)];
      if (slot.item == kUnset) {
        slot = {h, item};
        if (++size_ * 2 > slots_.size()) grow();
        return item;
      }
      if (slot.hash == h && equal(slot.item)) return slot.item;
    }
  }

 private:
  struct Slot {
    std::uint64_t hash;
    std::uint32_t item;
  };
  static constexpr Slot kEmpty = {0, kUnset};
  void grow() {
    std::vector<Slot> old(2 * slots_.size(), kEmpty);
    old.swap(slots_);
    for (const Slot& s : old)
      if (s.item != kUnset)
        for (std::size_t i = s.hash;; ++i)
          if (Slot& slot = slots_[i & (slots_.size() - 1)]; slot.item == kUnset) {
            slot = s;
            break;
          }
  }
  std::vector<Slot> slots_;
  std::size_t size_ = 0;
};

// Welds vertices with identical coordinates (−0 and +0 alike) and keeps only used ones, numbered
// in order of first use. The table misses the cache at nearly every lookup (4 MB for a 200 k-facet
// STL, whose 600 k corners are all distinct vertices), so each corner's slot is prefetched
// kAhead corners before it is looked up: 14 ms instead of 20 on that STL.
TriangleMesh weld(const TriangleMesh& in, MeshRepair& r) {
  constexpr std::size_t kAhead = 16;
  auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v + 0.0); };
  auto hash_of = [&](const Eigen::Vector3d& p) {
    return splitmix64(bits(p.x()) ^ splitmix64(bits(p.y()) ^ splitmix64(bits(p.z()))));
  };
  IndexSet table(in.triangles.size() / 2);  // a closed mesh has about half as many vertices
  std::vector<std::uint32_t> remap(in.vertices.size(), kUnset);
  TriangleMesh out;
  out.triangles.resize(in.triangles.size());
  out.vertices.reserve(in.vertices.size());  // address space only: pages are touched as it grows
  const std::size_t corners = 3 * in.triangles.size();
  auto vertex = [&](std::size_t c) { return in.triangles[c / 3][c % 3]; };
  std::array<std::uint64_t, kAhead> ahead{};  // the hashes of corners c .. c + kAhead - 1
  auto look_ahead = [&](std::size_t c) {
    if (c >= corners || remap[vertex(c)] != kUnset) return;
    ahead[c % kAhead] = hash_of(in.vertices[vertex(c)]);
    table.prefetch(ahead[c % kAhead]);
  };
  for (std::size_t c = 0; c < std::min(kAhead, corners); ++c) look_ahead(c);
  std::size_t used = 0;
  for (std::size_t c = 0; c < corners; ++c) {
    const std::uint32_t v = vertex(c);
    std::uint32_t& m = remap[v];
    if (m == kUnset) {  // hashed when looked ahead: only an earlier corner could have set m
      ++used;
      const Eigen::Vector3d& p = in.vertices[v];
      const auto next = static_cast<std::uint32_t>(out.vertices.size());
      m = table.find_or_insert(ahead[c % kAhead], next, [&](std::uint32_t o) {
        const Eigen::Vector3d& q = out.vertices[o];
        return bits(q.x()) == bits(p.x()) && bits(q.y()) == bits(p.y()) &&
               bits(q.z()) == bits(p.z());
      });
      if (m == next) out.vertices.push_back(p);
    }
    out.triangles[c / 3][c % 3] = m;
    look_ahead(c + kAhead);
  }
  r.welded_vertices = used - out.vertices.size();
  return out;
}

// The triangles at each vertex, in triangle order: vertex v's are triangles[start[v], start[v+1]).
// A triangle is listed once under each distinct corner (a degenerate one repeats corners).
struct Incidence {
  std::vector<std::uint32_t> start, triangles;
  std::span<const std::uint32_t> of(std::uint32_t v) const {
    return {triangles.data() + start[v], triangles.data() + start[v + 1]};
  }
};

bool first_use(const Triangle& t, int k) {
  return (k < 1 || t[k] != t[0]) && (k < 2 || t[k] != t[1]);
}

Incidence incidence(const TriangleMesh& mesh) {
  Incidence out;
  out.start.assign(mesh.vertices.size() + 1, 0);
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) out.start[t[k] + 1] += first_use(t, k) ? 1 : 0;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) out.start[v + 1] += out.start[v];
  out.triangles.resize(out.start.back());
  std::vector<std::uint32_t> next(out.start.begin(), out.start.end() - 1);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (first_use(mesh.triangles[t], k))
        out.triangles[next[mesh.triangles[t][k]]++] = static_cast<std::uint32_t>(t);
  return out;
}

// Drops triangles with a repeated corner, collinear corners (|ab × ac| below 1e-12 |ab| |ac|: no
// normal) or the same corners as an earlier triangle (either winding: a duplicate would make its
// edges non-manifold). An equal triangle shares the lowest corner, so the search for one runs
// through that vertex's few triangles (a hash of every triangle's corners took 3x as long on a
// 200 k-triangle mesh: its table does not fit in cache), each triangle on its own, in parallel.
void drop_degenerate(TriangleMesh& m, MeshRepair& r, int threads) {
  const std::size_t before = m.triangles.size();
  const Incidence at = incidence(m);
  auto sorted = [](Triangle t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  std::vector<std::uint8_t> keep(before, 0);
  parallel_for(before, threads, [&](std::size_t i) {
    const Triangle& t = m.triangles[i];
    const Eigen::Vector3d& a = m.vertices[t[0]];
    const Eigen::Vector3d ab = m.vertices[t[1]] - a, ac = m.vertices[t[2]] - a;
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
        !(ab.cross(ac).norm() > 1e-12 * ab.norm() * ac.norm()))
      return;
    const Triangle s = sorted(t);
    for (std::uint32_t j : at.of(s[0])) {
      if (j >= i) break;  // the first of equal triangles stays
      if (sorted(m.triangles[j]) == s) return;
    }
    keep[i] = 1;
  });
  std::size_t kept = 0;
  for (std::size_t i = 0; i < before; ++i)
    if (keep[i]) m.triangles[kept++] = m.triangles[i];
  m.triangles.resize(kept);
  r.dropped_triangles = before - kept;
}

// Whether neighbour o runs along t's edge k (corners k, k + 1) in the same direction as t: then
// their windings disagree.
bool same_direction(const Triangle& t, int k, const Triangle& o) {
  for (int j = 0; j < 3; ++j)
    if (o[j] == t[k]) return o[(j + 1) % 3] == t[(k + 1) % 3];
  return false;
}

// The winding's share of the topology: the signed volume, and the edges whose two triangles run
// along them in the same direction. Re-winding changes these two counts only.
void count_winding(const TriangleMesh& m,
                   const std::vector<std::array<std::uint32_t, 3>>& neighbours,
                   MeshTopology& topo) {
  topo.signed_volume = 0;
  topo.inconsistent_edges = 0;
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
    const Triangle& f = m.triangles[t];
    topo.signed_volume += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]])) / 6.0;
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t o = neighbours[t][k];
      if (o != kUnset && t < o && same_direction(f, k, m.triangles[o])) ++topo.inconsistent_edges;
    }
  }
}

// Re-winds t, and keeps its neighbours in step: edge 0 (corners 0-1) becomes edge 2 and back.
void flip(Triangle& t, std::array<std::uint32_t, 3>& neighbours) {
  std::swap(t[1], t[2]);
  std::swap(neighbours[0], neighbours[2]);
}

// Winds every piece consistently by a breadth-first walk over manifold edges, flipping the
// smaller of the two classes the walk finds, then turns closed pieces outward.
void orient(TriangleMesh& m, std::vector<std::array<std::uint32_t, 3>>& neighbour, MeshRepair& r) {
  const std::size_t n = m.triangles.size();
  std::vector<std::int8_t> parity(n, -1);  // 1: flip relative to the piece's seed
  std::vector<std::uint32_t> queue;
  for (std::uint32_t seed = 0; seed < n; ++seed) {
    if (parity[seed] >= 0) continue;
    queue.assign(1, seed);
    parity[seed] = 0;
    bool closed = true;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const std::uint32_t t = queue[head];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t o = neighbour[t][k];
        if (o == kUnset) {
          closed = false;
          continue;
        }
        if (parity[o] >= 0) continue;
        const bool same = same_direction(m.triangles[t], k, m.triangles[o]);
        parity[o] = static_cast<std::int8_t>(parity[t] ^ (same ? 1 : 0));
        queue.push_back(o);
      }
    }
    const std::size_t ones = static_cast<std::size_t>(
        std::count_if(queue.begin(), queue.end(), [&](std::uint32_t t) { return parity[t] == 1; }));
    const std::int8_t flip_class = 2 * ones <= queue.size() ? 1 : 0;
    r.flipped_triangles += flip_class == 1 ? ones : queue.size() - ones;
    double volume = 0;
    for (std::uint32_t t : queue) {
      if (parity[t] == flip_class) flip(m.triangles[t], neighbour[t]);
      const Triangle& f = m.triangles[t];
      volume += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]]));
    }
    if (closed && volume < 0) {
      ++r.inverted_components;
      for (std::uint32_t t : queue) flip(m.triangles[t], neighbour[t]);
    }
  }
}

}  // namespace

TriangleMesh transformed(const TriangleMesh& mesh, const Eigen::Isometry3d& T) {
  TriangleMesh out = mesh;
  for (Eigen::Vector3d& v : out.vertices) v = T * v;
  return out;
}

Eigen::AlignedBox3d bounding_box(const TriangleMesh& mesh) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Triangle& t : mesh.triangles)
    for (std::uint32_t i : t) {
      lo = lo.cwiseMin(mesh.vertices[i]);
      hi = hi.cwiseMax(mesh.vertices[i]);
    }
  return Eigen::AlignedBox3d(lo, hi);  // empty (lo > hi) for no triangle
}

double bounding_box_diagonal(const TriangleMesh& mesh) {
  const Eigen::AlignedBox3d box = bounding_box(mesh);
  return box.isEmpty() ? 0 : box.diagonal().norm();
}

double surface_area(const TriangleMesh& mesh) {
  double area = 0;
  for (const Triangle& t : mesh.triangles) area += 0.5 * area_vector(mesh, t).norm();
  return area;
}

void check_mesh(const TriangleMesh& mesh, const std::string& what) {
  if (mesh.triangles.empty()) throw DataError(what, "the mesh has no triangle");
  const std::size_t n = mesh.vertices.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t i : mesh.triangles[t]) {
      if (i >= n)
        throw DataError(what, "triangle " + std::to_string(t) + " refers to vertex " +
                                  std::to_string(i) + " of " + std::to_string(n));
      if (!mesh.vertices[i].allFinite())
        throw DataError(what, "vertex " + std::to_string(i) + " has a NaN or Inf coordinate");
    }
}

// Every edge through its first corner's triangles (a vertex → triangles table, in triangle order):
// linear, where sorting the 3n half-edges by their ends took 4x longer on a 200 k-triangle mesh.
// An undirected edge is counted once, by the lowest-numbered triangle using it.
MeshAdjacency analyse_adjacency(const TriangleMesh& mesh, int threads) {
  const std::size_t n = mesh.triangles.size();
  MeshAdjacency out;
  MeshTopology& topo = out.topology;
  out.neighbours.assign(n, {kUnset, kUnset, kUnset});
  topo.triangles = n;
  const Incidence at = incidence(mesh);
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    topo.vertices += at.start[v + 1] > at.start[v] ? 1 : 0;
  // Each triangle's edges on their own, in parallel; then the windings and the pieces in order.
  struct Counts {
    std::size_t boundary = 0, non_manifold = 0;
  };
  const Counts counts = parallel_reduce(
      n, threads, Counts{},
      [&](Counts& acc, std::size_t i) {
        const auto t = static_cast<std::uint32_t>(i);
        const Triangle& f = mesh.triangles[t];
        for (int k = 0; k < 3; ++k) {
          const std::uint32_t a = f[k], b = f[(k + 1) % 3];
          std::uint32_t others = 0, other = kUnset, lowest = t;
          for (std::uint32_t o : a != b ? at.of(a) : std::span<const std::uint32_t>()) {
            const Triangle& g = mesh.triangles[o];
            if (o == t || (g[0] != b && g[1] != b && g[2] != b)) continue;
            ++others;
            other = o;
            lowest = std::min(lowest, o);
          }
          if (others == 0) {
            ++acc.boundary;
          } else if (others > 1) {
            acc.non_manifold += lowest == t ? 1 : 0;
          } else {
            out.neighbours[t][k] = other;
          }
        }
      },
      [](Counts& a, const Counts& b) {
        a.boundary += b.boundary;
        a.non_manifold += b.non_manifold;
      });
  topo.boundary_edges = counts.boundary;
  topo.non_manifold_edges = counts.non_manifold;
  count_winding(mesh, out.neighbours, topo);
  Components pieces(n);
  for (std::uint32_t t = 0; t < n; ++t)
    for (std::uint32_t o : out.neighbours[t])
      if (o != kUnset && t < o) pieces.join(t, o);
  for (std::uint32_t t = 0; t < n; ++t)
    if (pieces.find(t) == t) ++topo.components;
  return out;
}

MeshTopology analyse_topology(const TriangleMesh& mesh) { return analyse_adjacency(mesh).topology; }

std::vector<std::array<std::uint32_t, 3>> edge_neighbours(const TriangleMesh& mesh) {
  return analyse_adjacency(mesh).neighbours;
}

TriangleMesh clean_mesh(const TriangleMesh& mesh, MeshRepair* repair, MeshAdjacency* adjacency,
                        int threads) {
  MeshRepair r;
  TriangleMesh out = weld(mesh, r);
  drop_degenerate(out, r, threads);
  MeshAdjacency welded = analyse_adjacency(out, threads);
  r.inconsistent_edges = welded.topology.inconsistent_edges;
  orient(out, welded.neighbours, r);
  if (adjacency) {  // the neighbours followed the flips (orient); the winding counts did not
    count_winding(out, welded.neighbours, welded.topology);
    *adjacency = std::move(welded);
  }
  // Vertices only the dropped triangles used go too.
  std::vector<std::uint32_t> remap(out.vertices.size(), kUnset);
  std::vector<Eigen::Vector3d> vertices;
  for (Triangle& t : out.triangles)
    for (std::uint32_t& i : t) {
      if (remap[i] == kUnset) {
        remap[i] = static_cast<std::uint32_t>(vertices.size());
        vertices.push_back(out.vertices[i]);
      }
      i = remap[i];
    }
  out.vertices = std::move(vertices);
  if (repair) *repair = r;
  return out;
}

PointCloud sample_surface(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed) {
  PointCloud out;
  const double area = surface_area(mesh);
  if (count == 0 || !(area > 0)) return out;
  out.positions.reserve(count);
  out.normals.reserve(count);
  Random rng(splitmix64(seed));
  // Systematic sampling of the cumulative area: sample k sits at (offset + k)·step, so each
  // triangle receives its share of the count rounded up or down, never a random clump.
  const double step = area / static_cast<double>(count);
  double next = rng.uniform() * step;
  double covered = 0;
  for (const Triangle& t : mesh.triangles) {
    const Eigen::Vector3d n = area_vector(mesh, t);
    covered += 0.5 * n.norm();
    const Eigen::Vector3d& a = mesh.vertices[t[0]];
    const Eigen::Vector3d ab = mesh.vertices[t[1]] - a, ac = mesh.vertices[t[2]] - a;
    while (next < covered && out.positions.size() < count) {
      // Uniform in the triangle: reflect the unit square's upper half onto the lower.
      double u = rng.uniform(), v = rng.uniform();
      if (u + v > 1) {
        u = 1 - u;
        v = 1 - v;
      }
      out.positions.push_back(a + u * ab + v * ac);
      out.normals.push_back(n.normalized());
      next += step;
    }
  }
  return out;
}

}  // namespace align3d
