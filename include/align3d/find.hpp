// Finding every instance of a part in a depth-camera scene (README, "Pick parts from a bin"): the
// bin-picking engine behind `align3d find`.
//
//   1. The model: points sampled evenly by area on the part's mesh (or a cloud) with outward
//      normals, downsampled with a voxel of `voxel_fraction` × the model's diameter, and the point
//      pair feature table built from them (coarse/ppf.hpp, PpfModel; prepared once, reusable from
//      `align3d ppf-model`). Its symmetry is detected from those points (symmetry.hpp) or given.
//   2. The scene, in the camera's frame (its viewpoint): points outside the depth range are
//      dropped, and the dominant plane removed for voting (not for verification), again while
//      one holds a fifth of what is left (a camera above a bin sees the ground and the bin's
//      floor) and spans more than 1.5 model diameters (a plane of the part's size may be its own
//      face). The rest is downsampled with the model's voxel; normals are turned toward the
//      camera, the side from which the outward normals of the visible model surface point too.
//   3. Hypotheses: PPF voting (coarse/ppf.hpp, ppf_hypotheses) with neighbour-bin lookups, one
//      vote per model-scene pair and several peaks per scene reference point, clustered poses:
//      the 400 strongest clusters, at most 8 of them in one place (a quarter of the diameter), so
//      a well-seen part's many wrongly turned clusters do not crowd out a less-seen part's. Each
//      is refined by ICP onto the model (icp/icp.hpp) of the scene points on its surface (near a
//      model point whose normal agrees with theirs; a touching neighbour does not pull it).
//   4. Verification against the depth image (range_image.hpp): the model points the camera would
//      see at the pose (facing it, not hidden behind the part itself) are compared with the scene
//      at their pixels. Explained: a scene point within a distance (0.75 voxel, or 2 σ of the
//      depth noise measured from the image at the part's depth, RangeImage::depth_sigma, where
//      that is more); seen through: the scene lies farther (1.5 voxel or 4 σ), so the
//      hypothesised part would hide it (free-space violation), or a removed
//      plane (the floor) lies in front, or the surface one of its own flat faces lies on (a side
//      fitted into the bin's wall), so the part would be inside it; occluded: something else lies
//      in front (a scene point on the part's own surface at the pose means the part hides that
//      point itself: not counted as visible), or the point lies beyond the image's border or
//      outside the sensor's field (RangeImage::in_field: a depth camera's blind border band);
//      missing: no return. Outline continuation: the share of the ring just outside the part's
//      outline where the scene surface goes on without a depth edge (a face fitted into a box's
//      top, the floor or a wall). Explained needs the scene's normal there within 45° of the
//      model's, and the outline counts only where the part is explained (a neighbour lying on it is
//      no evidence). score = (explained − seen through) / (visible − missing − occluded) −
//      continuation: what a part partly under its neighbours shows is judged as a whole part's;
//      visible_fraction = 1 − occluded / (visible − missing). A pose scores −1 when it is less than
//      40 % visible, when it turns a partial model's unscanned side to the camera (ModelSide),
//      when most of the scene points it explains lie on a removed plane (matched into the floor,
//      a table or a wall), or when the scene points one of its faces explains (grouped by the
//      model normal, within 20°; a face holding a quarter of the explained points) lie on one
//      plane (RMS below a third of the explain distance) that, grown through the depth image,
//      covers more than half as many pixels outside the part's outline as inside: a face of the
//      part matched into a larger surface (a plate into the bin's wall, where the outline ring
//      falls on the floor and cannot tell; face by face, so that an L fitted into two surfaces is
//      tested too).
//   5. Non-maximum suppression, best score first: each accepted instance claims the scene pixels
//      of its surface; a later hypothesis is scored again on its explained pixels still free and
//      dropped below min_score. So one part is reported once, whatever its symmetry. Each
//      accepted pose gets a last ICP on its scene points and is scored again there (on at most
//      the explained points it had); one that falls below min_score is dropped (so fewer than
//      max_instances may be reported when the limit was reached). Poses of a symmetric part are
//      reported in a canonical form (symmetry.hpp).
//
// Units: every distance default is a share of the model's diameter (or of the measured depth
// noise, in the scene's units), so the same data in mm or m
// give the same instances. The same inputs and settings give the same result at any thread count.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "align3d/coarse/ppf.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/mesh.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/range_image.hpp"
#include "align3d/symmetry.hpp"
#include "align3d/warning.hpp"

