#include "align3d/find.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include "align3d/error.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/plane/plane.hpp"
#include "align3d/voxel.hpp"
#include "detail/number.hpp"
#include "detail/parallel.hpp"
#include "detail/timing.hpp"

namespace align3d {
namespace {

using detail::Clock;
using detail::ms_since;

// Every distance below is a multiple of the model's voxel (a share of its diameter).
constexpr std::size_t kMaxHypotheses = 400;
constexpr std::size_t kHypothesesPerPlace = 8;  // ppf_hypotheses' max_per_place
constexpr double kPlaneShare = 0.2;             // a plane with this share of the scene is the floor
constexpr int kMaxPlanes = 3;         // planes removed at most (ground, bin floor, a table)
constexpr double kPlaneVoxels = 0.5;  // RANSAC's inlier distance for the floor
// A plane is a floor, a table or a wall only if its inliers span more than this many model
// diameters: one of about the part's size may be the part's own face (a box's side seen square
// on, which a Kinect frame's second plane was), and removing it takes the part out of the voting.
constexpr double kPlaneDiameters = 1.5;
constexpr std::size_t kPlaneScorePoints = 2000;  // RANSAC counts its candidates on these
constexpr double kExplainVoxels = 0.75;          // a scene point this near explains a model point
constexpr double kFreeSpaceVoxels = 1.5;  // scene this far behind a model point: seen through it
// Or, where the sensor's noise at the part's depth is larger (RangeImage::depth_sigma), this many
// of its σ.
constexpr double kExplainSigmas = 2, kFreeSpaceSigmas = 4;
constexpr double kRefineNormalDeg = 45;  // scene and model normals of a refined pair
constexpr double kVerifyNormalDeg = 45;  // scene and model normals of an explained point
constexpr double kMinFacing = 0.26;      // cos 75°: steeper surfaces return nothing (sensors)
constexpr double kSymmetryVoxels = 0.1;  // mean misfit of a turn that counts as a symmetry
// The disc each model point covers in its view: wide enough to close the gaps between the points
// (a voxel apart) so the outline is the part's, not each point's.
constexpr double kSplatVoxels = 0.75;
constexpr double kMinExplainedShare = 0.1;  // of the visible model points, and at least:
constexpr std::size_t kMinExplained = 10;
constexpr double kMinSceneShare = 0.5;  // scene extent / model diameter below this: an error
// surface_overhang: explained points this flat (RMS off their plane, in explain distances) are
// one face; its plane reaching this share of the footprint's pixels outside it: a larger surface.
constexpr double kFlatExplains = 1.0 / 3;
constexpr double kOverhangShare = 0.5;
constexpr double kFaceDeg = 20;      // any_face_overhangs: normals of one face
constexpr double kFaceShare = 0.25;  // of the explained points: a face worth testing

// The explain distance at a depth: kExplainVoxels voxels, or kExplainSigmas σ of the depth noise
// there where that is more.
double explain_distance(double voxel, const RangeImage& image, double depth) {
  return std::max(kExplainVoxels * voxel, kExplainSigmas * image.depth_sigma(depth));
}

void check_settings(const FindSettings& s) {
  if (s.max_instances < 0) throw std::invalid_argument("find: max_instances must be >= 0");
  if (!(s.min_score > 0 && s.min_score <= 1))
    throw std::invalid_argument("find: min_score must be in (0, 1], got " +
                                detail::number(s.min_score, 4));
  if (!(s.min_depth >= 0) || !(s.max_depth > s.min_depth))
    throw std::invalid_argument("find: the depth range must satisfy 0 <= min < max, got " +
                                detail::number(s.min_depth, 4) + " to " +
                                detail::number(s.max_depth, 4));
  if (s.threads < 0) throw std::invalid_argument("find: threads must be >= 0 (0: all cores)");
}

// The scene in its camera's frame: every point (scene order), whether it is in the depth range,
// and the downsampled voting cloud (in range, off the floor) with normals toward the camera.
struct Prepared {
  RangeImage image;
  std::vector<Eigen::Vector3d> points;
  std::vector<char> in_range;
  std::vector<char> on_plane;  // removed with the floor for voting (verification sees it)
  PointCloud voting;
  std::unique_ptr<KdTree> voting_tree;
  std::size_t depth_dropped = 0, plane_points = 0;
};

// Removes the dominant plane from `kept` (indices into prep.points) and from `sample` (their
// downsampling, which RANSAC searches) when it holds kPlaneShare of the sample and spans more than
// kPlaneDiameters model diameters.
bool remove_floor(Prepared& prep, std::vector<std::size_t>& kept, PointCloud& sample, double voxel,
                  double diameter, std::uint64_t seed) {
  RansacPlaneSettings rs;
  rs.threshold = kPlaneVoxels * voxel;
  rs.seed = seed;
  rs.score_points = kPlaneScorePoints;
  RansacPlaneResult plane;
  try {
    plane = ransac_plane(sample.positions, rs);
  } catch (const DataError&) {
    return false;  // no plane at all: nothing to remove
  }
  if (static_cast<double>(plane.inliers.size()) < kPlaneShare * static_cast<double>(sample.size()))
    return false;
  Eigen::AlignedBox3d span;
  for (std::size_t i : plane.inliers) span.extend(sample.positions[i]);
  if (span.diagonal().norm() <= kPlaneDiameters * diameter) return false;
  // The band removed: 3 σ of the raw points near the plane (a depth camera's noise is larger
  // than the downsampled sample's), at least RANSAC's distance.
  double sq_sum = 0;
  std::size_t near = 0;
  for (std::size_t i : kept) {
    const double d = plane.plane.signed_distance(prep.points[i]);
    if (std::abs(d) <= voxel) sq_sum += d * d, ++near;
  }
  const double band =
      std::max(kPlaneVoxels * voxel,
               3 * std::sqrt(sq_sum / static_cast<double>(std::max<std::size_t>(near, 1))));
  std::erase_if(kept, [&](std::size_t i) {
    const bool on = std::abs(plane.plane.signed_distance(prep.points[i])) <= band;
    prep.plane_points += on ? 1 : 0;
    prep.on_plane[i] = on ? 1 : 0;
    return on;
  });
  std::erase_if(sample.positions, [&](const Eigen::Vector3d& p) {
    return std::abs(plane.plane.signed_distance(p)) <= band;
  });
  return true;
}

Prepared prepare_scene(const FindScene& scene, const PpfModel& model, const FindSettings& s) {
  if (scene.cloud.empty()) throw DataError("scene", "holds no points");
  Prepared prep;
  const bool organized = scene.width > 0 && scene.height > 0 && !scene.pixels.empty();
  prep.image = organized
                   ? organized_range_image(scene.cloud, scene.pixels, static_cast<int>(scene.width),
                                           static_cast<int>(scene.height), scene.T_cloud_camera)
                   : projected_range_image(scene.cloud, scene.T_cloud_camera);
  const Eigen::Isometry3d T_camera_cloud = prep.image.T_cloud_camera.inverse();
  prep.points.resize(scene.cloud.size());
  prep.in_range.resize(scene.cloud.size());
  prep.on_plane.assign(scene.cloud.size(), 0);
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < scene.cloud.size(); ++i) {
    prep.points[i] = T_camera_cloud * scene.cloud.positions[i];
    const double z = prep.points[i].z();
    prep.in_range[i] = z > 0 && z >= s.min_depth && z <= s.max_depth;
    if (prep.in_range[i]) kept.push_back(i);
  }
  prep.depth_dropped = scene.cloud.size() - kept.size();
  if (kept.size() < 10)
    throw DataError("scene", std::to_string(kept.size()) +
                                 " points in front of the camera within the depth range");
  Eigen::AlignedBox3d box;
  for (std::size_t i : kept) box.extend(prep.points[i]);
  if (box.diagonal().norm() < kMinSceneShare * model.diameter)
    throw DataError("model", "its diameter (" + detail::number(model.diameter, 4) +
                                 ") is larger than the whole scene (extent " +
                                 detail::number(box.diagonal().norm(), 4) +
                                 "): a model in other units than the scene, or the files swapped?");
  // The dominant plane, and again while one holds kPlaneShare of what is left: a camera above a
  // bin sees the ground around it and the bin's floor, 12 mm apart.
  if (s.remove_plane) {
    PointCloud sample;
    for (std::size_t i : kept) sample.positions.push_back(prep.points[i]);
    sample = voxel_downsample(sample, model.voxel / 2);
    for (int round = 0; round < kMaxPlanes; ++round)
      if (!remove_floor(prep, kept, sample, model.voxel, model.diameter, s.seed)) break;
  }
  PointCloud rest;
  rest.positions.reserve(kept.size());
  for (std::size_t i : kept) rest.positions.push_back(prep.points[i]);
  try {
    prep.voting = ppf_scene(rest, model.voxel, Eigen::Vector3d::Zero(), s.threads);
  } catch (const DataError&) {
    // Too little left off the floor to vote: no instance (an empty bin).
  }
  prep.voting_tree = std::make_unique<KdTree>(prep.voting.positions, s.threads);
  return prep;
}

// What the depth image says about a hypothesis (find.hpp, step 4), counted over the model points
// the camera would see.
struct Evidence {
  std::size_t visible = 0, explained = 0, seen_through = 0, occluded = 0, missing = 0;
  std::vector<std::uint32_t> pixels;  // where the explained points were matched
  double continuation = 0;            // outline_continuation
  bool larger_surface = false;        // any_face_overhangs
  bool unseen_side = false;           // a partial model showing its unscanned side (verify)
  double score(std::size_t explained_free) const {
    const double seen = std::max<double>(1, static_cast<double>(visible - missing - occluded));
    if (unseen_side || visible_fraction() < kFindMinVisible || larger_surface) return -1;
    return (static_cast<double>(explained_free) - static_cast<double>(seen_through)) / seen -
           continuation;
  }
  double visible_fraction() const {
    const double usable = std::max<double>(1, static_cast<double>(visible - missing));
    return (usable - static_cast<double>(occluded)) / usable;
  }
};

// The model as the camera would see it at a pose: its projection's box (lo, size), per pixel the
// nearest model point (−1: none) splatted over a disc of half a voxel, and the model points it
// sees (facing the camera and in front in that z-buffer) with their pixels.
struct ModelView {
  Eigen::Vector2i lo, size;
  std::vector<float> z;
  std::vector<std::int32_t> owner;
  std::vector<std::size_t> visible;
  std::size_t outside = 0;          // points facing the camera beyond the image's border
  std::vector<Eigen::Vector2i> uv;  // per model point; meaningful for those projected
  std::size_t at(int u, int v) const {
    return static_cast<std::size_t>(v - lo.y()) * size.x() + (u - lo.x());
  }
  bool inside(int u, int v) const {
    return u >= lo.x() && v >= lo.y() && u < lo.x() + size.x() && v < lo.y() + size.y();
  }
};

ModelView view_model(const std::vector<Eigen::Vector3d>& p, const std::vector<Eigen::Vector3d>& n,
                     const RangeImage& image, double voxel, int margin) {
  ModelView view;
  view.uv.assign(p.size(), Eigen::Vector2i(-1, -1));
  Eigen::AlignedBox2i box;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (!(p[i].z() > 0) || n[i].dot(-p[i].normalized()) < kMinFacing) continue;
    const Eigen::Vector2d q = image.project(p[i]);
    const long u = std::lround(q.x()), v = std::lround(q.y());
    if (u < 0 || v < 0 || u >= image.width || v >= image.height ||
        !image.in_field(static_cast<int>(u), static_cast<int>(v))) {
      ++view.outside;
      continue;
    }
    view.uv[i] = Eigen::Vector2i(static_cast<int>(u), static_cast<int>(v));
    box.extend(view.uv[i]);
    view.visible.push_back(i);
  }
  if (view.visible.empty()) return view;
  // Room for the widest disc (of the nearest point) and the ring of `margin` pixels around it.
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i : view.visible) nearest = std::min(nearest, p[i].z());
  const int room = static_cast<int>(std::ceil(kSplatVoxels * voxel * image.fx / nearest)) + margin;
  view.lo = box.min() - Eigen::Vector2i::Constant(room);
  view.size = box.sizes() + Eigen::Vector2i::Constant(2 * room + 1);
  // Two splats: discs of half a voxel for the z-buffer (a point behind another surface of the
  // part by more than a voxel is hidden; on one face, tilted up to 60°, nothing hides), and of
  // kSplatVoxels for the owners, which close the outline.
  view.z.assign(static_cast<std::size_t>(view.size.x()) * view.size.y(),
                std::numeric_limits<float>::infinity());
  std::vector<float> owner_z = view.z;
  view.owner.assign(view.z.size(), -1);
  const auto splat = [&](std::size_t i, int r, std::vector<float>& z, bool own) {
    for (int dv = -r; dv <= r; ++dv)
      for (int du = -r; du <= r; ++du) {
        const int u = view.uv[i].x() + du, v = view.uv[i].y() + dv;
        if (!view.inside(u, v) || !(p[i].z() < z[view.at(u, v)])) continue;
        z[view.at(u, v)] = static_cast<float>(p[i].z());
        if (own) view.owner[view.at(u, v)] = static_cast<std::int32_t>(i);
      }
  };
  for (std::size_t i : view.visible) {
    const double pixels_per_voxel = voxel * image.fx / p[i].z();
    splat(i, static_cast<int>(0.5 * pixels_per_voxel), view.z, false);
    splat(i, static_cast<int>(std::ceil(kSplatVoxels * pixels_per_voxel)), owner_z, true);
  }
  std::erase_if(view.visible, [&](std::size_t i) {
    return p[i].z() > view.z[view.at(view.uv[i].x(), view.uv[i].y())] + voxel;
  });
  return view;
}

