// The as-built scan of synth/part.hpp: a parallel-projection raster scanner ray-casting the CAD
// mesh and the fixture through MeshIndex, with known defects, warp, noise and pose.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "align3d/mesh_index.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/part.hpp"
#include "detail/parallel.hpp"
#include "detail/random.hpp"

namespace align3d::synth {
namespace {

constexpr double kStandoff = 1000;          // mm from the raster plane to the part
constexpr std::size_t kPilotRays = 200000;  // rays of the pass that measures the hit rate
constexpr double kMaxRays = 2147483647.0;   // per view: ray numbers fit the noise key's 31 bits

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("AsBuiltSettings: " + what);
}

// The fixture as one mesh: 12 outward-wound triangles per box.
TriangleMesh fixture_mesh(const std::vector<FixtureBox>& boxes) {
  static constexpr int kQuads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3},
                                       {0, 2, 3, 1}, {4, 5, 7, 6}};  // −x +x −y +y −z +z
  TriangleMesh mesh;
  for (const FixtureBox& b : boxes) {
    const auto first = static_cast<std::uint32_t>(mesh.vertices.size());
    for (int k = 0; k < 8; ++k)  // corner k: bit 0 picks max x, bit 1 max y, bit 2 max z
      mesh.vertices.emplace_back(k & 1 ? b.max.x() : b.min.x(), k & 2 ? b.max.y() : b.min.y(),
                                 k & 4 ? b.max.z() : b.min.z());
    for (const auto& q : kQuads) {
      mesh.triangles.push_back({first + q[0], first + q[1], first + q[2]});
      mesh.triangles.push_back({first + q[0], first + q[2], first + q[3]});
    }
  }
  return mesh;
}

// A defect must lie on one face: at its centre and on rings of R/2 and R (16 points each) the
// material is just below the surface along −n and absent just above it.
void check_defects(const PartModel& part, const std::vector<SurfaceDefect>& defects) {
  for (std::size_t k = 0; k < defects.size(); ++k) {
    const SurfaceDefect& d = defects[k];
    const std::string name = "defect " + std::to_string(k) + ": ";
    require(d.radius > 0 && std::isfinite(d.peak) && std::abs(d.peak) < d.radius,
            name + "radius must be positive and above |peak|");
    require(d.normal.norm() > 0, name + "zero normal");
    const Eigen::Vector3d n = d.normal.normalized();
    const Eigen::Vector3d t1 = n.unitOrthogonal(), t2 = n.cross(t1);
    for (double ring : {0.0, 0.5, 1.0})
      for (int a = 0; a < 16; ++a) {
        const double angle = 2 * std::numbers::pi * a / 16;
        const Eigen::Vector3d p =
            d.centre + ring * d.radius * (std::cos(angle) * t1 + std::sin(angle) * t2);
        require(part.contains(p - 1e-3 * n) && !part.contains(p + 1e-3 * n),
                name + "does not lie on a face of the part with that normal");
      }
  }
}

void check_settings(const AsBuiltSettings& s) {
  require(!s.views.empty() && s.views.size() <= 255, "1 to 255 views");
  for (const Eigen::Vector3d& v : s.views)
    require(v.allFinite() && v.norm() > 0, "a view direction must be finite and non-zero");
  require(s.pitch > 0 && std::isfinite(s.pitch), "pitch must be positive");
  require(s.target_points <= 1'000'000'000, "target_points: at most 10^9");
  require(s.noise_sigma >= 0 && s.warp_amplitude >= 0 && s.warp_wavelength > 0,
          "noise_sigma and warp_amplitude must be >= 0, warp_wavelength > 0");
  require(s.max_incidence_deg > 0 && s.max_incidence_deg < 90, "max_incidence_deg: 0 to 90");
  require(s.raster_margin >= 0 && s.fixture_clearance >= 0, "margin and clearance must be >= 0");
  for (const FixtureBox& b : s.fixture)
    require((b.max - b.min).minCoeff() > 0, "fixture box " + b.name + ": min must lie below max");
}

// The points the raster frames: the CAD mesh's vertices and the corners of the `framed` fixture
// boxes (the part's own outline, not its bounding box: the boss alone reaches its top).
std::vector<Eigen::Vector3d> framed_points(const AsBuiltSettings& s, const TriangleMesh& part) {
  std::vector<Eigen::Vector3d> points = part.vertices;
  for (const FixtureBox& b : s.fixture)
    if (b.framed)
      for (int k = 0; k < 8; ++k)
        points.push_back(Eigen::AlignedBox3d(b.min, b.max)
                             .corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)));
  return points;
}

