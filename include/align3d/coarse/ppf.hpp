// Point pair features (Drost et al. 2010, "Model globally, match locally") for model-to-scene
// matching (coarse/global.hpp describes the contract).
//
// For two oriented points (p1, n1), (p2, n2) with d = p2 − p1 the feature is
//   F = (‖d‖, ∠(n1, d), ∠(n2, d), ∠(n1, n2)),
// quantised with the voxel as distance step and 12° angle steps (30 bins). The model description is
// a table from quantised F to every model pair (m_r, m_i) having it, stored as the reference point
// r and the angle α_m that turns m_i about n_r into a fixed half-plane once (m_r, n_r) is moved to
// the origin and the x axis (Drost, section 3.3). Each scene reference point s_r votes over (model
// reference point, α = α_m − α_s); a peak gives the pose
//   T_model_scene = T_m⁻¹ · R_x(α_s − α_m) · T_s       (T_m, T_s: the moves of m_r, s_r onto x).
// Every 5th scene point is a reference; its 3 best cells are pose candidates. Candidates are
// clustered (rotation < 12°, moved scene centroid < 2 voxels; Drost, section 3.5), the 10 clusters
// with most votes are refined by point-to-point ICP (icp/icp.hpp) on the downsampled clouds, and
// the winner is the one that lays most of the model onto the scene's surface (surface_fit,
// global.hpp: within 1.5 voxels, 0.25 voxel of the tangent plane, normals within 20°), counted on
// the model's side: a pose that lays one face of the model on a wide floor lays many scene points
// onto the model but few of the model's. Ambiguity compares the same fit: a distinct refined pose
// (coarse/global.hpp) with fit >= ambiguity_ratio × the winner's sets `ambiguous`, and `score` /
// `second_score` report those two fits. `overlap` (the winner's fit) and `success` follow the
// contract (>= min_overlap).
//
// Normal orientation: the angles depend on the normals' signs, so model and scene normals must be
// oriented by the same rule, one that turns with the data: away from the cloud's centroid. Parts of
// the surface whose side relative to the centroid differs between model and (partial) scene give
// no votes, which costs support but not correctness.
//
// Stop features: a feature shared by very many model pairs (chiefly two points on one plane) tells
// almost nothing about the pose and would dominate the voting time; such buckets are dropped when
// the model is built (more than kMaxBucketFactor × the mean bucket size, see ppf.cpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "align3d/coarse/global.hpp"
#include "align3d/symmetry.hpp"

