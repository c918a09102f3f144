// Synthetic scenes with known ground truth: the chapter's conveyor scene (section 39 opening,
// figure 39.1) and its harder variants, partial views of non-planar objects, and the rectification
// plates of section 39.5. Units are millimetres. Same settings and seed give identical clouds.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "align3d/point_cloud.hpp"

namespace align3d::synth {

struct ConveyorSettings {
  std::uint64_t seed = 39;
  int model_points = 5678;                 // model: plane + box + cap, sampled by area
  int scan_model_points = 4310;            // scan points that come from the model (after the crop)
  int wall_points = 2187;                  // scan points on the intruder wall (no correspondence)
  double plane_x = 280, plane_y = 200;     // conveyor plane, centred at the origin, z = 0
  Eigen::Vector3d box_centre{-30, 15, 0};  // box standing on the plane (base centre)
  Eigen::Vector3d box_size{40, 40, 25};
  Eigen::Vector2d cap_centre{35, -20};      // spherical cap standing on the plane
  double cap_radius = 28, cap_height = 14;  // sphere radius, cap height
  double rotation_deg = 12;                 // scan = T·model, T = (R about axis, t)
  Eigen::Vector3d rotation_axis{1, 2, 2};
  Eigen::Vector3d translation{5, -3, 2};
  double noise_sigma = 0.1;                // Gaussian, per coordinate, on the scan
  double wall_gap = 12, wall_height = 50;  // wall: this far right of the plane, this tall

  // Harder variants used by tests of the default registration: "chapter" (the above),
  // "wide-plane" (the plane dominates even more), "small-features" (smaller box and cap),
  // "large-offset" (20° and a 3× larger translation).
  static ConveyorSettings variant(const std::string& name);
};

struct Scene {
  PointCloud model;                    // the target
  PointCloud scan;                     // the source
  Eigen::Isometry3d T_model_scan;      // ground truth: model ≈ T·scan
  std::size_t scan_corresponding = 0;  // scan points that come from the model surfaces
  std::size_t scan_outliers = 0;       // scan points with no correspondence
};

Scene make_conveyor_scene(const ConveyorSettings& settings = {});

// A partial view of a non-planar object: target = the whole object surface; source = the part of
// it seen from one side (about `overlap` of the target's area), moved by a known transform, with
// noise and `outlier_fraction` of points scattered uniformly in the bounding box.
struct ObjectSettings {
  std::uint64_t seed = 7;
  std::string shape = "bumpy-sphere";  // "bumpy-sphere", "bracket" (an L-shaped part with a hole)
                                       // or "animal" (a quadruped of ellipsoids)
  int points = 8000;
  double overlap = 0.6;
  double outlier_fraction = 0.04;
  double noise_sigma = 0.1;
  double rotation_deg = 15;
  Eigen::Vector3d rotation_axis{0.3, -1, 0.5};
  Eigen::Vector3d translation{4, 3, -2};
};
Scene make_object_scene(const ObjectSettings& settings = {});

// A work cell for benchmarks at any size: a 1200 × 900 mm floor with a back wall and `parts`
// boxes, cylinders and domes of random sizes on a grid. target = the cell sampled with `points`
// points; source = an independent sampling of the cell (so no point has an exact twin), cropped to
// the `overlap` share of it farthest along +x, `points` points in all, moved by a known transform,
// with noise and `outlier_fraction` extra points scattered in the source's bounding box.
struct PartsSettings {
  std::uint64_t seed = 11;
  int points = 100000;
  int parts = 48;
  double overlap = 0.7;
  double outlier_fraction = 0.02;
  double noise_sigma = 0.1;
  double rotation_deg = 10;
  Eigen::Vector3d rotation_axis{1, -2, 3};
  Eigen::Vector3d translation{20, -10, 5};
};
Scene make_parts_scene(const PartsSettings& settings = {});

// Section 39.5: a plate tilted by `tilt_deg` about a slightly oblique horizontal-ish axis, with
// noise; with `clutter_fraction` > 0 a box-shaped part stands on the plate and holds that fraction
// of the points.
struct PlateSettings {
  std::uint64_t seed = 5;
  int points = 4000;
  double size_x = 100, size_y = 80;
  double tilt_deg = 7;
  Eigen::Vector3d tilt_axis{1, 0.35, 0};  // horizontal but oblique: a compound tilt
  double height = 20;                     // plate centre height above z = 0 before tilting
  double noise_sigma = 0.05;
  double clutter_fraction = 0.0;
};
struct Plate {
  PointCloud cloud;
  Eigen::Vector3d true_normal;  // the plate's upward unit normal
  std::size_t plate_points = 0;
};
Plate make_plate(const PlateSettings& settings = {});

// The chapter's plates for a scene seed, as `align3d synth` and the demo use them: the tilted plate
// (seed + 1) and, with `cluttered`, the plate with a part holding 20 % of the points (seed + 2).
PlateSettings chapter_plate(std::uint64_t scene_seed, bool cluttered);

}  // namespace align3d::synth