// Whether scene point b continues the surface through scene point a: no step in depth larger than
// `explain`, or (a slanted surface, a wall seen at a grazing angle) b within half that of the
// tangent plane of the voting point nearest a.
bool continues(const Prepared& prep, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
               double explain) {
  if (std::abs(b.z() - a.z()) <= explain) return true;
  Neighbor nn;
  if (!prep.voting_tree->nearest(a, nn, 4 * explain * explain)) return false;
  return std::abs(prep.voting.normals[nn.index].dot(b - a)) <= explain / 2;
}

// The share of the scene just outside the model's outline (a ring `margin` pixels wide) that
// continues, without a depth edge (a step of more than `explain`), the scene surface at the
// nearest outline point's pixel: a real part ends at its outline, a face matched into a larger
// surface (a box's top, the floor) does not.
double outline_continuation(ModelView& view, const std::vector<Eigen::Vector3d>& p,
                            const Prepared& prep, double explain, int margin) {
  const RangeImage& image = prep.image;
  std::size_t valid = 0, continuing = 0;
  std::vector<std::int32_t> next;
  for (int step = 0; step < margin; ++step) {  // grow the owners outward one pixel per step
    next = view.owner;
    for (int v = view.lo.y(); v < view.lo.y() + view.size.y(); ++v)
      for (int u = view.lo.x(); u < view.lo.x() + view.size.x(); ++u) {
        if (view.owner[view.at(u, v)] >= 0) continue;
        for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}})
          if (view.inside(u + du, v + dv) && view.owner[view.at(u + du, v + dv)] >= 0) {
            next[view.at(u, v)] = view.owner[view.at(u + du, v + dv)];
            if (u < 0 || v < 0 || u >= image.width || v >= image.height) break;
            const std::int32_t q = image.point[image.pixel(u, v)];
            if (q < 0 || !prep.in_range[static_cast<std::size_t>(q)]) break;
            // The scene at the owner's own pixel: is there a depth edge between the two?
            const auto m = static_cast<std::size_t>(next[view.at(u, v)]);
            const std::int32_t o = image.point[image.pixel(view.uv[m].x(), view.uv[m].y())];
            if (o < 0 || !prep.in_range[static_cast<std::size_t>(o)]) break;
            // An owner the scene does not explain (occluded by a neighbour): no evidence here.
            if ((prep.points[static_cast<std::size_t>(o)] - p[m]).norm() > explain) break;
            ++valid;
            continuing += continues(prep, prep.points[static_cast<std::size_t>(o)],
                                    prep.points[static_cast<std::size_t>(q)], explain)
                              ? 1
                              : 0;
            break;
          }
      }
    view.owner.swap(next);
  }
  return valid ? static_cast<double>(continuing) / static_cast<double>(valid) : 0.0;
}