// The raster of a view: u, v square to the direction, the window the framed points project to
// plus the margin, on a plane kStandoff before their centre.
ScanRaster make_raster(const Eigen::Vector3d& view, const std::vector<Eigen::Vector3d>& framed,
                       double pitch, double margin) {
  ScanRaster r;
  r.direction = view.normalized();
  // u: the CAD x axis seen from the scanner (y when looking along x), so that the raster's rows
  // follow the block's long edges and its window holds little beside the part.
  const Eigen::Vector3d axis =
      std::abs(r.direction.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  r.u = (axis - axis.dot(r.direction) * r.direction).normalized();
  r.v = r.direction.cross(r.u);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  Eigen::AlignedBox3d all;
  for (const Eigen::Vector3d& p : framed) {
    all.extend(p);
    const Eigen::Vector2d uv(p.dot(r.u), p.dot(r.v));
    lo = lo.cwiseMin(uv);
    hi = hi.cwiseMax(uv);
  }
  lo -= Eigen::Vector2d::Constant(margin);
  hi += Eigen::Vector2d::Constant(margin);
  const double columns = std::ceil((hi.x() - lo.x()) / pitch);
  const double rows = std::ceil((hi.y() - lo.y()) / pitch);
  if (!(columns * rows <= kMaxRays))
    throw std::invalid_argument("AsBuiltSettings: more than 2^31 rays per view; raise the pitch");
  r.columns = static_cast<int>(columns);
  r.rows = static_cast<int>(rows);
  const Eigen::Vector3d c = all.center();  // the plane's point with u = v = 0, standoff before c
  r.origin = c - kStandoff * r.direction - c.dot(r.u) * r.u - c.dot(r.v) * r.v + lo.x() * r.u +
             lo.y() * r.v;
  return r;
}

// A standard normal variate for one ray, from counters (view, ray) and the seed alone, so that the
// noise does not depend on the thread count or on the order of the rays: SplitMix64 of a key that
// no two rays share, then Box–Muller on two uniforms.
double ray_noise(std::uint64_t seed, std::uint64_t view, std::uint64_t ray) {
  const std::uint64_t a = splitmix64(splitmix64(seed) ^ (view << 40) ^ ray), b = splitmix64(a);
  const double u1 = 1.0 - static_cast<double>(a >> 11) * 0x1.0p-53;  // (0, 1]
  const double u2 = static_cast<double>(b >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
}

struct RawPoint {
  Eigen::Vector3d p;  // CAD frame
  double deviation;
  ScanLabel label;
};

// The scanner's geometry: the CAD mesh and the fixture, indexed.
class Scanner {
 public:
  explicit Scanner(const AsBuiltSettings& s)
      : s_(s),
        part_(PartModel(s.part).mesh(), s.threads, "part"),
        framed_(framed_points(s, part_.mesh())),
        cos_max_(std::cos(s.max_incidence_deg * std::numbers::pi / 180)) {
    if (!s.fixture.empty()) fixture_.emplace(fixture_mesh(s.fixture), s.threads, "fixture");
  }

  ScanRaster raster(std::size_t view, double pitch) const {
    return make_raster(s_.views[view], framed_, pitch, s_.raster_margin);
  }

  // The point ray (origin, d) measures, or nothing (no hit, grazing, a fixture hit too close to
  // the part: then `dropped`). d is unit.
  std::optional<RawPoint> shoot(const Eigen::Vector3d& origin, const Eigen::Vector3d& d,
                                double noise, bool& dropped) const {
    RayHit on_part, on_fixture;
    const bool part_hit = part_.intersect(origin, d, on_part);
    const bool fixture_hit =
        fixture_ &&
        fixture_->intersect(origin, d, on_fixture, 0,
                            part_hit ? on_part.t : std::numeric_limits<double>::infinity());
    if (!part_hit && !fixture_hit) return std::nullopt;
    const MeshIndex& index = fixture_hit ? *fixture_ : part_;
    const RayHit& hit = fixture_hit ? on_fixture : on_part;
    const Eigen::Vector3d& n = index.face_normal(hit.triangle);
    if (-d.dot(n) <= cos_max_) return std::nullopt;  // grazing incidence (or a back face)
    const Eigen::Vector3d x = origin + hit.t * d;
    const Eigen::Vector3d range_noise = s_.noise_sigma * noise * d;
    if (!fixture_hit) {
      const double delta = true_deviation(s_, x, n);
      return RawPoint{x + delta * n + range_noise, delta, ScanLabel::kPart};
    }
    SurfacePoint near;
    const double sq_clearance = s_.fixture_clearance * s_.fixture_clearance;
    if (part_.closest(x, near, sq_clearance)) {
      dropped = true;
      return std::nullopt;
    }
    return RawPoint{x + range_noise, 0, ScanLabel::kFixture};
  }

  // The points of one view in raster order (rows cast in parallel, joined in order).
  std::vector<RawPoint> scan(const ScanRaster& r, double pitch, std::uint64_t view,
                             std::size_t& dropped) const {
    std::vector<std::vector<RawPoint>> rows(static_cast<std::size_t>(r.rows));
    std::vector<std::size_t> row_dropped(rows.size(), 0);
    parallel_tasks(rows.size(), s_.threads, [&](std::size_t j) {
      for (int i = 0; i < r.columns; ++i) {
        const Eigen::Vector3d origin =
            r.origin + (i + 0.5) * pitch * r.u + (static_cast<double>(j) + 0.5) * pitch * r.v;
        const std::uint64_t ray = j * static_cast<std::uint64_t>(r.columns) + i;
        bool drop = false;
        if (auto p = shoot(origin, r.direction, ray_noise(s_.seed, view, ray), drop))
          rows[j].push_back(*p);
        row_dropped[j] += drop;
      }
    });
    std::vector<RawPoint> out;
    for (std::size_t j = 0; j < rows.size(); ++j) {
      out.insert(out.end(), rows[j].begin(), rows[j].end());
      dropped += row_dropped[j];
    }
    return out;
  }

 private:
  const AsBuiltSettings& s_;
  MeshIndex part_;
  std::vector<Eigen::Vector3d> framed_;
  std::optional<MeshIndex> fixture_;
  double cos_max_;
};

// The pitch giving about `target` points: a pilot pass of about kPilotRays rays measures the
// points per unit of raster area (a fixed share of the rays hits, so points ∝ pitch⁻²).
double pitch_for(const Scanner& scanner, const AsBuiltSettings& s, std::size_t target) {
  double area = 0;
  for (std::size_t k = 0; k < s.views.size(); ++k) {
    const ScanRaster r = scanner.raster(k, 1);
    area += static_cast<double>(r.columns) * r.rows;
  }
  const double pilot = std::sqrt(area / kPilotRays);
  std::size_t points = 0, dropped = 0;
  for (std::size_t k = 0; k < s.views.size(); ++k)
    points += scanner.scan(scanner.raster(k, pilot), pilot, k, dropped).size();
  if (points == 0) throw std::invalid_argument("AsBuiltSettings: the scanner sees nothing");
  return pilot * std::sqrt(static_cast<double>(points) / static_cast<double>(target));
}

}  // namespace

double true_deviation(const AsBuiltSettings& s, const Eigen::Vector3d& x,
                      const Eigen::Vector3d& n) {
  const double k = 2 * std::numbers::pi / s.warp_wavelength;
  double delta = s.warp_amplitude * std::sin(k * x.x() + 0.3) * std::sin(k * x.y() + 1.1) *
                 std::cos(k * x.z());
  for (const SurfaceDefect& d : s.defects) {
    const Eigen::Vector3d dn = d.normal.normalized(), r = x - d.centre;
    const double height = r.dot(dn);
    if (n.dot(dn) < 1 - 1e-9 || std::abs(height) > 1e-6) continue;  // another face
    const double rho = (r - height * dn).norm();
    if (rho >= d.radius) continue;
    const double c = std::cos(std::numbers::pi * rho / (2 * d.radius));
    delta += d.peak * c * c;
  }
  return delta;
}

AsBuiltScan make_as_built_scan(const AsBuiltSettings& s) {
  check_settings(s);
  check_defects(PartModel(s.part), s.defects);
  const Scanner scanner(s);
  AsBuiltScan out;
  out.pitch = s.target_points > 0 ? pitch_for(scanner, s, s.target_points) : s.pitch;
  const Eigen::Isometry3d T_scan_cad =
      rigid_transform(s.rotation_deg, s.rotation_axis, s.translation);
  out.T_cad_scan = T_scan_cad.inverse();
  for (std::size_t k = 0; k < s.views.size(); ++k) {
    ScanRaster r = scanner.raster(k, out.pitch);
    const std::vector<RawPoint> points = scanner.scan(r, out.pitch, k, out.dropped_near_part);
    r.points = points.size();
    out.rasters.push_back(r);
    for (const RawPoint& p : points) {
      out.scan.positions.push_back(T_scan_cad * p.p);
      out.label.push_back(p.label);
      out.deviation.push_back(p.deviation);
      out.view.push_back(static_cast<std::uint8_t>(k));
      (p.label == ScanLabel::kPart ? out.part_points : out.fixture_points)++;
    }
  }
  return out;
}

}  // namespace align3d::synth
