// Bin-picking scenes with exact ground truth, for `align3d find`: a bin on a floor holding K
// instances of a part's CAD mesh dropped at random poses (touching, never interpenetrating) among
// distractor objects, seen from above by a depth camera (synth/camera.hpp's sensor model) whose
// rays are cast at the meshes through MeshIndex (mesh_index.hpp). Units: millimetres. Same
// settings, same bits (at any thread count).
//
// The parts (model frame: z up, the part resting on z = 0 in its CAD pose):
//   bracket  the machined part of synth/part.hpp (120 × 80 × 55 with the boss, 812 triangles):
//            no symmetry;
//   flange   a turned flanged bushing, a surface of revolution about the z axis: flange r 45,
//            10 thick; hub r 25 up to z = 50; bore r 12 through; every circle a regular polygon
//            of `flange_segments` sides, so its symmetry is continuous for matching purposes
//            (rotation about z by any angle moves the surface by at most r·(1 − cos(π/n))).
//   plate    a mostly flat part: the machined part of synth/part.hpp as a 110 × 70 × 10 mounting
//            plate (bin_plate_settings(): 1.5 mm chamfer, a 30 × 16 slot 4 deep with a hole r 4
//            through it, a hole r 5, a boss r 7 standing 4 high): no symmetry, its features small
//            beside its two large faces (what makes flat parts prone to false matches on planes).
// Distractors: boxes, cylinders and spheres (as meshes) of 30–110 mm, not the part.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "align3d/mesh.hpp"
#include "align3d/plane/plane.hpp"
#include "align3d/synth/camera.hpp"
#include "align3d/synth/part.hpp"

namespace align3d::synth {

enum class BinPart : std::uint8_t { kBracket, kFlange, kPlate };
const char* to_string(BinPart part);  // "bracket", "flange" or "plate"
// "bracket", "flange" or "plate"; std::invalid_argument otherwise.
BinPart bin_part_from_string(const std::string& name);

// The part's closed, outward-wound mesh in its model frame (header).
TriangleMesh bin_part_mesh(BinPart part, int flange_segments = 64);
// The plate's description (header): the machined part's settings with a plate's sizes.
PartSettings bin_plate_settings();

// Closed, outward-wound meshes of simple solids, centred on the origin: a box of the given half
// sizes; a cylinder of radius r and half height h about z (`segments` sides); a sphere of radius r
// (`rings` × 2·`rings` latitude-longitude cells). The surface of revolution of a closed profile
// polygon (r, z) with r > 0 everywhere, about z with `segments` sides.
TriangleMesh box_mesh(const Eigen::Vector3d& half_size);
TriangleMesh cylinder_mesh(double radius, double half_height, int segments);
TriangleMesh sphere_mesh(double radius, int rings);
TriangleMesh revolve(const std::vector<Eigen::Vector2d>& profile, int segments);

// World frame: the floor is z = 0, z up, the bin's base centred on the origin. The camera looks
// down from `camera_height` above the floor, its optical axis through the origin tilted by
// `camera_tilt_deg` about the horizontal `camera_tilt_axis`; image up is world +y. Instances and
// then distractors are dropped one at a time: a uniformly random orientation (seeded), a random
// position over the bin's inner floor, lowered until it would come closer than `clearance` to
// the floor, a wall or an object already placed (checked both ways on surface samples). An object
// that cannot be placed after 50 tries is left out (BinPickingScene counts what was placed).
struct BinPickingSettings {
  std::uint64_t seed = 1;
  BinPart part = BinPart::kBracket;
  int instances = 6;  // 0 to 12
  int distractors = 3;
  PinholeCamera camera;  // intrinsics; T_world_camera is set from the fields below
  double camera_height = 1000;
  double camera_tilt_deg = 5;
  Eigen::Vector3d camera_tilt_axis{1, 0.6, 0};
  Eigen::Vector3d bin_size{600, 420, 220};  // outer length, width, height
  double bin_wall = 12;                     // wall and bottom thickness
  double clearance = 0.5;                   // mm between placed objects
  DepthSensorSettings sensor;
  int threads = 0;  // rendering; the scene does not depend on it
};

struct BinPickingInstance {
  Eigen::Isometry3d T_camera_model;  // scene (camera frame) ≈ T·model
  std::size_t pixels = 0;            // valid pixels of the scene on this instance
  // BOP's visib_fract: pixels where the instance is the first surface hit ÷ pixels it would cover
  // alone in front of the same camera (exact ray casts, no sensor losses); 0 when it covers none.
  double visible_fraction = 0;
};

struct BinPickingScene {
  OrganizedCloud cloud;  // camera frame; cloud.shape: the instance index, or −1 for the rest
  TriangleMesh model;    // bin_part_mesh(settings.part)
  PinholeCamera camera;  // with its pose T_world_camera
  Plane floor;           // the bin's inner bottom (z = bin_wall) in the camera frame, normal up
  std::vector<BinPickingInstance> instances;  // those placed, in drop order
  int distractors = 0;                        // distractors placed
};

// Throws std::invalid_argument for bad settings (instances outside 0–12, negative distractors,
// a bin that does not fit the part, a camera that does not see it).
BinPickingScene make_bin_picking_scene(const BinPickingSettings& settings = {});

}  // namespace align3d::synth
