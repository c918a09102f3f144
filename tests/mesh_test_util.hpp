// Small closed meshes with known geometry for the mesh tests: prisms extruded from polygons.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "align3d/mesh.hpp"

namespace align3d::test {

// The prism over a polygon (counter-clockwise seen from +z) from z0 to z1, outward wound. The caps
// are fanned from corner `fan` of the polygon, which must see every other corner (star-shaped).
inline TriangleMesh prism(const std::vector<Eigen::Vector2d>& polygon, double z0, double z1,
                          std::uint32_t fan = 0) {
  TriangleMesh m;
  const auto n = static_cast<std::uint32_t>(polygon.size());
  for (const auto& p : polygon) m.vertices.emplace_back(p.x(), p.y(), z0);
  for (const auto& p : polygon) m.vertices.emplace_back(p.x(), p.y(), z1);
  for (std::uint32_t k = 1; k + 1 < n; ++k) {
    const std::uint32_t a = fan, b = (fan + k) % n, c = (fan + k + 1) % n;
    m.triangles.push_back({n + a, n + b, n + c});  // top, normal +z
    m.triangles.push_back({a, c, b});              // bottom, normal −z
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    m.triangles.push_back({i, j, n + j});
    m.triangles.push_back({i, n + j, n + i});
  }
  return m;
}

// An axis-aligned box [lo, hi].
inline TriangleMesh box_mesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return prism({{lo.x(), lo.y()}, {hi.x(), lo.y()}, {hi.x(), hi.y()}, {lo.x(), hi.y()}}, lo.z(),
               hi.z());
}

// An L-shaped block: the square [0, 2]² without the quadrant (1, 2]², from z = 0 to 1. It has a
// concave edge along (1, 1, z) and saddle corners at its ends. Fanned from the reflex corner.
inline TriangleMesh l_block() {
  return prism({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}, 0, 1, 3);
}
inline bool l_block_contains(const Eigen::Vector3d& p) {
  const bool in_square = p.x() > 0 && p.x() < 2 && p.y() > 0 && p.y() < 2;
  const bool in_notch = p.x() > 1 && p.y() > 1;
  return in_square && !in_notch && p.z() > 0 && p.z() < 1;
}

// The same triangles with every corner its own vertex, as an STL file stores them.
inline TriangleMesh unwelded(const TriangleMesh& m) {
  TriangleMesh out;
  for (const auto& t : m.triangles) {
    const auto base = static_cast<std::uint32_t>(out.vertices.size());
    for (std::uint32_t i : t) out.vertices.push_back(m.vertices[i]);
    out.triangles.push_back({base, base + 1, base + 2});
  }
  return out;
}

}  // namespace align3d::test