namespace align3d {

// The hashed model description: what build_ppf_model computes and save/load_ppf_model store.
struct PpfModel {
  double voxel = 0;     // downsampling voxel = distance quantisation step (data units)
  double diameter = 0;  // largest pair distance (the bounding-box diagonal of `points`)
  std::uint32_t angle_bins = 30;
  // The normals' sign: away from the centroid (ppf_register's rule, the header's), or outward
  // from the part's material (built from a mesh or a cloud with such normals: `align3d find`).
  bool outward = false;
  PointCloud points;  // downsampled model with unit normals, signed as `outward` says
  // The table in compressed-row form: keys sorted and unique; the pairs with feature keys[k] are
  // entries [offsets[k], offsets[k + 1]) of `refs` (model reference point) and `alphas` (α_m,
  // radians in [−π, π]). Entries of one key are ordered by (reference point, paired point).
  std::vector<std::uint64_t> keys;
  std::vector<std::uint32_t> offsets;
  std::vector<std::uint32_t> refs;
  std::vector<float> alphas;
};

// The voxel build_ppf_model(model, voxel, …) downsamples `model` with: `voxel` (> 0), enlarged
// until at most 1500 voxel centroids remain. std::invalid_argument for a voxel not positive.
double ppf_model_voxel(const PointCloud& model, double voxel);

// Downsamples `model` with `voxel` (> 0; enlarged until at most 1500 points remain, so the table
// holds at most ~2.25 M pairs; PpfModel::voxel is the size used), estimates normals and builds the
// table. Throws DataError("model", …) with fewer than 10 points after downsampling or all points
// on a line; std::invalid_argument for a voxel that is not positive.
// With `outward`, the PCA normals take the sign of the model's own normals (averaged per voxel;
// std::invalid_argument when it has none).
PpfModel build_ppf_model(const PointCloud& model, double voxel, int threads = 0,
                         bool outward = false);

// Binary file, little-endian throughout (version 1; version 2 has the same layout and marks a
// model with outward normals):
//   magic "A3DPPF\r\n" (8 bytes), u32 version = 1 or 2, u32 angle_bins, f64 voxel, f64 diameter,
//   u64 point count P, u64 key count K, u64 entry count E               (header: 56 bytes)
//   P × (3 f64 position, 3 f64 normal), K × u64 key, (K + 1) × u32 offset, E × (u32 ref, f32 α).
// The writer goes through io::write_atomically (OutputError on failure). The loader checks the
// header's counts against the file size before allocating, then every offset, reference and
// value; any mismatch throws IoError naming the file and the byte offset.
void save_ppf_model(const std::filesystem::path& path, const PpfModel& model);
PpfModel load_ppf_model(const std::filesystem::path& path);

// Matches `scene` against the model: the result's T_target_source maps the scene into the model's
// frame (model ≈ T·scene). The model's voxel is used for the scene (settings.voxel is not: the
// model was built with it; result.voxel reports it); score = the winner's fit, votes = its pose
// cluster's votes, candidates = clusters verified. Same result, bit for bit, whatever
// settings.threads. Throws DataError("scene", …) when the downsampled scene has fewer than 10
// points or lies on a line.
GlobalResult ppf_match(const PpfModel& model, const PointCloud& scene,
                       const GlobalSettings& settings);

// build_ppf_model(object, global_voxel(source, target, settings)) then ppf_match(model, other
// cloud), where the object is the cloud of smaller robust extent (global.hpp), whichever role it
// has; the result maps source into target either way. A voxel enlarged by the model's cap is
// noted in `message`. DataError names the role ("source"/"target") of the cloud at fault.
GlobalResult ppf_register(const PointCloud& source, const PointCloud& target,
                          const GlobalSettings& settings, const GlobalContext& context = {});

// ---- Many instances in one scene (`align3d find`, find.hpp) ----
//
// The model must have outward normals and the scene's normals point toward the camera: the sides
// a camera sees of a part are those whose outward normals face it. The voting adds what Vidal et
// al. (2018) found to matter: each scene pair also looks up the neighbouring feature bins of
// every dimension whose value lies within a quarter bin of the edge (noise moves features across
// bin edges), and one scene pair votes at most once for any (model reference, α bin) cell
// (Hinterstoisser et al. 2016). Every kSceneReferenceStep-th scene point is a reference, paired
// with every second scene point within the model's diameter; its 3 highest cells become poses, the
// poses are clustered (12°, 2 voxels; for a symmetric part after turning each to its canonical
// form, symmetry.hpp, so the votes for one instance are not spread over its equivalent poses) and
// the clusters with the most votes returned, at most `max_hypotheses`, most votes first. With
// `max_per_place` > 0 a cluster is skipped when that many stronger ones already put the model's
// centroid within a quarter of its diameter of the place where the first of them put it: a
// well-seen part draws dozens of clusters (its faces matched at wrong turns), and without a cap
// they fill the list before a less-seen part gets one. Same result whatever the thread count.

// Voxel centroids of the scene with PCA normals (as the model's) turned toward `viewpoint`.
// Throws DataError("scene", …) with fewer than 10 points after downsampling or all on a line.
PointCloud ppf_scene(const PointCloud& scene, double voxel, const Eigen::Vector3d& viewpoint,
                     int threads = 0);

struct PpfHypothesis {
  Eigen::Isometry3d T_scene_model;  // scene ≈ T·model
  double votes = 0;                 // of its pose cluster
};

// std::invalid_argument for a model without outward normals or inconsistent.
std::vector<PpfHypothesis> ppf_hypotheses(const PpfModel& model, const PointCloud& scene,
                                          const Symmetry& symmetry, std::size_t max_hypotheses,
                                          int threads = 0, std::size_t max_per_place = 0);

}  // namespace align3d
