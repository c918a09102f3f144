#include "align3d/mesh.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "align3d/error.hpp"
#include "detail/random.hpp"

namespace align3d {
namespace {

using Triangle = std::array<std::uint32_t, 3>;
constexpr std::uint32_t kUnset = std::numeric_limits<std::uint32_t>::max();

Eigen::Vector3d area_vector(const TriangleMesh& m, const Triangle& t) {
  const Eigen::Vector3d& a = m.vertices[t[0]];
  return (m.vertices[t[1]] - a).cross(m.vertices[t[2]] - a);
}

// One directed edge of a triangle: its undirected key (lo, hi), the triangle and whether it runs
// lo → hi. Sorting by key groups the triangles of each edge.
struct HalfEdge {
  std::uint32_t lo, hi, triangle;
  bool forward;
  bool operator<(const HalfEdge& o) const {
    return lo != o.lo ? lo < o.lo : hi != o.hi ? hi < o.hi : triangle < o.triangle;
  }
};

std::vector<HalfEdge> half_edges(const TriangleMesh& m) {
  std::vector<HalfEdge> e;
  e.reserve(3 * m.triangles.size());
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = m.triangles[t][k], b = m.triangles[t][(k + 1) % 3];
      e.push_back({std::min(a, b), std::max(a, b), t, a < b});
    }
  std::sort(e.begin(), e.end());
  return e;
}

// Calls f(first, last) for each run of half-edges with the same undirected key.
template <class F>
void for_each_edge(const std::vector<HalfEdge>& e, F&& f) {
  for (std::size_t i = 0; i < e.size();) {
    std::size_t j = i + 1;
    while (j < e.size() && e[j].lo == e[i].lo && e[j].hi == e[i].hi) ++j;
    f(i, j);
    i = j;
  }
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

// Welds vertices with identical coordinates (−0 and +0 alike) and keeps only used ones.
TriangleMesh weld(const TriangleMesh& in, MeshRepair& r) {
  struct Key {
    std::uint64_t x, y, z;
    bool operator==(const Key&) const = default;
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      return splitmix64(k.x ^ splitmix64(k.y ^ splitmix64(k.z)));
    }
  };
  auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v + 0.0); };
  std::unordered_map<Key, std::uint32_t, Hash> index;
  std::vector<std::uint32_t> remap(in.vertices.size(), kUnset);
  TriangleMesh out;
  out.triangles.reserve(in.triangles.size());
  std::size_t used = 0;
  for (const Triangle& t : in.triangles) {
    Triangle w;
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& m = remap[t[k]];
      if (m == kUnset) {
        ++used;
        const Eigen::Vector3d& p = in.vertices[t[k]];
        const auto [it, fresh] = index.try_emplace(Key{bits(p.x()), bits(p.y()), bits(p.z())},
                                                   static_cast<std::uint32_t>(out.vertices.size()));
        if (fresh) out.vertices.push_back(p);
        m = it->second;
      }
      w[k] = m;
    }
    out.triangles.push_back(w);
  }
  r.welded_vertices = used - out.vertices.size();
  return out;
}

// Drops triangles with a repeated corner, collinear corners (|ab × ac| below 1e-12 |ab| |ac|: no
// normal) or the same corners as an earlier triangle (either winding: a duplicate would make its
// edges non-manifold).
void drop_degenerate(TriangleMesh& m, MeshRepair& r) {
  const std::size_t before = m.triangles.size();
  std::vector<Triangle> kept;
  kept.reserve(m.triangles.size());
  std::vector<std::pair<Triangle, std::uint32_t>> sorted;
  for (const Triangle& t : m.triangles) {
    const Eigen::Vector3d& a = m.vertices[t[0]];
    const Eigen::Vector3d ab = m.vertices[t[1]] - a, ac = m.vertices[t[2]] - a;
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] ||
        !(ab.cross(ac).norm() > 1e-12 * ab.norm() * ac.norm()))
      continue;
    Triangle s = t;
    std::sort(s.begin(), s.end());
    sorted.push_back({s, static_cast<std::uint32_t>(kept.size())});
    kept.push_back(t);
  }
  std::sort(sorted.begin(), sorted.end());
  std::vector<bool> duplicate(kept.size(), false);
  for (std::size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i].first == sorted[i - 1].first) duplicate[sorted[i].second] = true;
  m.triangles.clear();
  for (std::size_t i = 0; i < kept.size(); ++i)
    if (!duplicate[i]) m.triangles.push_back(kept[i]);
  r.dropped_triangles = before - m.triangles.size();
}