// Whether x (model frame) lies on the model's surface: within 2 × explain of a model point and
// within explain / 2 of its tangent plane.
bool on_surface(const PpfModel& model, const KdTree& model_tree, const Eigen::Vector3d& x,
                double explain) {
  Neighbor nn;
  if (!model_tree.nearest(x, nn, 4 * explain * explain)) return false;
  const Eigen::Vector3d off = x - model.points.positions[nn.index];
  return std::abs(model.points.normals[nn.index].dot(off)) <= explain / 2;
}

// Whether the scene's surface at scene point s faces as the model's normal n does (within
// max_deg; the normal of the voting point nearest s, within a voxel). A surface passing
// near the model at another angle (a neighbour's side, a box under a face) explains nothing.
bool agrees(const Prepared& prep, const Eigen::Vector3d& s, const Eigen::Vector3d& n, double voxel,
            double max_deg = kVerifyNormalDeg) {
  Neighbor nn;
  if (!prep.voting_tree->nearest(s, nn, voxel * voxel)) return true;
  return prep.voting.normals[nn.index].dot(n) >= std::cos(deg_to_rad(max_deg));
}

// A face of the part that the scene explains, flat: its explained pixels grouped by their model
// point's normal (within kFaceDeg of the group's first), holding kFaceShare of them, whose scene
// points lie on one plane (fit_plane; RMS below kFlatExplains × explain). One face at a time: an L
// fitted into two surfaces (the bin's inner corner) explains two planes, which a test over all
// its points would not see as one.
struct FlatFace {
  Plane plane;
  Eigen::Vector3d normal;  // the model's (outward) normal of the group's first point
  std::vector<std::uint32_t> pixels;
};

