#include "align3d/range_image.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <string>

#include "align3d/cloud_stats.hpp"
#include "align3d/error.hpp"
#include "align3d/kdtree.hpp"

namespace align3d {
namespace {

constexpr std::size_t kMinScenePoints = 10;
constexpr double kMaxFitResidualPx = 0.5;
constexpr double kMaxSpreadDeg = 150;
constexpr int kMaxProjectedSide = 4096;  // pixels: bounds the made-up image's memory
// The given orientation is kept while the image's own rays agree with it to this angle.
constexpr double kMaxOrientationDeg = 1.0;
constexpr std::size_t kResectionSamples = 20000;  // points the resection reads at most

RangeImage empty_image(int width, int height) {
  RangeImage image;
  image.width = width;
  image.height = height;
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  image.depth.assign(n, std::numeric_limits<float>::quiet_NaN());
  image.point.assign(n, -1);
  return image;
}

// Keeps point i at pixel `at` if it is the nearest there.
void splat(RangeImage& image, std::size_t at, double z, std::size_t i) {
  if (std::isnan(image.depth[at]) || z < image.depth[at]) {
    image.depth[at] = static_cast<float>(z);
    image.point[at] = static_cast<std::int32_t>(i);
  }
}

// The sensor's field of an organized image: per row and per column its first and last pixel
// with depth (image.hpp, in_field).
void set_field(RangeImage& image) {
  const auto w = static_cast<std::size_t>(image.width), h = static_cast<std::size_t>(image.height);
  image.row_first.assign(h, image.width), image.row_last.assign(h, -1);
  image.col_first.assign(w, image.height), image.col_last.assign(w, -1);
  for (std::size_t v = 0; v < h; ++v)
    for (std::size_t u = 0; u < w; ++u) {
      if (image.point[v * w + u] < 0) continue;
      const int iu = static_cast<int>(u), iv = static_cast<int>(v);
      image.row_first[v] = std::min(image.row_first[v], iu);
      image.row_last[v] = std::max(image.row_last[v], iu);
      image.col_first[u] = std::min(image.col_first[u], iv);
      image.col_last[u] = std::max(image.col_last[u], iv);
    }
}

// The depth noise of an organized image by depth (image.hpp, noise_depth / noise_inverse). On a
// grid of 5 x 5 windows (every kNoiseStride pixels) whose pixels all have depth, the residual of a
// plane fitted to the inverse depth over (u, v) (a plane in space is one in 1/z; the window's
// offsets are symmetric, so the fit is three sums); its σ (22 degrees of freedom) per window; the
// windows sorted by depth into kNoiseBins bins of equal count, and each bin's median σ (windows
// across a depth edge or a corner are a minority: the median ignores them).
constexpr int kNoiseStride = 4;
constexpr std::size_t kNoiseBins = 8, kNoiseMinWindows = 50;  // windows a bin, at least
void estimate_depth_noise(RangeImage& image) {
  std::vector<std::pair<double, double>> windows;  // (z, σ of 1/z)
  for (int v = 2; v + 2 < image.height; v += kNoiseStride)
    for (int u = 2; u + 2 < image.width; u += kNoiseStride) {
      double sum = 0, su = 0, sv = 0, sq = 0;
      bool full = true;
      for (int dv = -2; dv <= 2 && full; ++dv)
        for (int du = -2; du <= 2; ++du) {
          const float z = image.depth[image.pixel(u + du, v + dv)];
          if (!(z > 0)) {
            full = false;
            break;
          }
          const double w = 1.0 / z;
          sum += w, su += du * w, sv += dv * w, sq += w * w;
        }
      if (!full) continue;
      // Σ du² = Σ dv² = 50 over the window; the fit's sum of squares is sum²/25 + su²/50 + sv²/50.
      const double rss = std::max(0.0, sq - sum * sum / 25 - (su * su + sv * sv) / 50);
      windows.emplace_back(25 / sum, std::sqrt(rss / 22));
    }
  if (windows.size() < kNoiseBins * kNoiseMinWindows) return;
  std::sort(windows.begin(), windows.end());
  for (std::size_t b = 0; b < kNoiseBins; ++b) {
    const auto first =
        windows.begin() + static_cast<std::ptrdiff_t>(b * windows.size() / kNoiseBins);
    const auto last =
        windows.begin() + static_cast<std::ptrdiff_t>((b + 1) * windows.size() / kNoiseBins);
    std::vector<double> sigmas;
    for (auto it = first; it != last; ++it) sigmas.push_back(it->second);
    std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
    image.noise_depth.push_back((first + (last - first) / 2)->first);
    image.noise_inverse.push_back(sigmas[sigmas.size() / 2]);
  }
}

// Least squares of coordinate c = centre + f·ratio over the samples: {f, centre, rms residual}.
struct LineFit {
  double f = 0, centre = 0, rms = 0;
};
LineFit fit_axis(const std::vector<Eigen::Vector2d>& samples) {  // (ratio, c)
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (const auto& s : samples) {
    const Eigen::Vector2d row(s.x(), 1.0);
    A.noalias() += row * row.transpose();
    b += row * s.y();
  }
  const Eigen::Vector2d x = A.ldlt().solve(b);
  double sum = 0;
  for (const auto& s : samples) sum += std::pow(x(0) * s.x() + x(1) - s.y(), 2);
  return {x(0), x(1), std::sqrt(sum / static_cast<double>(samples.size()))};
}

// The camera's orientation from the image itself (camera resection with its centre `eye` known,
// the direct linear transform): the 3×3 M = K·R with (u, v, 1) ∝ M·(p − eye) for every pixel's
// point, the smallest eigenvector of the stacked constraints (pixel coordinates normalized to
// ±1, Hartley 1997), then split by an RQ decomposition into the upper-triangular intrinsics K and
// the rotation R (cloud → camera). Hand-written: Eigen has the pieces, no library resects with a
// known centre. nullopt when the rays do not determine a right-handed camera in front of them.
std::optional<Eigen::Matrix3d> resected_rotation(const PointCloud& cloud,
                                                 const std::vector<std::uint32_t>& pixels,
                                                 int width, int height,
                                                 const Eigen::Vector3d& eye) {
  const double half = 0.5 * std::max(width, height);
  Eigen::Matrix<double, 9, 9> normal = Eigen::Matrix<double, 9, 9>::Zero();
  const std::size_t step = std::max<std::size_t>(1, cloud.size() / kResectionSamples);
  std::vector<Eigen::Vector3d> rays;
  for (std::size_t i = 0; i < cloud.size(); i += step) {
    const Eigen::Vector3d d = cloud.positions[i] - eye;
    if (!(d.norm() > 0)) continue;
    rays.push_back(d.normalized());
    const double u =
        (static_cast<double>(pixels[i] % static_cast<std::uint32_t>(width)) - 0.5 * width) / half;
    const double v =
        (static_cast<double>(pixels[i] / static_cast<std::uint32_t>(width)) - 0.5 * height) / half;
    Eigen::Matrix<double, 9, 1> a = Eigen::Matrix<double, 9, 1>::Zero(), b = a;
    a << rays.back(), Eigen::Vector3d::Zero(), -u * rays.back();
    b << Eigen::Vector3d::Zero(), rays.back(), -v * rays.back();
    normal.noalias() += a * a.transpose() + b * b.transpose();
  }
  if (rays.size() < kMinScenePoints) return std::nullopt;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(normal);
  const Eigen::Matrix<double, 9, 1> m = eig.eigenvectors().col(0);
  Eigen::Matrix3d M;
  M << m.segment<3>(0).transpose(), m.segment<3>(3).transpose(), m.segment<3>(6).transpose();
  std::size_t front = 0;
  for (const Eigen::Vector3d& r : rays) front += M.row(2).dot(r) > 0;
  if (2 * front < rays.size()) M = -M;
  Eigen::Matrix3d to_pixels;  // undoes the normalization
  to_pixels << half, 0, 0.5 * width, 0, half, 0.5 * height, 0, 0, 1;
  M = to_pixels * M;
  // RQ: with J the row reversal, QR of (J·M)ᵀ = Q·U gives M = (J·Uᵀ·J)·(J·Qᵀ).
  Eigen::Matrix3d J;
  J << 0, 0, 1, 0, 1, 0, 1, 0, 0;
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr((J * M).transpose());
  const Eigen::Matrix3d Q = qr.householderQ();
  const Eigen::Matrix3d U = qr.matrixQR().triangularView<Eigen::Upper>();
  const Eigen::Matrix3d K = J * U.transpose() * J;
  Eigen::Matrix3d R = J * Q.transpose();
  for (int k = 0; k < 3; ++k)  // K's diagonal positive: its sign moves into R's row
    if (K(k, k) < 0) R.row(k) *= -1;
  if (!(R.determinant() > 0) || !R.allFinite()) return std::nullopt;  // a mirrored image
  return R;
}

}  // namespace

RangeImage organized_range_image(const PointCloud& cloud, const std::vector<std::uint32_t>& pixels,
                                 int width, int height, const Eigen::Isometry3d& T_given) {
  if (width <= 0 || height <= 0 || pixels.size() != cloud.size())
    throw DataError("scene", "an organized cloud needs one pixel index per point");
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (pixels[i] >= n)
      throw DataError("scene", "pixel index " + std::to_string(pixels[i]) + " outside the " +
                                   std::to_string(width) + " x " + std::to_string(height) +
                                   " image");
  // The orientation the image's rays give replaces a given one they contradict (a PCD VIEWPOINT
  // is often a placeholder: PCL's own Kinect frames carry a half turn about x).
  Eigen::Isometry3d T_cloud_camera = T_given;
  double disagreement = 0;
  bool from_rays = false;
  if (const auto R = resected_rotation(cloud, pixels, width, height, T_given.translation())) {
    const Eigen::Matrix3d rays_camera = R->transpose();  // camera → cloud
    disagreement = Eigen::AngleAxisd(T_given.linear().transpose() * rays_camera).angle();
    from_rays = disagreement > kMaxOrientationDeg * std::numbers::pi / 180;
    if (from_rays) T_cloud_camera.linear() = rays_camera;
  }
  const Eigen::Isometry3d T_camera_cloud = T_cloud_camera.inverse();
  std::vector<Eigen::Vector2d> us, vs;  // (x/z, u), (y/z, v)
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p = T_camera_cloud * cloud.positions[i];
    if (!(p.z() > 0)) continue;
    us.emplace_back(p.x() / p.z(), static_cast<double>(pixels[i] % width));
    vs.emplace_back(p.y() / p.z(), static_cast<double>(pixels[i] / width));
  }
  if (us.size() < kMinScenePoints)
    throw DataError("scene", std::to_string(us.size()) +
                                 " points in front of the camera; at least 10 are needed");
  const LineFit fu = fit_axis(us), fv = fit_axis(vs);
  RangeImage image = empty_image(width, height);
  image.T_cloud_camera = T_cloud_camera;
  image.organized = true;
  image.given_orientation_error_deg = disagreement * 180 / std::numbers::pi;
  image.orientation_from_rays = from_rays;
  image.fx = fu.f, image.cx = fu.centre, image.fy = fv.f, image.cy = fv.centre;
  image.fit_rms_px = std::hypot(fu.rms, fv.rms);
  if (!(image.fx > 0 && image.fy > 0) || !(image.fit_rms_px <= kMaxFitResidualPx))
    throw DataError("scene", "its points do not fit a pinhole camera at the viewpoint (residual " +
                                 std::to_string(image.fit_rms_px) +
                                 " pixels): not a depth image in the camera's frame");
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double z = (T_camera_cloud * cloud.positions[i]).z();
    if (z > 0) splat(image, pixels[i], z, i);
  }
  set_field(image);
  estimate_depth_noise(image);
  return image;
}

