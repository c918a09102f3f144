// Depth-camera scenes with exact ground truth, rendered by synth/camera.hpp from analytic shapes
// (synth/shapes.hpp): a bin seen from above (bin picking) and range scans of one object from
// several viewpoints (multi-view stitching). Units: millimetres. Same settings, same bits.
//
// The test object (object frame: its base on z = 0, z up, ~140 × 80 × 75 mm): a base block
// 140 × 80 × 30 centred on the origin, an upright wall 18 × 68 × 65 near its +x end (an
// L-bracket), a cylinder boss (r 16, top at z = 65) at (−35, 12) and a sphere knob (r 16) at
// (5, −22, 34) sunk into the top. No symmetry maps it onto itself. Its parts overlap (no shared
// faces), so the sampled model holds the outer surface of the union only.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "align3d/plane/plane.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/synth/camera.hpp"
#include "align3d/synth/shapes.hpp"

namespace align3d::synth {

// The test object's parts in its own frame.
std::vector<Shape> test_object_shapes();
// Its model: `points` samples spread evenly by area over its outer surface, with outward normals.
PointCloud test_object_model(int points = 20000, std::uint64_t seed = 1);
// An animal: a quadruped about 115 mm long and 93 mm tall made of ellipsoids (body, neck, head,
// snout, two ears, four legs, a tail), standing on z = 0 and facing +x. Its head, ears and tail
// turn a little to one side, so it has no mirror plane; where the ellipsoids meet, its creases are
// sharper than a scanned animal's.
std::vector<Shape> animal_shapes();

// A bin on a floor, seen from above by a depth camera. World frame: the floor is z = 0, z up, the
// bin's base centred on the origin. The camera sits `camera_height` above the floor, its optical
// axis through the origin and tilted from the vertical by `camera_tilt_deg` about
// `camera_tilt_axis` (horizontal), so the floor is not fronto-parallel; image up is world +y.
// Inside the bin rest `instances` copies of the test object (random yaw, tilted by up to
// `max_instance_tilt_deg`, lowest point on the bin's bottom) and `clutter` boxes, cylinders and
// spheres of random sizes (30–120 mm), none overlapping another (bounding circles apart); clutter
// that finds no free spot is left out. The default bin holds 3 instances for any seed (4 for
// most). The
// sensor: camera.hpp's Kinect-like defaults. `seed` draws the placements, the model's samples and
// (through splitmix64(seed + 1)) the sensor's dropout and noise.
struct BinSceneSettings {
  std::uint64_t seed = 1;
  PinholeCamera camera;  // intrinsics; T_world_camera is set from the fields below
  double camera_height = 900;
  double camera_tilt_deg = 4;
  Eigen::Vector3d camera_tilt_axis{1, 0.6, 0};
  Eigen::Vector3d bin_size{600, 420, 200};  // outer length, width, height
  double bin_wall = 12;                     // wall and bottom thickness
  int instances = 1;
  int clutter = 6;
  double max_instance_tilt_deg = 20;
  int model_points = 20000;
  DepthSensorSettings sensor;
};

struct BinScene {
  OrganizedCloud cloud;                            // camera frame
  PointCloud model;                                // the test object (object frame), with normals
  std::vector<Eigen::Isometry3d> T_camera_object;  // per instance: scene ≈ T·model
  std::vector<int> instance;  // per pixel: the instance its point lies on, −1 for none or NaN
  Plane floor;                // the floor in the camera frame, normal towards the camera
  PinholeCamera camera;       // with its pose T_world_camera
  std::vector<Shape> shapes;  // world frame: floor, bin, clutter, then the instances' parts
  std::vector<int> shape_instance;  // per shape: the instance it belongs to, −1 for the others
  int clutter = 0;                  // clutter parts placed (fewer than asked when the bin is full)
};

// Throws std::invalid_argument for bad settings or when the instances do not fit into the bin.
BinScene make_bin_scene(const BinSceneSettings& settings = {});

// Range scans of the test object (or of the animal: `object`) alone (no background), one per
// azimuth: the camera is on a circle of radius `distance` about the object's vertical axis,
// `elevation_deg` above the plane z = `target_height` and looking at the point (0, 0,
// target_height). View k sees one side of the object; two views share less of it the farther apart
// their azimuths are. Overlap of the test object, as the share of the model seen by both among that
// seen by either, for the default first view (30°) and a second one 10°, 60°, 120°, 180° away:
// 0.91, 0.46, 0.35, 0.11 (at 180° the top faces, seen at 70° incidence, and two end faces remain
// common).
// Defaults: a structured-light scanner at ~0.5 m (narrower field of view, σ ≈ 0.1 mm).
struct ObjectViewsSettings {
  std::uint64_t seed = 1;
  std::string object = "part";  // "part" (test_object_shapes) or "animal" (animal_shapes)
  std::vector<double> azimuth_deg = {30, 90};
  double distance = 500;
  double elevation_deg = 20;
  double target_height = 30;
  PinholeCamera camera{.fx = 1000, .fy = 1000};
  DepthSensorSettings sensor{.min_depth = 300,
                             .max_depth = 1500,
                             .noise_a = 0.05,  // σ = 0.1 mm at 0.5 m
                             .noise_b = 2e-7,
                             .projector_offset = {80, 0, 0},
                             .dropout = 0.005,
                             .hole_clusters = 8,
                             .hole_radius_max = 3};
  int model_points = 20000;
};

struct ObjectViews {
  PointCloud model;                                // the test object (object frame), with normals
  std::vector<OrganizedCloud> views;               // view k in its own camera frame
  std::vector<PinholeCamera> cameras;              // T_world_camera with world = the object frame
  std::vector<Eigen::Isometry3d> T_camera_object;  // view k ≈ T_k·model; view i ≈ T_i·T_j⁻¹·view j
};

// Throws std::invalid_argument for no azimuth, an unknown object or a distance that puts the
// camera inside the object.
ObjectViews make_object_views(const ObjectViewsSettings& settings = {});

}  // namespace align3d::synth