std::vector<FlatFace> flat_faces(const std::vector<Eigen::Vector3d>& n,
                                 const std::vector<std::size_t>& explained_model,
                                 const std::vector<std::uint32_t>& pixels, const Prepared& prep,
                                 double explain) {
  const double min_cos = std::cos(deg_to_rad(kFaceDeg));
  std::vector<std::pair<Eigen::Vector3d, std::vector<std::uint32_t>>> groups;
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    const Eigen::Vector3d& normal = n[explained_model[k]];
    auto group = std::find_if(groups.begin(), groups.end(),
                              [&](const auto& g) { return g.first.dot(normal) >= min_cos; });
    if (group == groups.end()) group = groups.insert(groups.end(), {normal, {}});
    group->second.push_back(pixels[k]);
  }
  std::vector<FlatFace> faces;
  for (auto& [normal, group] : groups) {
    if (static_cast<double>(group.size()) < kFaceShare * static_cast<double>(pixels.size()) ||
        group.size() < kMinExplained)
      continue;
    std::vector<std::size_t> points;
    for (std::uint32_t px : group) points.push_back(static_cast<std::size_t>(prep.image.point[px]));
    Plane plane;
    try {
      plane = fit_plane(prep.points, &points);
    } catch (const DataError&) {
      continue;  // on one spot or one line, or a volume: not a face
    }
    double sq_sum = 0;
    for (std::size_t q : points) sq_sum += std::pow(plane.signed_distance(prep.points[q]), 2);
    if (std::sqrt(sq_sum / static_cast<double>(points.size())) <= kFlatExplains * explain)
      faces.push_back({plane, normal, std::move(group)});
  }
  return faces;
}

// Whether a flat face's plane goes on well beyond the model's footprint in the image (the owners'
// pixels and their outline ring, `footprint` of them): a face of the part matched into a larger
// surface, a plate into the bin's wall beside the floor, where the outline test sees the floor.
// The plane is grown over 4-connected pixels from the face's, through scene points within
// `explain` of it and within the diameter of its centroid, not those of a removed plane (a plate
// lying on the floor is parallel to it, a plate's thickness above).
bool surface_overhang(const ModelView& view, std::size_t footprint, const FlatFace& face,
                      const Prepared& prep, double explain, double diameter) {
  const RangeImage& image = prep.image;
  const Plane& plane = face.plane;
  const std::vector<std::uint32_t>& explained_pixels = face.pixels;
  const Eigen::Vector3d& normal = plane.normal;
  const Eigen::Vector3d& mean = plane.point;
  // The flood fill's marks, per thread, cleared after use (the image is large, the fill small).
  thread_local std::vector<char> seen;
  seen.resize(image.depth.size(), 0);
  std::vector<std::uint32_t> stack(explained_pixels), touched(explained_pixels);
  for (std::uint32_t px : stack) seen[px] = 1;
  std::size_t inside = 0, outside = 0;
  // Inside cannot pass the footprint's pixel count: beyond that share outside, the answer is yes.
  const double enough = kOverhangShare * static_cast<double>(footprint);
  while (!stack.empty() && static_cast<double>(outside) <= enough) {
    const std::uint32_t px = stack.back();
    stack.pop_back();
    const int u = static_cast<int>(px % static_cast<std::uint32_t>(image.width));
    const int v = static_cast<int>(px / static_cast<std::uint32_t>(image.width));
    ++(view.inside(u, v) && view.owner[view.at(u, v)] >= 0 ? inside : outside);
    for (const auto& [du, dv] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      if (u + du < 0 || v + dv < 0 || u + du >= image.width || v + dv >= image.height) continue;
      const auto next = static_cast<std::uint32_t>(image.pixel(u + du, v + dv));
      if (seen[next]) continue;
      seen[next] = 1;
      touched.push_back(next);
      const std::int32_t q = image.point[next];
      if (q < 0 || !prep.in_range[static_cast<std::size_t>(q)] ||
          prep.on_plane[static_cast<std::size_t>(q)])
        continue;
      const Eigen::Vector3d& x = prep.points[static_cast<std::size_t>(q)];
      if (std::abs(normal.dot(x - mean)) <= explain && (x - mean).norm() <= diameter)
        stack.push_back(next);
    }
  }
  for (std::uint32_t px : touched) seen[px] = 0;
  return static_cast<double>(outside) > kOverhangShare * static_cast<double>(inside);
}