// Whether neighbour o runs along t's edge k (corners k, k + 1) in the same direction as t: then
// their windings disagree.
bool same_direction(const Triangle& t, int k, const Triangle& o) {
  for (int j = 0; j < 3; ++j)
    if (o[j] == t[k]) return o[(j + 1) % 3] == t[(k + 1) % 3];
  return false;
}

void flip(Triangle& t) { std::swap(t[1], t[2]); }

// Winds every piece consistently by a breadth-first walk over manifold edges, flipping the
// smaller of the two classes the walk finds, then turns closed pieces outward.
void orient(TriangleMesh& m, MeshRepair& r) {
  const std::vector<std::array<std::uint32_t, 3>> neighbour = edge_neighbours(m);
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
      if (parity[t] == flip_class) flip(m.triangles[t]);
      const Triangle& f = m.triangles[t];
      volume += m.vertices[f[0]].dot(m.vertices[f[1]].cross(m.vertices[f[2]]));
    }
    if (closed && volume < 0) {
      ++r.inverted_components;
      for (std::uint32_t t : queue) flip(m.triangles[t]);
    }
  }
}

}  // namespace

TriangleMesh transformed(const TriangleMesh& mesh, const Eigen::Isometry3d& T) {
  TriangleMesh out = mesh;
  for (Eigen::Vector3d& v : out.vertices) v = T * v;
  return out;
}

double bounding_box_diagonal(const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) return 0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Triangle& t : mesh.triangles)
    for (std::uint32_t i : t) {
      lo = lo.cwiseMin(mesh.vertices[i]);
      hi = hi.cwiseMax(mesh.vertices[i]);
    }
  return (hi - lo).norm();
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

MeshTopology analyse_topology(const TriangleMesh& mesh) {
  MeshTopology topo;
  topo.triangles = mesh.triangles.size();
  std::vector<bool> used(mesh.vertices.size(), false);
  for (const Triangle& t : mesh.triangles) {
    for (std::uint32_t i : t) used[i] = true;
    const Eigen::Vector3d& a = mesh.vertices[t[0]];
    topo.signed_volume += a.dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]])) / 6.0;
  }
  topo.vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), true));
  Components pieces(mesh.triangles.size());
  const std::vector<HalfEdge> e = half_edges(mesh);
  for_each_edge(e, [&](std::size_t i, std::size_t j) {
    if (j - i == 1) ++topo.boundary_edges;
    if (j - i > 2) ++topo.non_manifold_edges;
    if (j - i != 2) return;
    if (e[i].forward == e[i + 1].forward) ++topo.inconsistent_edges;
    pieces.join(e[i].triangle, e[i + 1].triangle);
  });
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t)
    if (pieces.find(t) == t) ++topo.components;
  return topo;
}

std::vector<std::array<std::uint32_t, 3>> edge_neighbours(const TriangleMesh& mesh) {
  std::vector<std::array<std::uint32_t, 3>> out(mesh.triangles.size(), {kUnset, kUnset, kUnset});
  auto slot = [&](const HalfEdge& h) {
    const Triangle& t = mesh.triangles[h.triangle];
    for (int k = 0; k < 3; ++k)
      if (std::min(t[k], t[(k + 1) % 3]) == h.lo && std::max(t[k], t[(k + 1) % 3]) == h.hi)
        return k;
    return 0;
  };
  const std::vector<HalfEdge> e = half_edges(mesh);
  for_each_edge(e, [&](std::size_t i, std::size_t j) {
    if (j - i != 2) return;
    out[e[i].triangle][slot(e[i])] = e[i + 1].triangle;
    out[e[i + 1].triangle][slot(e[i + 1])] = e[i].triangle;
  });
  return out;
}

TriangleMesh clean_mesh(const TriangleMesh& mesh, MeshRepair* repair) {
  MeshRepair r;
  TriangleMesh out = weld(mesh, r);
  drop_degenerate(out, r);
  r.inconsistent_edges = analyse_topology(out).inconsistent_edges;
  orient(out, r);
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
