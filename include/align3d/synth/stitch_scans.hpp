// Multi-view range scans of one object with exact ground truth, for `align3d stitch`: a ring of
// views around the object plus an optional leaf view, each rendered by casting the pixels' rays at
// the object's mesh through MeshIndex (mesh_index.hpp) with synth/camera.hpp's sensor model, and
// each scan kept in its own camera frame. Units: millimetres. Same settings, same bits (at any
// thread count).
//
// The objects (object frame: the mesh's own, z up, resting on z = 0):
//   bracket  bin_part_mesh(BinPart::kBracket), the machined part of synth/part.hpp (120 × 80 × 55
//            with the boss): no symmetry;
//   flange   keyed_flange_mesh(): the turned flange of bin_part_mesh(BinPart::kFlange) (r 45
//            flange, r 25 hub, r 12 bore, 50 high) keyed by three box lugs on its rim at uneven
//            angles. Near-symmetric: rotated about z by any multiple of 360°/64 the flange maps
//            onto itself, the lugs (about 6 % of its outer surface) do not, so a matcher must find
//            them.
//
// The rig (world frame: z up, the origin at the centre of the object's bounding box). Ring view k
// of N sits at azimuth 360°·k/N about the world z axis (from +x), `distance` from the origin and
// `high_elevation_deg` above the horizontal for even k, `low_elevation_deg` for odd k, looking at
// the origin with world +z up in its image. Every view is jittered: azimuth, elevation and the roll
// about the optical axis by up to ±jitter_deg, the distance and the aimed point's coordinates by
// up to ±jitter_mm (uniform, seeded).
// The object is held tilted by `tilt_deg` about a horizontal axis, its underside turned towards
// the low ring view P = (N / 2) | 1 (`leaf_parent`; 5 of 8), as a part propped up on a turntable.
// With a leaf, P looks from `parent_elevation_deg` (lower than the other low views) and sees the
// bottom face at about 90° + its elevation − tilt from its normal (65° with the defaults), while
// the high views look at it from behind its plane and the other low views, 90° or more away,
// edge-on. The leaf view (index N, when `leaf`) looks up at that underside from
// below, from P's azimuth, at `leaf_elevation_deg` and `leaf_distance`: it sees the bottom face
// (the flange's lugs and rim at most at its edge), which only P of the ring sees. Measured with
// the defaults for rings of 2 to 12 views, seeds 1 to 6 and both objects: overlap 0.55 to 0.75
// with P, at most 0.01 with any other view. The ring is connected through neighbours (0.16 to
// 0.64 between views 45° apart with seed 1); opposite views share little or nothing.
// The leaf's scan is nearly planar (a face with holes and its outline): a hard pair to register.
//
// Overlap of views i and j: the share of `overlap_samples` surface samples (sample_surface over the
// mesh) visible in both among those visible in either (Jaccard), where a sample is visible in a
// view when it projects into the image, its depth lies in the sensor's range, it faces the camera
// at less than the sensor's max_incidence_deg, and the ray from the eye to it crosses no surface
// before it. Exact geometry: no dropout, noise or projector shadows.
//
// Conventions: a transformation maps a source into a target's frame (target ≈ T·source);
// T_first_scan[k] maps scan k into scan 0's frame (scan_0 ≈ T_first_scan[k]·scan_k),
// T_camera_object[k] maps the object (the mesh) into scan k's camera frame. Camera frames are
// synth/camera.hpp's: the sensor at the origin, x right, y down, z along the optical axis.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "align3d/mesh.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/synth/camera.hpp"

namespace align3d::synth {

enum class StitchObject : std::uint8_t { kBracket, kKeyedFlange };
const char* to_string(StitchObject object);  // "bracket" or "flange"
// "bracket" or "flange" (the keyed flange); std::invalid_argument otherwise.
StitchObject stitch_object_from_string(const std::string& name);

// The angles of the keyed flange's lugs, degrees about z from +x.
inline constexpr double kKeyedFlangeLugDeg[3] = {0, 75, 200};

// bin_part_mesh(BinPart::kFlange, segments) plus three closed box meshes overlapping it (a lug
// each, at the kKeyedFlangeLugDeg angles): 11 mm radially (r 39 to 50, standing 5 mm proud of the
// rim), 8 mm wide, from the base z = 0 to z = 15 (5 mm above the flange's top). Four closed,
// outward-wound pieces: a ray cast takes the first hit, so the overlaps are harmless, but the
// parts of each piece inside another are sampled by sample_surface like the rest.
TriangleMesh keyed_flange_mesh(int segments = 64);
TriangleMesh stitch_object_mesh(StitchObject object);

struct StitchScanSettings {
  std::uint64_t seed = 1;
  StitchObject object = StitchObject::kBracket;
  int views = 8;          // ring views, at least 2
  double distance = 450;  // eye to the rig's origin
  double high_elevation_deg = 50, low_elevation_deg = 25;
  double tilt_deg = 30;  // the object's underside turned towards the leaf's parent
  bool leaf = true;
  double leaf_distance = 400;
  double leaf_elevation_deg = -45;  // below the horizontal: the leaf looks up
  // The leaf's parent P's elevation (with a leaf; without one P is a low view like the others).
  double parent_elevation_deg = 5;
  double jitter_deg = 3;  // azimuth, elevation, roll: uniform in ±this
  double jitter_mm = 5;   // distance and the aimed point: uniform in ±this
  // A structured-light scanner at ~0.5 m, as ObjectViewsSettings': σ ≈ 0.09 mm at 450 mm.
  PinholeCamera camera{.fx = 1000, .fy = 1000};
  DepthSensorSettings sensor{.min_depth = 200,
                             .max_depth = 1500,
                             .noise_a = 0.05,
                             .noise_b = 2e-7,
                             .projector_offset = {80, 0, 0},
                             .dropout = 0.005,
                             .hole_clusters = 8,
                             .hole_radius_max = 3};
  int overlap_samples = 20000;
  int threads = 0;  // rendering and visibility; 0: all cores; the result does not depend on it
};

struct StitchScans {
  TriangleMesh mesh;                               // the object, object frame
  std::vector<PointCloud> scans;                   // each in its camera frame, finite points only
  std::vector<Eigen::Isometry3d> T_first_scan;     // scan_0 ≈ T_k·scan_k (T_0 = identity)
  std::vector<Eigen::Isometry3d> T_camera_object;  // scan_k ≈ T_k·mesh
  std::vector<Eigen::Vector3d> eye;                // each camera's centre, object frame
  std::vector<PinholeCamera> cameras;  // intrinsics; T_world_camera with world = the object frame
  Eigen::MatrixXd overlap;             // views × views, symmetric, 1 on the diagonal (see above)
  double diameter = 0;                 // bounding_box_diagonal(mesh)
  int leaf = -1;                       // the leaf's scan index (the last), −1 without one
  int leaf_parent = -1;                // the ring view it overlaps (P above), −1 without a leaf
};

// Throws std::invalid_argument for bad settings: fewer than 2 views, a distance that puts a camera
// inside the object's bounding sphere (or not positive), elevations beyond ±80°, negative jitter,
// fewer than 100 overlap samples, or a camera or sensor render() rejects.
StitchScans make_stitch_scans(const StitchScanSettings& settings = {});

}  // namespace align3d::synth