// What hides each occluded model point (`occluders`: the scene point in front of each). The part
// itself, where the points' z-buffer missed it (the scene point lies on the part's surface at the
// pose): not visible. The surface one of its own flat faces lies on (on its plane and facing as it
// does; a neighbour lying on the part meets that plane only with its sides): the part would lie
// inside that surface, as behind the floor (a side fitted into the bin's wall, the rest of the
// part behind it): seen through. Anything else stays occluded.
void reclassify_occluded(const PpfModel& model, const KdTree& model_tree, const Prepared& prep,
                         const Eigen::Isometry3d& T_model_camera,
                         const std::vector<FlatFace>& faces,
                         const std::vector<std::size_t>& occluders, double explain, Evidence& ev) {
  for (std::size_t q : occluders) {
    const Eigen::Vector3d& x = prep.points[q];
    if (on_surface(model, model_tree, T_model_camera * x, explain)) {
      --ev.occluded, --ev.visible;
    } else if (std::any_of(faces.begin(), faces.end(), [&](const FlatFace& f) {
                 return std::abs(f.plane.signed_distance(x)) <= explain &&
                        agrees(prep, x, f.normal, model.voxel, kFaceDeg);
               })) {
      --ev.occluded, ++ev.seen_through;
    }
  }
}

Evidence verify(const PpfModel& model, const KdTree& model_tree, const Prepared& prep,
                const ModelSide& side, const Eigen::Isometry3d& T_camera_model) {
  Evidence ev;
  const Eigen::Vector3d centre = T_camera_model * centroid(model.points);
  // A partial model turned so that the camera would see its unscanned side: nothing to verify.
  const Eigen::Vector3d to_camera = -centre.normalized();
  if (side.partial && (T_camera_model.linear() * side.seen_from).dot(to_camera) <
                          std::cos(kFindMaxUnseenDeg * std::numbers::pi / 180)) {
    ev.unseen_side = true;
    return ev;
  }
  const RangeImage& image = prep.image;
  const double voxel = model.voxel;
  const double depth = centre.z();
  const double explain = explain_distance(voxel, image, depth);
  const double free =
      std::max(kFreeSpaceVoxels * voxel, kFreeSpaceSigmas * image.depth_sigma(depth));
  std::vector<Eigen::Vector3d> p(model.points.size()), n(model.points.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    p[i] = T_camera_model * model.points.positions[i];
    n[i] = T_camera_model.linear() * model.points.normals[i];
  }
  // The outline ring: half a voxel in pixels at the model's depth, at least 2.
  const int margin =
      depth > 0 ? std::max(2, static_cast<int>(std::lround(0.5 * voxel * image.fx / depth))) : 2;
  ModelView view = view_model(p, n, image, voxel, margin);
  const std::vector<Eigen::Vector2i>& uv = view.uv;
  std::vector<std::size_t> explained_model, occluders;  // occluders: the scene points in front
  for (std::size_t i : view.visible) {
    ++ev.visible;
    double best = std::numeric_limits<double>::infinity(), nearest_z = best;
    bool nearest_on_plane = false;
    std::size_t best_pixel = 0, nearest = 0;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du) {
        const int u = uv[i].x() + du, v = uv[i].y() + dv;
        if (u < 0 || v < 0 || u >= image.width || v >= image.height) continue;
        const std::size_t at = image.pixel(u, v);
        const std::int32_t q = image.point[at];
        if (q < 0 || !prep.in_range[static_cast<std::size_t>(q)]) continue;
        const Eigen::Vector3d& s = prep.points[static_cast<std::size_t>(q)];
        if (s.z() < nearest_z) {
          nearest_z = s.z(), nearest = static_cast<std::size_t>(q);
          nearest_on_plane = prep.on_plane[nearest] != 0;
        }
        const double d = (s - p[i]).norm();
        if (d < best) best = d, best_pixel = at;
      }
    if (best <= explain &&
        agrees(prep, prep.points[static_cast<std::size_t>(image.point[best_pixel])], n[i], voxel)) {
      ++ev.explained;
      ev.pixels.push_back(static_cast<std::uint32_t>(best_pixel));
      explained_model.push_back(i);
    } else if (!std::isfinite(nearest_z)) {
      ++ev.missing;
    } else if (nearest_z > p[i].z() + free ||
               (nearest_z < p[i].z() - explain && nearest_on_plane)) {
      // Seen through, or hidden by the floor: the part would lie inside it.
      ++ev.seen_through;
    } else if (nearest_z < p[i].z() - explain) {
      ++ev.occluded;
      occluders.push_back(nearest);
    }
  }
  // Beyond the image's border the camera sees nothing of the part: hidden from it, as by an
  // occluder (a pose mostly outside the image is too little visible to verify: a face matched into
  // a wall that leaves the image, whose outline there cannot be checked).
  ev.visible += view.outside;
  ev.occluded += view.outside;
  // The outline's depth edges are the part's geometry: a step of the voxel-based distance, not
  // widened by the noise (a thin part's edge would pass for a continuing surface).
  if (!view.visible.empty())
    ev.continuation = outline_continuation(view, p, prep, kExplainVoxels * voxel, margin);
  const std::vector<FlatFace> faces = flat_faces(n, explained_model, ev.pixels, prep, explain);
  const auto footprint = static_cast<std::size_t>(
      std::count_if(view.owner.begin(), view.owner.end(), [](std::int32_t o) { return o >= 0; }));
  ev.larger_surface = std::any_of(faces.begin(), faces.end(), [&](const FlatFace& f) {
    return surface_overhang(view, footprint, f, prep, explain, model.diameter);
  });
  // Explained mostly by a removed plane's points (the floor, a table, a wall): matched into it.
  const auto on_plane = static_cast<std::size_t>(
      std::count_if(ev.pixels.begin(), ev.pixels.end(), [&](std::uint32_t px) {
        return prep.on_plane[static_cast<std::size_t>(image.point[px])] != 0;
      }));
  if (2 * on_plane > ev.pixels.size()) ev.larger_surface = true;
  reclassify_occluded(model, model_tree, prep, T_camera_model.inverse(), faces, occluders, explain,
                      ev);
  return ev;
}

