#include "align3d/synth/stitch_scans.hpp"

#include <cmath>
#include <optional>
#include <stdexcept>

#include "align3d/mesh_index.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/bin_picking.hpp"
#include "detail/parallel.hpp"
#include "detail/random.hpp"

namespace align3d::synth {
namespace {

constexpr double kMaxElevationDeg = 80;
constexpr std::uint64_t kOverlapSampleSeed = 1;  // the overlap is the views', not the seed's

// a's triangles and vertices followed by b's.
void append(TriangleMesh& a, const TriangleMesh& b) {
  const auto offset = static_cast<std::uint32_t>(a.vertices.size());
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (const auto& t : b.triangles)
    a.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
}

void check(const StitchScanSettings& s, double radius) {
  if (s.views < 2) throw std::invalid_argument("make_stitch_scans: at least 2 views");
  if (!(s.distance > radius) || !(s.leaf_distance > radius) || !std::isfinite(s.distance) ||
      !std::isfinite(s.leaf_distance))
    throw std::invalid_argument(
        "make_stitch_scans: the distances must put the cameras outside the object's bounding "
        "sphere (radius " +
        std::to_string(radius) + " mm)");
  for (double e :
       {s.high_elevation_deg, s.low_elevation_deg, s.leaf_elevation_deg, s.parent_elevation_deg})
    if (!(std::abs(e) <= kMaxElevationDeg))
      throw std::invalid_argument("make_stitch_scans: elevations must lie within ±80°");
  if (!(s.jitter_deg >= 0) || !(s.jitter_mm >= 0) || !std::isfinite(s.tilt_deg) ||
      s.overlap_samples < 100)
    throw std::invalid_argument("make_stitch_scans: bad jitter, tilt or overlap samples");
}

// T_world_object: the object's bounding-box centre at the origin, then tilted by tilt_deg about the
// horizontal axis perpendicular to azimuth_deg so that its −z turns towards that azimuth.
Eigen::Isometry3d place_object(const Eigen::Vector3d& centre, double tilt_deg, double azimuth_deg) {
  const double a = deg_to_rad(azimuth_deg);
  const Eigen::Vector3d towards(std::cos(a), std::sin(a), 0);
  // Rodrigues: a rotation by θ about (towards × z) takes −z to −z·cos θ + towards·sin θ.
  Eigen::Isometry3d T = rigid_transform(tilt_deg, towards.cross(Eigen::Vector3d::UnitZ()));
  T.translation() = -(T.linear() * centre);
  return T;
}

// A camera pose T_world_camera at azimuth, elevation and distance about the origin, jittered.
// The draws, always seven and in this order: azimuth, elevation, distance, the aimed point's x, y,
// z, roll.
Eigen::Isometry3d jittered_view(double azimuth_deg, double elevation_deg, double distance,
                                const StitchScanSettings& s, Random& rng) {
  const double a = deg_to_rad(azimuth_deg + rng.uniform(-s.jitter_deg, s.jitter_deg));
  const double e = deg_to_rad(elevation_deg + rng.uniform(-s.jitter_deg, s.jitter_deg));
  const double d = distance + rng.uniform(-s.jitter_mm, s.jitter_mm);
  Eigen::Vector3d target;
  for (int i = 0; i < 3; ++i) target[i] = rng.uniform(-s.jitter_mm, s.jitter_mm);
  const double roll = rng.uniform(-s.jitter_deg, s.jitter_deg);
  const Eigen::Vector3d eye = target + d * Eigen::Vector3d(std::cos(e) * std::cos(a),
                                                           std::cos(e) * std::sin(a), std::sin(e));
  return look_at(eye, target, Eigen::Vector3d::UnitZ()) *
         rigid_transform(roll, Eigen::Vector3d::UnitZ());
}

// Per view, per sample: whether the sample is visible (header, "Overlap").
std::vector<std::uint8_t> visibility(const MeshIndex& index, const PointCloud& samples,
                                     const std::vector<PinholeCamera>& cameras,
                                     const DepthSensorSettings& sensor, int threads) {
  const std::size_t n = samples.size();
  const double min_cos = std::cos(deg_to_rad(sensor.max_incidence_deg));
  std::vector<std::uint8_t> visible(cameras.size() * n, 0);
  parallel_for(visible.size(), threads, [&](std::size_t i) {
    const PinholeCamera& c = cameras[i / n];
    const Eigen::Vector3d& p = samples.positions[i % n];
    const Eigen::Vector3d& normal = samples.normals[i % n];
    const Eigen::Vector3d in_camera = c.T_world_camera.inverse() * p;
    if (!(in_camera.z() >= sensor.min_depth && in_camera.z() <= sensor.max_depth)) return;
    const Eigen::Vector2d uv = c.project(in_camera);
    if (uv.x() < -0.5 || uv.x() >= c.width - 0.5 || uv.y() < -0.5 || uv.y() >= c.height - 0.5)
      return;
    const Eigen::Vector3d eye = c.T_world_camera.translation();
    const Eigen::Vector3d to_sample = p - eye;
    if (-normal.dot(to_sample) <= min_cos * to_sample.norm()) return;  // grazing or facing away
    RayHit hit;  // anything in front of the sample, 1e-6 of the way short of it
    visible[i] = !index.intersect(eye, to_sample, hit, 0, 1 - 1e-6);
  });
  return visible;
}

Eigen::MatrixXd jaccard(const std::vector<std::uint8_t>& visible, std::size_t views) {
  const std::size_t n = visible.size() / views;
  Eigen::MatrixXd overlap =
      Eigen::MatrixXd::Identity(static_cast<Eigen::Index>(views), static_cast<Eigen::Index>(views));
  for (std::size_t i = 0; i < views; ++i)
    for (std::size_t j = i + 1; j < views; ++j) {
      std::size_t both = 0, either = 0;
      for (std::size_t k = 0; k < n; ++k) {
        both += visible[i * n + k] & visible[j * n + k];
        either += visible[i * n + k] | visible[j * n + k];
      }
      const double share = either ? static_cast<double>(both) / static_cast<double>(either) : 0.0;
      overlap(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = share;
      overlap(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) = share;
    }
  return overlap;
}

}  // namespace

const char* to_string(StitchObject object) {
  return object == StitchObject::kBracket ? "bracket" : "flange";
}

StitchObject stitch_object_from_string(const std::string& name) {
  if (name == "bracket") return StitchObject::kBracket;
  if (name == "flange") return StitchObject::kKeyedFlange;
  throw std::invalid_argument("unknown object '" + name + "' (bracket or flange)");
}

TriangleMesh keyed_flange_mesh(int segments) {
  TriangleMesh mesh = bin_part_mesh(BinPart::kFlange, segments);
  const TriangleMesh lug = box_mesh({5.5, 4, 7.5});  // r 39..50, 8 wide, z 0..15
  for (double angle : kKeyedFlangeLugDeg) {
    Eigen::Isometry3d T = rigid_transform(angle, Eigen::Vector3d::UnitZ());
    T.translation() = T.linear() * Eigen::Vector3d(44.5, 0, 7.5);
    append(mesh, transformed(lug, T));
  }
  return mesh;
}

TriangleMesh stitch_object_mesh(StitchObject object) {
  return object == StitchObject::kBracket ? bin_part_mesh(BinPart::kBracket) : keyed_flange_mesh();
}

StitchScans make_stitch_scans(const StitchScanSettings& s) {
  StitchScans out;
  out.mesh = stitch_object_mesh(s.object);
  const Eigen::AlignedBox3d box = bounding_box(out.mesh);
  out.diameter = bounding_box_diagonal(out.mesh);
  check(s, out.diameter / 2);
  const MeshIndex index(out.mesh, s.threads, "stitch object");

  const int parent = (s.views / 2) | 1;
  const double step = 360.0 / s.views;
  const Eigen::Isometry3d T_world_object = place_object(box.center(), s.tilt_deg, parent * step);
  const Eigen::Isometry3d T_object_world = T_world_object.inverse();
  Random rng(s.seed);
  for (int k = 0; k < s.views; ++k) {
    double e = k % 2 == 0 ? s.high_elevation_deg : s.low_elevation_deg;
    if (s.leaf && k == parent) e = s.parent_elevation_deg;
    PinholeCamera& c = out.cameras.emplace_back(s.camera);
    c.T_world_camera = T_object_world * jittered_view(k * step, e, s.distance, s, rng);
  }
  if (s.leaf) {
    PinholeCamera& c = out.cameras.emplace_back(s.camera);
    c.T_world_camera = T_object_world *
                       jittered_view(parent * step, s.leaf_elevation_deg, s.leaf_distance, s, rng);
    out.leaf = s.views;
    out.leaf_parent = parent;
  }

  const RayCaster cast = [&index](const Ray& ray, double t_min,
                                  double t_max) -> std::optional<Hit> {
    RayHit h;
    if (!index.intersect(ray.origin, ray.direction, h, t_min, t_max)) return std::nullopt;
    return Hit{h.t, ray.origin + h.t * ray.direction, index.face_normal(h.triangle), 0};
  };
  DepthSensorSettings sensor = s.sensor;
  sensor.threads = s.threads;
  for (std::size_t k = 0; k < out.cameras.size(); ++k) {
    const PinholeCamera& c = out.cameras[k];
    out.scans.push_back(render_rays(c, cast, sensor, splitmix64(s.seed + k + 1)).valid_points());
    out.T_camera_object.push_back(c.T_world_camera.inverse());
    out.eye.push_back(c.T_world_camera.translation());
    out.T_first_scan.push_back(out.T_camera_object[0] * c.T_world_camera);
  }
  out.T_first_scan[0] = Eigen::Isometry3d::Identity();

  const PointCloud samples =
      sample_surface(index.mesh(), static_cast<std::size_t>(s.overlap_samples), kOverlapSampleSeed);
  out.overlap =
      jaccard(visibility(index, samples, out.cameras, sensor, s.threads), out.cameras.size());
  return out;
}

}  // namespace align3d::synth
