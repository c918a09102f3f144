#include "align3d/plane/rectify.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>
#include <stdexcept>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/se3.hpp"

namespace align3d {

Eigen::Matrix3d rotation_to_z(const Eigen::Vector3d& n) {
  return shortest_arc(n, Eigen::Vector3d::UnitZ());
}

namespace {

double angle_to_z_deg(const Eigen::Vector3d& n) {
  return rad_to_deg(std::atan2(n.cross(Eigen::Vector3d::UnitZ()).norm(), n.z()));
}

// The up side from the points off the plane (policy 2 of rectify.hpp); 0 when undecided. Only
// points over the plate's footprint count: a floor showing past the plate's edge is not a part.
double part_side(const std::vector<Eigen::Vector3d>& points, const Plane& plane,
                 const std::vector<std::size_t>& inliers) {
  std::vector<double> r;
  r.reserve(inliers.size());
  for (std::size_t i : inliers) r.push_back(std::abs(plane.signed_distance(points[i])));
  auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
  std::nth_element(r.begin(), mid, r.end());
  const double cut = 6 * 1.4826 * *mid;
  // The extent of the points on the plane (within the cut) along their principal in-plane axes
  // u, v: a tight box for a plate.
  std::vector<std::size_t> on_plane;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (std::abs(plane.signed_distance(points[i])) <= cut) on_plane.push_back(i);
  Eigen::Vector3d u = plane.normal.unitOrthogonal(), v = plane.normal.cross(u);
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (std::size_t i : on_plane) {
    const Eigen::Vector3d d = points[i] - plane.point;
    const Eigen::Vector2d w(d.dot(u), d.dot(v));
    cov.noalias() += w * w.transpose();
  }
  const Eigen::Matrix2d axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvectors();
  const Eigen::Vector3d u0 = u;
  u = axes(0, 0) * u0 + axes(1, 0) * v;
  v = plane.normal.cross(u);
  Eigen::AlignedBox2d footprint;
  for (std::size_t i : on_plane) {
    const Eigen::Vector3d d = points[i] - plane.point;
    footprint.extend(Eigen::Vector2d(d.dot(u), d.dot(v)));
  }
  std::size_t above = 0, below = 0;
  for (const auto& p : points) {
    const double d = plane.signed_distance(p);
    if (std::abs(d) <= cut) continue;
    const Eigen::Vector3d w = p - plane.point;
    if (!footprint.contains(Eigen::Vector2d(w.dot(u), w.dot(v)))) continue;
    above += d > 0;
    below += d < 0;
  }
  if (static_cast<double>(above + below) <= 0.005 * static_cast<double>(points.size()) ||
      above == below)
    return 0.0;
  return above > below ? 1.0 : -1.0;
}

// The not_flat warning (rectify.hpp): the inliers' RMS against the cloud's own surface noise.
void check_flatness(const PointCloud& cloud, bool robust, RectifyResult& out) {
  const KdTree tree(cloud.positions);
  out.noise = surface_noise(cloud, tree);
  const double floor = std::max(out.noise, 0.05 * point_spacing(cloud, tree));
  if (!(out.rms > kMaxFlatnessNoise * floor)) return;
  std::ostringstream m;
  m.precision(3);
  m << "the " << out.inliers << " points fitted lie " << out.rms << " (RMS) from the plane, "
    << out.rms / floor << " x the surface noise " << floor
    << ": they do not lie on one plane, so the tilt is not to be trusted"
    << (robust ? " (a curved or stepped surface?)"
               : " (parts or walls in the fit? the robust fit finds the dominant plane)");
  out.warnings.push_back({"not_flat", m.str()});
}

}  // namespace

RectifyResult rectify(const PointCloud& cloud, const RectifySettings& settings) {
  // Only up's direction counts; scaling by its largest component keeps a tiny (even subnormal) one
  // from vanishing in the dot product below.
  const double up_scale = settings.up ? settings.up->cwiseAbs().maxCoeff() : 1.0;
  if (!(up_scale > 0) || !std::isfinite(up_scale))
    throw std::invalid_argument("rectify: RectifySettings::up must be a finite non-zero vector");
  check_finite(cloud, "cloud");
  const auto& points = cloud.positions;
  std::vector<std::size_t> inliers;
  Plane plane;
  if (settings.robust) {
    RansacPlaneResult r = ransac_plane(points, settings.ransac);
    plane = r.plane;
    inliers = std::move(r.inliers);
  } else {
    plane = fit_plane(points);
    inliers.resize(points.size());
    std::iota(inliers.begin(), inliers.end(), std::size_t{0});
  }
  double sign = 0;
  if (settings.up) {
    sign = plane.normal.dot(*settings.up / up_scale) >= 0 ? 1.0 : -1.0;
  }
  if (sign == 0) sign = part_side(points, plane, inliers);
  if (sign == 0) sign = plane.normal.z() >= 0 ? 1.0 : -1.0;
  plane.normal *= sign;

  RectifyResult out;
  out.normal = plane.normal;
  out.inliers = inliers.size();
  out.tilt_before_deg = angle_to_z_deg(plane.normal);
  const Eigen::Matrix3d R = rotation_to_z(plane.normal);
  out.T_level_cloud.linear() = R;
  out.T_level_cloud.translation() = Eigen::Vector3d(0, 0, -(R * plane.point).z());

  // Measure, don't assume: refit the moved inliers.
  std::vector<Eigen::Vector3d> moved;
  moved.reserve(inliers.size());
  for (std::size_t i : inliers) moved.push_back(out.T_level_cloud * points[i]);
  Plane after = fit_plane(moved);
  if (after.normal.z() < 0) after.normal = -after.normal;
  out.tilt_after_deg = angle_to_z_deg(after.normal);
  double lo = 0, hi = 0, sq = 0;
  for (std::size_t i : inliers) {
    const double d = plane.signed_distance(points[i]);
    lo = std::min(lo, d);
    hi = std::max(hi, d);
    sq += d * d;
  }
  out.flatness = hi - lo;
  out.rms = inliers.empty() ? 0.0 : std::sqrt(sq / static_cast<double>(inliers.size()));
  check_flatness(cloud, settings.robust, out);
  return out;
}

}  // namespace align3d