// ICP of the scene's voting points near the hypothesis onto the model (point-to-plane on the
// model's normals): two rounds, pairs within 2 and then 1 voxel. Each round keeps only the scene
// points on the model's surface as the current pose places it: near a model point whose normal
// agrees with theirs (within kRefineNormalDeg). A neighbouring part touching this one, or the
// back of the model, otherwise pulls the pose off a true instance.
Eigen::Isometry3d refine(const PpfModel& model, const KdTree& model_tree, const PointCloud& voting,
                         const KdTree& voting_tree, const Eigen::Vector3d& model_centre,
                         const Eigen::Isometry3d& T_camera_model) {
  thread_local std::vector<Neighbor> nb;
  const double reach = model.diameter / 2 + 2 * model.voxel;
  voting_tree.radius(T_camera_model * model_centre, reach * reach, nb);
  const double min_cos = std::cos(deg_to_rad(kRefineNormalDeg));
  Eigen::Isometry3d T_model_camera = T_camera_model.inverse();
  for (const double voxels : {2.0, 1.0}) {
    const double bound = voxels * model.voxel;
    PointCloud crop;
    for (const Neighbor& m : nb) {
      Neighbor nn;
      const Eigen::Vector3d x = T_model_camera * voting.positions[m.index];
      if (model_tree.nearest(x, nn, bound * bound) &&
          model.points.normals[nn.index].dot(T_model_camera.linear() * voting.normals[m.index]) >=
              min_cos)
        crop.positions.push_back(voting.positions[m.index]);
    }
    if (crop.size() < kMinExplained) break;
    IcpSettings s;
    s.rejection = RejectionRule::max_distance(bound);
    s.termination.max_iterations = 30;
    s.threads = 1;  // the hypotheses run in parallel
    T_model_camera = icp(crop, model.points, model_tree, T_model_camera, s).T_target_source;
  }
  return T_model_camera.inverse();
}

}  // namespace

FindScene organized_scene(const std::vector<Eigen::Vector3d>& image, std::size_t width,
                          std::size_t height, const Eigen::Isometry3d& T_cloud_camera) {
  if (width == 0 || height == 0 || image.size() != width * height)
    throw std::invalid_argument("organized_scene: " + std::to_string(image.size()) +
                                " points for a " + std::to_string(width) + " x " +
                                std::to_string(height) + " image");
  FindScene scene;
  scene.width = width, scene.height = height;
  scene.T_cloud_camera = T_cloud_camera;
  for (std::size_t i = 0; i < image.size(); ++i)
    if (image[i].allFinite()) {
      scene.cloud.positions.push_back(image[i]);
      scene.pixels.push_back(static_cast<std::uint32_t>(i));
    }
  return scene;
}

FindScene read_find_scene(const std::filesystem::path& path) {
  io::ReadInfo info;
  FindScene scene;
  scene.cloud = io::read_point_cloud(path, &info);
  scene.cloud.normals.clear();  // find estimates its own, toward the camera
  if (info.height > 1) {
    scene.width = info.width, scene.height = info.height;
    scene.pixels = std::move(info.indices);
  }
  scene.T_cloud_camera = Eigen::Translation3d(info.viewpoint.position) * info.viewpoint.orientation;
  return scene;
}

namespace {

// Seen from `eye`, of the points whose surface does not graze the line of sight (|n·ray| at least
// kMinFacing, whatever the normal's sign): the share more than 3 point spacings behind another
// point in their direction (a pixel of projected_range_image spans about one spacing), and the
// share whose normal faces away from the eye. 1 and 1 when no single view sees the points.
struct SideShares {
  double hidden = 1, back = 1;
};
SideShares shares_from(const PointCloud& model, const Eigen::Vector3d& eye) {
  RangeImage image;
  try {
    image = projected_range_image(model, Eigen::Isometry3d(Eigen::Translation3d(eye)));
  } catch (const DataError&) {
    return {};
  }
  const Eigen::Isometry3d T_camera_cloud = image.T_cloud_camera.inverse();
  std::size_t tested = 0, hidden = 0, back = 0;
  for (std::size_t i = 0; i < model.size(); ++i) {
    const Eigen::Vector3d ray = (eye - model.positions[i]).normalized();
    const double facing = model.normals[i].dot(ray);
    if (std::abs(facing) < kMinFacing) continue;
    ++tested;
    back += facing < 0;
    const Eigen::Vector3d p = T_camera_cloud * model.positions[i];
    const Eigen::Vector2d uv = image.project(p);
    const long u = std::lround(uv.x()), v = std::lround(uv.y());
    if (u < 0 || v < 0 || u >= image.width || v >= image.height) continue;
    hidden += p.z() > image.depth[image.pixel(static_cast<int>(u), static_cast<int>(v))] +
                          3 * p.z() / image.fx;
  }
  if (tested == 0) return {};
  const auto share = [&](std::size_t k) {
    return static_cast<double>(k) / static_cast<double>(tested);
  };
  return {share(hidden), share(back)};
}

}  // namespace

ModelSide model_side(const PointCloud& model) {
  ModelSide side;
  if (model.size() < 10 || !model.has_normals()) return side;
  const Eigen::Vector3d eye = estimated_viewpoint(model, bounding_box_diagonal(model));
  side.seen_from = (eye - centroid(model)).normalized();
  const SideShares shares = shares_from(model, eye);
  side.hidden_share = shares.hidden;
  // A closed surface hides its far side from any eye (a thin plate's lies too close behind to
  // tell), and its outward normals face away from it on about half its area; a partial one shows
  // its eye nearly everything, facing it.
  side.partial = shares.hidden <= kFindMaxHiddenShare && shares.back <= kFindMaxHiddenShare;
  return side;
}