RangeImage projected_range_image(const PointCloud& cloud, const Eigen::Isometry3d& T_cloud_camera) {
  const Eigen::Vector3d eye = T_cloud_camera.translation();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::size_t front = 0;
  for (const auto& p : cloud.positions) {
    const Eigen::Vector3d d = p - eye;
    if (d.norm() > 0) mean += d.normalized(), ++front;
  }
  if (front < kMinScenePoints || !(mean.norm() > 0))
    throw DataError("scene", std::to_string(front) +
                                 " points apart from the camera position; "
                                 "at least 10 are needed");
  const Eigen::Vector3d axis = mean.normalized();
  // The camera: z along the mean direction, x as close to the given camera's x as possible.
  Eigen::Vector3d x = T_cloud_camera.linear().col(0);
  x = (x - x.dot(axis) * axis);
  if (x.norm() < 1e-6) x = axis.unitOrthogonal();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x.normalized();
  T.linear().col(2) = axis;
  T.linear().col(1) = axis.cross(x.normalized());
  T.translation() = eye;
  const Eigen::Isometry3d T_camera_cloud = T.inverse();

  // Angular extent and resolution: tan of the ray angles; one pixel per median point spacing.
  double max_tan = 0;
  std::vector<double> depths;
  depths.reserve(cloud.size());
  const double max_tan_allowed = std::tan(kMaxSpreadDeg / 2 * std::numbers::pi / 180);
  for (const auto& q : cloud.positions) {
    const Eigen::Vector3d p = T_camera_cloud * q;
    if (!(p.z() > 0)) continue;
    max_tan = std::max({max_tan, std::abs(p.x() / p.z()), std::abs(p.y() / p.z())});
    depths.push_back(p.z());
  }
  if (depths.size() < kMinScenePoints || max_tan > max_tan_allowed)
    throw DataError("scene", "its points spread over more than " +
                                 std::to_string(static_cast<int>(kMaxSpreadDeg)) +
                                 " degrees around the viewpoint: no single camera sees them");
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const double median_depth = depths[depths.size() / 2];
  const KdTree tree(cloud.positions);
  const double spacing = point_spacing(cloud, tree);
  double f = spacing > 0 ? median_depth / spacing : 1.0;
  f = std::min(f, (kMaxProjectedSide / 2 - 1) / std::max(max_tan, 1e-9));
  const int side = static_cast<int>(std::ceil(2 * f * max_tan)) + 2;
  RangeImage image = empty_image(side, side);
  image.T_cloud_camera = T;
  image.fx = image.fy = f;
  image.cx = image.cy = (side - 1) / 2.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p = T_camera_cloud * cloud.positions[i];
    if (!(p.z() > 0)) continue;
    const Eigen::Vector2d uv = image.project(p);
    const long u = std::lround(uv.x()), v = std::lround(uv.y());
    if (u < 0 || v < 0 || u >= side || v >= side) continue;
    splat(image, image.pixel(static_cast<int>(u), static_cast<int>(v)), p.z(), i);
  }
  return image;
}

double RangeImage::depth_sigma(double z) const {
  if (noise_depth.empty()) return 0;
  const auto hi = std::lower_bound(noise_depth.begin(), noise_depth.end(), z);
  double inverse = 0;
  if (hi == noise_depth.begin()) {
    inverse = noise_inverse.front();
  } else if (hi == noise_depth.end()) {
    inverse = noise_inverse.back();
  } else {
    const auto k = static_cast<std::size_t>(hi - noise_depth.begin());
    const double t = (z - noise_depth[k - 1]) / (noise_depth[k] - noise_depth[k - 1]);
    inverse = noise_inverse[k - 1] + t * (noise_inverse[k] - noise_inverse[k - 1]);
  }
  return z * z * inverse;
}

}  // namespace align3d