namespace align3d {

// Defaults, declared once (CLI, Python and docs read them from here).
// Model voxel / model diameter. HALCON's surface matching samples at 3 %; on the development scenes
// of bench/compare_find.py 4 % found 0.977 of the instances where 5 % found 0.941 (the box-like
// bracket: a face's few points at 5 % voted for its look-alike faces), at 1.3× the time.
inline constexpr double kFindVoxelFraction = 0.04;
inline constexpr double kFindMinScore = 0.6;
inline constexpr double kFindMinVisible = 0.4;           // a pose less visible scores −1 (step 4)
inline constexpr std::size_t kFindModelSamples = 20000;  // area-uniform samples of a mesh model

struct FindSettings {
  int max_instances = 0;  // 0: every instance that verifies
  double min_score = kFindMinScore;
  // Symmetry of the part: detected from the model (auto) or declared (symmetry.hpp).
  bool detect_symmetry = true;
  Symmetry symmetry;         // used when detect_symmetry is false
  bool remove_plane = true;  // the dominant plane of the scene (the bin floor) takes no votes
  // Scene points with depth (z in the camera frame) outside [min_depth, max_depth] are dropped.
  double min_depth = 0;
  double max_depth = std::numeric_limits<double>::infinity();
  std::uint64_t seed = 1;  // the floor's RANSAC
  int threads = 0;         // 0: all cores; the result does not depend on it
  // The ICP cost and kernel of each instance's final refinement (step 6; the hypotheses of step 3
  // are refined point-to-plane). Unset kernel: none (the pairs are within the explain distance
  // already); a kernel with scale 0: its tuning constant × σ̂ of each iteration (icp/solver.hpp).
  CostSettings cost;
};

// The scene as read: the points, and where they came from.
struct FindScene {
  PointCloud cloud;
  // An organized cloud (a depth camera's image): its width and height, and each point's pixel
  // index (v·width + u) in `pixels`; 0 × 0 and no pixels for an unorganized cloud.
  std::size_t width = 0, height = 0;
  std::vector<std::uint32_t> pixels;
  // The camera's pose in the cloud's frame (a PCD's VIEWPOINT; the identity otherwise): the
  // camera frame's z axis is the viewing direction.
  Eigen::Isometry3d T_cloud_camera = Eigen::Isometry3d::Identity();
};

// An organized scene from a depth camera's image: `image` holds width × height points row-major
// (NaN or Inf where the camera returned nothing), in the frame where the camera sits at
// T_cloud_camera. std::invalid_argument when the sizes disagree.
FindScene organized_scene(const std::vector<Eigen::Vector3d>& image, std::size_t width,
                          std::size_t height,
                          const Eigen::Isometry3d& T_cloud_camera = Eigen::Isometry3d::Identity());

// The scene of a point cloud file (io/point_cloud_io.hpp): a PCD with HEIGHT > 1 is organized, its
// VIEWPOINT the camera; any other cloud is unorganized, seen from the origin. Throws what
// read_point_cloud throws (IoError naming the file).
FindScene read_find_scene(const std::filesystem::path& path);

// Whether a model is one side of its part (partial: a teach-in scan, cloud or mesh) or its whole
// surface. Its sensor is placed where a one-sided scan's would be (estimated_viewpoint,
// normals.hpp); of the model's points whose surface does not graze that sensor's line of sight,
// the model is partial when at most kFindMaxHiddenShare lie more than 3 point spacings behind
// another of its points in their direction and at most that share have normals facing away from
// it (a closed part hides its far side, about half, or, a thin plate, faces away from the sensor
// with half its outward normals). `seen_from`: the unit direction from the model's centroid
// toward that sensor, in the model's frame.
inline constexpr double kFindMaxHiddenShare = 0.2;
// A partial model is verified only at poses that show its scanned side to the camera: `seen_from`
// within this angle of the direction from the part to the camera (beyond it the camera would see
// the side no scan recorded, where nothing can be confirmed or contradicted).
inline constexpr double kFindMaxUnseenDeg = 60;
struct ModelSide {
  bool partial = false;
  Eigen::Vector3d seen_from = Eigen::Vector3d::Zero();
  double hidden_share = 0;  // of the model's points, seen from the estimated sensor
};
// `model`: points with outward normals (a model of build_find_model); not partial without them.
ModelSide model_side(const PointCloud& model);

struct FoundInstance {
  Eigen::Isometry3d T_scene_model;  // maps MODEL coordinates into the SCENE's frame
  double score = 0;
  double visible_fraction = 0;
  double rms = 0;                     // of the last ICP's pairs (its scene points to the model)
  std::size_t explained = 0;          // scene points it explains
  std::vector<std::uint32_t> points;  // those points (indices into FindScene::cloud), ascending
};

struct FindResult {
  std::vector<FoundInstance> instances;  // best score first
  Symmetry symmetry;                     // of the model, as used
  ModelSide model_side;                  // whether the model is a partial scan
  double model_diameter = 0, voxel = 0;  // voxel: the model's (= the scene's downsampling)
  std::size_t model_points = 0;          // in the feature table
  // The scene: its camera (estimated from an organized cloud, or made up for an unorganized one),
  // points dropped by the depth range, removed as the plane, and the downsampled voting cloud.
  RangeImage image;
  std::size_t depth_dropped = 0, plane_points = 0, voting_points = 0;
  std::size_t hypotheses = 0;  // pose clusters refined and verified
  double prepare_ms = 0, vote_ms = 0, refine_ms = 0, verify_ms = 0, total_ms = 0;
  std::vector<Warning> warnings;
};

// The model description find() needs, built from a mesh (sampled evenly by area, face normals) or
// from a cloud (its normals if it has them; else PCA normals, k = 20, turned toward the sensor of
// a partial model (model_side) and away from the centroid of a whole one). Throws
// DataError("model", …) for a model too small or degenerate to sample.
PpfModel build_find_model(const TriangleMesh& mesh, double voxel_fraction = kFindVoxelFraction,
                          int threads = 0);
PpfModel build_find_model(const PointCloud& model, double voxel_fraction = kFindVoxelFraction,
                          int threads = 0);

// Every instance of the model in the scene. Throws std::invalid_argument for unusable settings,
// DataError("scene", …) for a scene that holds no usable points, and DataError("model", …) when
// the model is larger than everything the scene shows.
FindResult find(const PpfModel& model, const FindScene& scene, const FindSettings& settings = {});

}  // namespace align3d