PpfModel build_find_model(const TriangleMesh& mesh, double voxel_fraction, int threads) {
  check_mesh(mesh, "model");
  const PointCloud samples = sample_surface(mesh, kFindModelSamples);
  if (samples.size() < 10) throw DataError("model", "the mesh has no area to sample");
  return build_find_model(samples, voxel_fraction, threads);
}

PpfModel build_find_model(const PointCloud& model, double voxel_fraction, int threads) {
  if (!(voxel_fraction > 0 && voxel_fraction < 1))
    throw std::invalid_argument("find: the voxel fraction must be in (0, 1), got " +
                                detail::number(voxel_fraction, 4));
  if (model.size() < 10) throw DataError("model", "fewer than 10 points");
  const double diameter = bounding_box_diagonal(model);
  if (!(diameter > 0) || !std::isfinite(diameter))
    throw DataError("model", "all its points coincide or are not finite");
  if (model.has_normals()) return build_ppf_model(model, voxel_fraction * diameter, threads, true);
  // No normals: the surface's (PCA), turned toward the scanner of a model that is one side of its
  // part (seen from its estimated sensor, it hides almost nothing), where the surface faces it,
  // and elsewhere away from the centroid (outward on a convex part, and on the faces a one-sided
  // scan sees at a grazing angle).
  PointCloud oriented = model;
  NormalSettings ns;
  ns.threads = threads;
  const Eigen::Vector3d c = centroid(model);
  ns.viewpoint = c;
  estimate_normals(oriented, ns);
  const Eigen::Vector3d eye = estimated_viewpoint(oriented, diameter);
  const bool one_side = shares_from(oriented, eye).hidden <= kFindMaxHiddenShare;
  for (std::size_t i = 0; i < oriented.size(); ++i) {
    Eigen::Vector3d& n = oriented.normals[i];
    const Eigen::Vector3d ray = (eye - oriented.positions[i]).normalized();
    const bool toward_eye = one_side && std::abs(n.dot(ray)) >= kMinFacing;
    if (toward_eye ? n.dot(ray) < 0 : n.dot(oriented.positions[i] - c) < 0) n = -n;
  }
  return build_ppf_model(oriented, voxel_fraction * diameter, threads, true);
}

namespace {

struct Hypothesis {
  Eigen::Isometry3d T_camera_model;
  Evidence evidence;
};

// The scene points (indices) on the model's surface at the pose: those of the pixels around the
// model's projection within the explain distance of the surface (tangent plane of the nearest
// model point). Ascending.
std::vector<std::uint32_t> instance_points(const PpfModel& model, const KdTree& model_tree,
                                           const Prepared& prep,
                                           const Eigen::Isometry3d& T_camera_model) {
  const RangeImage& image = prep.image;
  Eigen::AlignedBox2d box;
  for (const auto& q : model.points.positions) {
    const Eigen::Vector3d p = T_camera_model * q;
    if (p.z() > 0) box.extend(image.project(p));
  }
  std::vector<std::uint32_t> out;
  if (box.isEmpty()) return out;
  const Eigen::Isometry3d T_model_camera = T_camera_model.inverse();
  const double explain =
      explain_distance(model.voxel, image, (T_camera_model * centroid(model.points)).z());
  const int u0 = std::max(0, static_cast<int>(std::floor(box.min().x())) - 2);
  const int v0 = std::max(0, static_cast<int>(std::floor(box.min().y())) - 2);
  const int u1 = std::min(image.width - 1, static_cast<int>(std::ceil(box.max().x())) + 2);
  const int v1 = std::min(image.height - 1, static_cast<int>(std::ceil(box.max().y())) + 2);
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u) {
      const std::int32_t q = image.point[image.pixel(u, v)];
      if (q < 0 || !prep.in_range[static_cast<std::size_t>(q)]) continue;
      const Eigen::Vector3d m = T_model_camera * prep.points[static_cast<std::size_t>(q)];
      if (on_surface(model, model_tree, m, explain)) out.push_back(static_cast<std::uint32_t>(q));
    }
  std::sort(out.begin(), out.end());
  return out;
}

// Final pose of an accepted instance: ICP of its scene points (full resolution; normals toward the
// camera when the cost needs them) onto the model, pairs within the explain distance, with the
// settings' cost; and the RMS of the pairs (plane distances but for point-to-point).
Eigen::Isometry3d final_refine(const PpfModel& model, const KdTree& model_tree,
                               const Prepared& prep, const std::vector<std::uint32_t>& points,
                               const Eigen::Isometry3d& T_camera_model, const CostSettings& cost,
                               double& rms) {
  PointCloud source;
  for (std::uint32_t q : points) source.positions.push_back(prep.points[q]);
  if (source.size() < kMinExplained) return T_camera_model;
  if (needs_source_normals(cost.method)) {
    NormalSettings ns;
    ns.viewpoint = Eigen::Vector3d::Zero();  // the camera, in whose frame prep.points are
    ns.threads = 1;
    estimate_normals(source, ns);
  }
  IcpSettings s;
  s.method = cost.method;
  s.kernel = cost.kernel.value_or(RobustKernel::kNone);
  s.kernel_scale = cost.kernel_scale;
  s.rejection = RejectionRule::max_distance(
      explain_distance(model.voxel, prep.image, (T_camera_model * centroid(model.points)).z()));
  s.termination.max_iterations = 30;
  s.threads = 1;
  const IcpResult r = icp(source, model.points, model_tree, T_camera_model.inverse(), s);
  rms = r.rms;
  return r.T_target_source.inverse();
}

