// The scene as a depth camera saw it: a pinhole image whose pixels hold the nearest scene point
// along their ray, the frame in which `align3d find` verifies its hypotheses (find.hpp).
//
// Camera frame: x right, y down, z forward (the optical axis). Pixel (u, v) is column u, row v;
// a point p projects to u = cx + fx·p.x / p.z, v = cy + fy·p.y / p.z (OpenCV's convention).
//
// From an organized cloud (a depth camera's image) the camera's orientation is resected from the
// pixels' rays about the given camera position (the given orientation is kept when it agrees to
// 1°), then the intrinsics are fitted by least squares to u·z = cx·z + fx·x (and v likewise) over
// its valid pixels: exact for a pinhole camera, whatever the depth noise along the rays. Its depth
// noise is measured by depth (the residual of planes fitted to 1/z over 5 × 5 windows; on PCL's
// Kinect frames σ of 1/z is 1.0-1.2e-3 per metre at every depth, σ_z 0.6 mm at 0.7 m to 26 mm at
// 5 m), and its field bounded by the pixels with depth. An
// unorganized cloud is projected through a made-up pinhole looking along its points' mean direction
// from the camera, with one pixel per median point spacing; where several points fall on a pixel
// the nearest is kept.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d {

struct RangeImage {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // The image's camera frame → the cloud's frame of the points indexed by `point` (cloud ≈ T·p).
  Eigen::Isometry3d T_cloud_camera = Eigen::Isometry3d::Identity();
  std::vector<float> depth;         // z in the camera frame per pixel (row-major); NaN: none
  std::vector<std::int32_t> point;  // the cloud's point at the pixel, or −1
  bool organized = false;           // from an organized cloud (else projected)
  double fit_rms_px = 0;            // organized: the pinhole fit's residual, pixels
  // Organized: the angle between the given orientation and the one the rays give (degrees), and
  // whether the rays' replaced the given one (more than 1° apart).
  double given_orientation_error_deg = 0;
  bool orientation_from_rays = false;
  // Organized: the sensor's field, per row and per column the first and last pixel with depth (a
  // depth camera returns nothing in a band at its border, often slanted by its registration: a
  // pixel there is not a surface that did not return); empty for a projected image (all of it).
  std::vector<int> row_first, row_last, col_first, col_last;
  // Organized: the depth noise by depth, estimated from the image (estimate_depth_noise): σ of
  // inverse depth (1/z) at depths noise_depth (ascending); empty when it could not be measured.
  std::vector<double> noise_depth, noise_inverse;

  bool in_field(int u, int v) const {
    if (row_first.empty()) return true;
    const auto r = static_cast<std::size_t>(v), c = static_cast<std::size_t>(u);
    return u >= row_first[r] && u <= row_last[r] && v >= col_first[c] && v <= col_last[c];
  }
  // σ of the depth at depth z: z² times the inverse depth's σ interpolated between the measured
  // depths (held beyond them: a triangulating sensor's disparity noise is the same at any depth,
  // so its depth noise grows with z²); 0 when none was measured.
  double depth_sigma(double z) const;

  std::size_t pixel(int u, int v) const {
    return static_cast<std::size_t>(v) * static_cast<std::size_t>(width) +
           static_cast<std::size_t>(u);
  }
  // Image coordinates of a camera-frame point with z > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    return {cx + fx * p.x() / p.z(), cy + fy * p.y() / p.z()};
  }
};

// `cloud` seen by a camera at T_given (its orientation replaced by the rays' where they disagree);
// `pixels[i]` the pixel index (v·width + u) of point i. Throws DataError("scene", …) when fewer
// than 10 points have positive depth, the pixel indices are out of range, or the points do not fit
// a pinhole camera (residual above 0.5 pixel: not a depth image, or points not in the camera's
// frame).
RangeImage organized_range_image(const PointCloud& cloud, const std::vector<std::uint32_t>& pixels,
                                 int width, int height, const Eigen::Isometry3d& T_given);

// Projects an unorganized cloud seen from the camera at T_cloud_camera (its z axis is replaced by
// the points' mean direction). Throws DataError("scene", …) when fewer than 10 points lie in
// front of the camera or they spread over more than 150° from it (a pinhole cannot see them).
RangeImage projected_range_image(const PointCloud& cloud, const Eigen::Isometry3d& T_cloud_camera);

}  // namespace align3d