// Non-maximum suppression (find.hpp, step 5): best score first; each accepted instance claims the
// scene pixels of its surface, and a later hypothesis is scored on its explained pixels still free.
std::vector<std::size_t> suppress(const std::vector<Hypothesis>& hyps, const Prepared& prep,
                                  const PpfModel& model, const KdTree& model_tree,
                                  const FindSettings& s,
                                  std::vector<std::vector<std::uint32_t>>& claimed_points) {
  std::vector<std::size_t> order(hyps.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return hyps[a].evidence.score(hyps[a].evidence.explained) >
           hyps[b].evidence.score(hyps[b].evidence.explained);
  });
  std::vector<char> claimed(prep.image.depth.size(), 0);
  std::vector<std::size_t> accepted;
  for (std::size_t h : order) {
    const Evidence& ev = hyps[h].evidence;
    std::size_t free = 0;
    for (std::uint32_t px : ev.pixels) free += claimed[px] ? 0 : 1;
    const double needed = std::max<double>(kMinExplained, kMinExplainedShare * ev.visible);
    if (ev.score(free) < s.min_score || static_cast<double>(free) < needed) continue;
    if (s.max_instances > 0 && accepted.size() == static_cast<std::size_t>(s.max_instances)) break;
    accepted.push_back(h);
    claimed_points.push_back(instance_points(model, model_tree, prep, hyps[h].T_camera_model));
    for (std::uint32_t px : ev.pixels) claimed[px] = 1;
    for (std::uint32_t q : claimed_points.back()) {
      const Eigen::Vector2d uv = prep.image.project(prep.points[q]);
      const long u = std::lround(uv.x()), v = std::lround(uv.y());
      if (u >= 0 && v >= 0 && u < prep.image.width && v < prep.image.height)
        claimed[prep.image.pixel(static_cast<int>(u), static_cast<int>(v))] = 1;
    }
  }
  return accepted;
}

}  // namespace

FindResult find(const PpfModel& model, const FindScene& scene, const FindSettings& settings) {
  const auto start = Clock::now();
  check_settings(settings);
  if (!model.outward || model.points.size() < 10 || !model.points.has_normals())
    throw std::invalid_argument(
        "find: the model description must be built with outward normals (build_find_model)");
  const int threads = settings.threads;
  FindResult result;
  result.model_diameter = model.diameter;
  result.voxel = model.voxel;
  result.model_points = model.points.size();
  result.symmetry = settings.detect_symmetry
                        ? detect_symmetry(model.points, kSymmetryVoxels * model.voxel, threads)
                        : settings.symmetry;
  result.model_side = model_side(model.points);
  const Prepared prep = prepare_scene(scene, model, settings);
  result.image = prep.image;
  result.depth_dropped = prep.depth_dropped;
  result.plane_points = prep.plane_points;
  result.voting_points = prep.voting.size();
  result.prepare_ms = ms_since(start);

  auto lap = Clock::now();
  const std::vector<PpfHypothesis> votes =
      prep.voting.size() >= 10 ? ppf_hypotheses(model, prep.voting, result.symmetry, kMaxHypotheses,
                                                threads, kHypothesesPerPlace)
                               : std::vector<PpfHypothesis>{};
  result.hypotheses = votes.size();
  result.vote_ms = ms_since(lap);

  lap = Clock::now();
  const KdTree model_tree(model.points.positions, threads);
  const KdTree& voting_tree = *prep.voting_tree;
  const Eigen::Vector3d model_centre = centroid(model.points);
  std::vector<Hypothesis> hyps(votes.size());
  // One task a hypothesis (parallel_tasks, not parallel_for's runs of 256: 400 hypotheses would
  // make two runs of unequal size).
  parallel_tasks(votes.size(), threads, [&](std::size_t h) {
    hyps[h].T_camera_model =
        refine(model, model_tree, prep.voting, voting_tree, model_centre, votes[h].T_scene_model);
  });
  result.refine_ms = ms_since(lap);

  lap = Clock::now();
  parallel_tasks(hyps.size(), threads, [&](std::size_t h) {
    hyps[h].evidence = verify(model, model_tree, prep, result.model_side, hyps[h].T_camera_model);
  });
  std::vector<std::vector<std::uint32_t>> points;
  const std::vector<std::size_t> accepted =
      suppress(hyps, prep, model, model_tree, settings, points);
  result.instances.resize(accepted.size());
  parallel_tasks(accepted.size(), threads, [&](std::size_t k) {
    const Hypothesis& h = hyps[accepted[k]];
    FoundInstance& out = result.instances[k];
    const Eigen::Isometry3d T =
        final_refine(model, model_tree, prep, points[k], h.T_camera_model, settings.cost, out.rms);
    out.T_scene_model = canonical_pose(prep.image.T_cloud_camera * T, result.symmetry);
    const Evidence ev = verify(model, model_tree, prep, result.model_side, T);
    out.score = ev.score(std::min(ev.explained, h.evidence.explained));
    out.visible_fraction = ev.visible_fraction();
    out.points = instance_points(model, model_tree, prep, T);
    out.explained = out.points.size();
  });
  // The last ICP moves a pose onto its scene points; when that lowers the score below min_score,
  // the hypothesis only looked right at its coarser pose: not an instance.
  std::erase_if(result.instances,
                [&](const FoundInstance& f) { return f.score < settings.min_score; });
  std::stable_sort(
      result.instances.begin(), result.instances.end(),
      [](const FoundInstance& a, const FoundInstance& b) { return a.score > b.score; });
  result.verify_ms = ms_since(lap);
  if (!prep.image.organized)
    result.warnings.push_back(
        {"projected_scene",
         "the scene is not organized: its depth image was made by projecting the points from the "
         "viewpoint, so the visibility checks hold only if the points were seen from there"});
  result.total_ms = ms_since(start);
  return result;
}

}  // namespace align3d
