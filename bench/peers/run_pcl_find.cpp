// pcl_find_run: PCL 1.13's side of the bin-picking comparison (bench/compare_find.py): every
// instance of a part (binary STL) in an organized depth-camera scene (PCD, camera frame).
//
//   pcl_find_run MODEL.stl SCENE.pcd [--method cg|ppf] [--threads T] [--budget S]
//                [--voxel-fraction 0.04] [--min-fitness F] [--max-tries N] [--verbose]
//                [cg, for tuning: --grouping gc|hough --shot-radius --rf-radius --scene-keys
//                 --model-keys --hough-bin --normal-radius (in voxels) --match --hough-threshold
//                 --verify 0|1 --occlusion 0|1]
//
// Prints ONE JSON line: system, method, instances [{transformation (4x4 row-major, scene ≈
// T·model), score, ...}] best score first, model_ms (the model's preparation), time_ms (the
// detection: the scene in memory to the poses), cpu_ms, capped (the budget stopped the search
// early), plane_points, scene_points, peak_rss_kb. The files are read before any clock starts.
//
// Shared by both methods (the settings compare_find.py's docstring lists for every peer):
//   model   the STL sampled evenly by area (20000 points, std::mt19937 seed 1, the triangles'
//           normals: outward), voxel v = voxel_fraction × the model's diameter (its bounding-box
//           diagonal, as align3d and the generator define it), VoxelGrid(v) with the normals
//           averaged per voxel.
//   scene   planes removed as compare_find.py's Open3D peer does: RANSAC (SACSegmentation,
//           SACMODEL_PLANE, 0.5 v, 1000 iterations) on a VoxelGrid(v / 2) sample; a plane holding
//           at least 2 % of the first sample is cut out of the full cloud in a band of
//           max(0.5 v, 3 × the RMS distance of the points within v); at most 6 planes (the ground
//           around the bin, its floor and walls). Then VoxelGrid(v) with normals
//           (NormalEstimationOMP, radius 2 v, turned toward the camera at the origin).
//   refine  each pose: point-to-plane ICP (IterativeClosestPointWithNormals) of the downsampled
//           model onto the downsampled scene, max correspondence v, 30 iterations; fitness =
//           share of the model's downsampled points within v of the scene afterwards.
//
// --method cg (the default): correspondence grouping as PCL's tutorial
//   (correspondence_grouping.cpp) with its global hypothesis verification. Keypoints by
//   UniformSampling (leaf v) on the model sample and on the full-resolution scene (normals radius
//   2 v toward the camera); SHOT352 (SHOTEstimationOMP, radius 6 v, the full clouds as support);
//   for each scene descriptor the nearest model descriptor, kept when the squared distance is
//   < 0.5; GeometricConsistencyGrouping (consensus 2 v, at least 3 correspondences; --grouping
//   hough: Hough3DGrouping with BOARD frames of radius 2 v, bin 2 v, threshold 3); each pose
//   refined; GlobalHypothesesVerification (resolution v / 2, inlier and occlusion thresholds v,
//   occupancy grid v, normals radius 2 v, regularizer 3, clutter radius 3 v, clutter regularizer
//   5, occlusion reasoning on); the poses it keeps with fitness ≥ --min-fitness (0.1), best
//   first, a pose whose model centre lies within 0.2 × the diameter of a better one's dropped.
//   When GO throws (std::length_error from vector::_M_fill_insert: PCL 1.13 does on some scenes),
//   every hypothesis stands on its fitness and the output says "verify_failed": true.
//   Tried on 6 scenes of other seeds and worse: Hough3DGrouping (no correct pose), the tutorial's
//   match threshold 0.25 and 5 votes (no pose), SHOT radius 4 v and k = 10 normals (no pose).
// --method ppf: PCL's point pair features (Drost et al. 2010): PPFEstimation on the model,
//   PPFHashMapSearch (12° angle step, distance step v), PPFRegistration (every 5th scene point a
//   reference, clusters within 2 v and 12°; ONE pose per run, the cluster with most votes),
//   re-run with the found instance's scene points (within v of the posed model) removed until
//   the refined fitness is below --min-fitness, --max-tries runs or the budget. Not used by the
//   bench: the model's table took 135 s for the bracket's 1025 points and each run ~10 s on one
//   core (PCL's PPF has no threads).
#include <omp.h>
#include <pcl/common/transforms.h>
#include <pcl/correspondence.h>
#include <pcl/features/board.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/features/ppf.h>
#include <pcl/features/shot_omp.h>
#include <pcl/filters/extract_indices.h>
#include <pcl/filters/filter.h>
#include <pcl/filters/uniform_sampling.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/recognition/cg/geometric_consistency.h>
#include <pcl/recognition/cg/hough_3d.h>
#include <pcl/recognition/hv/hv_go.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/ppf_registration.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <pcl/recognition/impl/cg/hough_3d.hpp>  // not instantiated for PointNormal in the library
#include <random>
#include <string>
#include <vector>

#include "runner_common.hpp"

namespace {

using Point = pcl::PointXYZ;
using PointN = pcl::PointNormal;
using Cloud = pcl::PointCloud<Point>;
using CloudN = pcl::PointCloud<PointN>;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

struct Args {
  std::string model, scene, method = "cg";
  int threads = 1, max_tries = 20;
  double budget_s = 20, voxel_fraction = 0.04, min_fitness = 0.1;
  // cg's sizes in voxels (see the header), and its thresholds.
  // The defaults are the best of those tried on 6 scenes of other seeds (bench/README.md).
  double shot_radius = 6, rf_radius = 2, scene_keys = 1, model_keys = 1, hough_bin = 2;
  double normal_radius = 2;  // scene normals for SHOT: a radius in v; 0 = k = 10 neighbours
  double match = 0.5, hough_threshold = 3;  // squared SHOT distance; votes (hough or gc)
  bool verify = true, occlusion = true;
  std::string grouping = "gc";  // GeometricConsistencyGrouping, or "hough": Hough3DGrouping
  bool verbose = false;         // stage counts and times on stderr
  Clock::time_point start = Clock::now();
};

struct Triangle {
  Eigen::Vector3f a, b, c;
};

// A binary STL's triangles (80-byte header, count, 50-byte records).
std::vector<Triangle> read_stl(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<char> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() < 84) throw std::runtime_error(path + ": not a binary STL");
  std::uint32_t n = 0;
  std::memcpy(&n, data.data() + 80, 4);
  if (data.size() != 84 + 50 * static_cast<std::size_t>(n))
    throw std::runtime_error(path + ": not a binary STL (size does not match the count)");
  std::vector<Triangle> tris(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    float f[9];
    std::memcpy(f, data.data() + 84 + 50 * static_cast<std::size_t>(i) + 12, sizeof f);
    tris[i] = {{f[0], f[1], f[2]}, {f[3], f[4], f[5]}, {f[6], f[7], f[8]}};
  }
  return tris;
}

// `count` points spread evenly by area, each with its triangle's (outward) normal.
CloudN::Ptr sample_mesh(const std::vector<Triangle>& tris, int count) {
  std::vector<double> cumulative(tris.size());
  double total = 0;
  for (std::size_t i = 0; i < tris.size(); ++i) {
    total += 0.5 * (tris[i].b - tris[i].a).cross(tris[i].c - tris[i].a).cast<double>().norm();
    cumulative[i] = total;
  }
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  CloudN::Ptr out(new CloudN);
  for (int k = 0; k < count; ++k) {
    const double pick = u(rng) * total;
    const auto i = static_cast<std::size_t>(std::min<std::ptrdiff_t>(
        std::lower_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin(),
        static_cast<std::ptrdiff_t>(tris.size()) - 1));
    double r1 = std::sqrt(u(rng)), r2 = u(rng);
    const Triangle& t = tris[i];
    const Eigen::Vector3f p = static_cast<float>(1 - r1) * t.a +
                              static_cast<float>(r1 * (1 - r2)) * t.b +
                              static_cast<float>(r1 * r2) * t.c;
    const Eigen::Vector3f n = (t.b - t.a).cross(t.c - t.a).normalized();
    PointN q;
    q.getVector3fMap() = p;
    q.getNormalVector3fMap() = n;
    out->push_back(q);
  }
  return out;
}

template <class P>
typename pcl::PointCloud<P>::Ptr voxel_grid(const typename pcl::PointCloud<P>::ConstPtr& in,
                                            double leaf) {
  typename pcl::PointCloud<P>::Ptr out(new pcl::PointCloud<P>);
  pcl::VoxelGrid<P> grid;
  grid.setInputCloud(in);
  grid.setLeafSize(static_cast<float>(leaf), static_cast<float>(leaf), static_cast<float>(leaf));
  grid.filter(*out);
  return out;
}

// Removes up to 6 planes holding >= 2 % of the scene (see the header); returns the points removed.
std::size_t remove_planes(Cloud::Ptr& scene, double v) {
  std::size_t removed = 0;
  std::size_t first_sample = 0;
  for (int k = 0; k < 6; ++k) {
    Cloud::Ptr sample = voxel_grid<Point>(scene, v / 2);
    if (k == 0) first_sample = sample->size();
    if (sample->size() < 10) break;
    pcl::SACSegmentation<Point> seg;
    seg.setModelType(pcl::SACMODEL_PLANE);
    seg.setMethodType(pcl::SAC_RANSAC);
    seg.setDistanceThreshold(0.5 * v);
    seg.setMaxIterations(1000);
    seg.setInputCloud(sample);
    pcl::PointIndices inliers;
    pcl::ModelCoefficients c;
    seg.segment(inliers, c);
    if (inliers.indices.size() < 0.02 * static_cast<double>(first_sample)) break;
    const Eigen::Vector4f plane(c.values[0], c.values[1], c.values[2], c.values[3]);
    const float norm = plane.head<3>().norm();
    double sq = 0;
    std::size_t near = 0;
    for (const Point& p : *scene) {
      const double d = (plane.head<3>().dot(p.getVector3fMap()) + plane[3]) / norm;
      if (std::abs(d) <= v) sq += d * d, ++near;
    }
    const double band = std::max(0.5 * v, 3 * std::sqrt(sq / std::max<std::size_t>(near, 1)));
    Cloud::Ptr kept(new Cloud);
    for (const Point& p : *scene) {
      const double d = (plane.head<3>().dot(p.getVector3fMap()) + plane[3]) / norm;
      if (std::abs(d) > band) kept->push_back(p);
    }
    removed += scene->size() - kept->size();
    scene = kept;
  }
  return removed;
}

// Normals of `cloud` (radius or k neighbours), turned toward the camera at the origin.
CloudN::Ptr with_normals(const Cloud::Ptr& cloud, int threads, double radius, int k) {
  pcl::PointCloud<pcl::Normal> normals;
  pcl::NormalEstimationOMP<Point, pcl::Normal> ne(threads);
  ne.setInputCloud(cloud);
  if (k > 0)
    ne.setKSearch(k);
  else
    ne.setRadiusSearch(radius);
  ne.setViewPoint(0, 0, 0);
  ne.compute(normals);
  CloudN::Ptr out(new CloudN);
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    if (!std::isfinite(normals[i].normal_x)) continue;
    PointN q;
    q.getVector3fMap() = (*cloud)[i].getVector3fMap();
    q.getNormalVector3fMap() = normals[i].getNormalVector3fMap();
    out->push_back(q);
  }
  return out;
}

struct Found {
  Eigen::Matrix4f T;
  double score = 0, fitness_before = 0;
  std::size_t votes = 0;
};

// Share of `model` points within `d` of `scene` at the pose T.
double fitness(const CloudN& model, const pcl::KdTreeFLANN<PointN>& tree, const Eigen::Matrix4f& T,
               double d) {
  CloudN posed;
  pcl::transformPointCloudWithNormals(model, posed, T);
  pcl::Indices idx(1);
  std::vector<float> sq(1);
  std::size_t in = 0;
  for (const PointN& p : posed)
    if (tree.nearestKSearch(p, 1, idx, sq) == 1 && sq[0] <= d * d) ++in;
  return static_cast<double>(in) / static_cast<double>(std::max<std::size_t>(model.size(), 1));
}

Eigen::Matrix4f refine(const CloudN::Ptr& model, const CloudN::Ptr& scene, const Eigen::Matrix4f& T,
                       double v) {
  pcl::IterativeClosestPointWithNormals<PointN, PointN> icp;
  icp.setMaxCorrespondenceDistance(v);
  icp.setMaximumIterations(30);
  icp.setInputSource(model);
  icp.setInputTarget(scene);
  CloudN out;
  icp.align(out, T);
  return icp.hasConverged() ? icp.getFinalTransformation() : T;
}

struct Run {
  std::vector<Found> found;
  bool capped = false, verify_failed = false;
  std::size_t scene_points = 0;
};

using Shot = pcl::PointCloud<pcl::SHOT352>;
using Rf = pcl::PointCloud<pcl::ReferenceFrame>;

// What depends on the model alone, prepared before the scene's clock starts (model_ms).
struct Model {
  double v = 0;
  CloudN::Ptr dense, down;           // the sample, VoxelGrid(v)
  pcl::PPFHashMapSearch::Ptr table;  // ppf
  CloudN::Ptr keys;                  // cg: keypoints, their SHOT descriptors and BOARD frames
  Shot::Ptr shot;
  Rf::Ptr rf;
};

CloudN::Ptr uniform_keypoints(const CloudN::Ptr& cloud, double radius) {
  CloudN::Ptr out(new CloudN);
  pcl::UniformSampling<PointN> us;
  us.setInputCloud(cloud);
  us.setRadiusSearch(radius);
  us.filter(*out);
  return out;
}

Shot::Ptr shot_descriptors(const CloudN::Ptr& keys, const CloudN::Ptr& surface, double radius,
                           int threads) {
  Shot::Ptr out(new Shot);
  pcl::SHOTEstimationOMP<PointN, PointN, pcl::SHOT352> shot(threads);
  shot.setRadiusSearch(radius);
  shot.setInputCloud(keys);
  shot.setInputNormals(surface);
  shot.setSearchSurface(surface);
  shot.compute(*out);
  return out;
}

Rf::Ptr board_frames(const CloudN::Ptr& keys, const CloudN::Ptr& surface, double radius) {
  Rf::Ptr out(new Rf);
  pcl::BOARDLocalReferenceFrameEstimation<PointN, PointN, pcl::ReferenceFrame> rf;
  rf.setFindHoles(true);
  rf.setRadiusSearch(radius);
  rf.setInputCloud(keys);
  rf.setInputNormals(surface);
  rf.setSearchSurface(surface);
  rf.compute(*out);
  return out;
}

Model prepare_model(const Args& a, const std::vector<Triangle>& tris) {
  Model m;
  Eigen::Vector3f lo = tris.at(0).a, hi = lo;
  for (const Triangle& t : tris)
    for (const Eigen::Vector3f& p : {t.a, t.b, t.c}) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double v = m.v = a.voxel_fraction * static_cast<double>((hi - lo).norm());
  m.dense = sample_mesh(tris, 20000);
  m.down = voxel_grid<PointN>(m.dense, v);
  for (PointN& p : *m.down) p.getNormalVector3fMap().normalize();
  if (a.method == "ppf") {
    pcl::PointCloud<pcl::PPFSignature>::Ptr features(new pcl::PointCloud<pcl::PPFSignature>);
    pcl::PPFEstimation<PointN, PointN, pcl::PPFSignature> pe;
    pe.setInputCloud(m.down);
    pe.setInputNormals(m.down);
    pe.compute(*features);
    m.table.reset(new pcl::PPFHashMapSearch(12.0f / 180.0f * static_cast<float>(M_PI),
                                            static_cast<float>(v)));
    m.table->setInputFeatureCloud(features);
  } else {
    m.keys = uniform_keypoints(m.dense, a.model_keys * v);
    m.shot = shot_descriptors(m.keys, m.dense, a.shot_radius * v, a.threads);
    m.rf = board_frames(m.keys, m.dense, a.rf_radius * v);
  }
  return m;
}

Run run_ppf(const Args& a, const Model& m, const CloudN::Ptr& scene_down, Clock::time_point start) {
  Run run;
  const double v = m.v;
  const CloudN::Ptr& model_down = m.down;
  const pcl::PPFHashMapSearch::Ptr& table = m.table;
  CloudN::Ptr rest(new CloudN(*scene_down));
  run.scene_points = rest->size();
  for (int t = 0; t < a.max_tries && rest->size() >= 10; ++t) {
    if (ms_since(start) > 1e3 * a.budget_s) {
      run.capped = true;
      break;
    }
    pcl::PPFRegistration<PointN, PointN> reg;
    reg.setSceneReferencePointSamplingRate(5);
    reg.setPositionClusteringThreshold(static_cast<float>(2 * v));
    reg.setRotationClusteringThreshold(12.0f / 180.0f * static_cast<float>(M_PI));
    reg.setSearchMethod(table);
    reg.setInputSource(model_down);
    reg.setInputTarget(rest);
    CloudN out;
    reg.align(out);
    const Eigen::Matrix4f T0 = reg.getFinalTransformation();
    pcl::KdTreeFLANN<PointN> tree;
    tree.setInputCloud(rest);
    const double before = fitness(*model_down, tree, T0, v);
    const Eigen::Matrix4f T = refine(model_down, rest, T0, v);
    const double score = fitness(*model_down, tree, T, v);
    if (score < a.min_fitness) break;
    run.found.push_back({T, score, before, 0});
    // The instance's scene points: within v of the posed model.
    CloudN posed;
    pcl::transformPointCloudWithNormals(*model_down, posed, T);
    pcl::KdTreeFLANN<PointN> near;
    near.setInputCloud(posed.makeShared());
    pcl::Indices idx(1);
    std::vector<float> sq(1);
    CloudN::Ptr kept(new CloudN);
    for (const PointN& p : *rest)
      if (!(near.nearestKSearch(p, 1, idx, sq) == 1 && sq[0] <= v * v)) kept->push_back(p);
    rest = kept;
  }
  return run;
}

Run run_cg(const Args& a, const Model& m, const Cloud::Ptr& scene_full,
           const CloudN::Ptr& scene_down) {
  Run run;
  const double v = m.v;
  const CloudN::Ptr& model_down = m.down;
  // Scene at full resolution with normals (SHOT's support), keypoints by uniform sampling.
  CloudN::Ptr scene = a.normal_radius > 0
                          ? with_normals(scene_full, a.threads, a.normal_radius * v, 0)
                          : with_normals(scene_full, a.threads, 0, 10);
  run.scene_points = scene->size();
  CloudN::Ptr scene_keys = uniform_keypoints(scene, a.scene_keys * v);
  Shot::Ptr scene_shot = shot_descriptors(scene_keys, scene, a.shot_radius * v, a.threads);
  pcl::CorrespondencesPtr corrs(new pcl::Correspondences);
  pcl::KdTreeFLANN<pcl::SHOT352> match;
  match.setInputCloud(m.shot);
  for (std::size_t i = 0; i < scene_shot->size(); ++i) {
    if (!std::isfinite((*scene_shot)[i].descriptor[0])) continue;
    pcl::Indices idx(1);
    std::vector<float> sq(1);
    if (match.nearestKSearch((*scene_shot)[i], 1, idx, sq) == 1 && sq[0] < a.match)
      corrs->emplace_back(idx[0], static_cast<int>(i), sq[0]);
  }
  std::vector<Eigen::Matrix4f, Eigen::aligned_allocator<Eigen::Matrix4f>> poses;
  std::vector<pcl::Correspondences> clustered;
  if (a.grouping == "gc") {
    pcl::GeometricConsistencyGrouping<PointN, PointN> gc;
    gc.setGCSize(static_cast<float>(a.hough_bin * v));
    gc.setGCThreshold(a.hough_threshold);
    gc.setInputCloud(m.keys);
    gc.setSceneCloud(scene_keys);
    gc.setModelSceneCorrespondences(corrs);
    gc.recognize(poses, clustered);
  } else {
    Rf::Ptr scene_rf = board_frames(scene_keys, scene, a.rf_radius * v);
    pcl::Hough3DGrouping<PointN, PointN, pcl::ReferenceFrame, pcl::ReferenceFrame> hough;
    hough.setHoughBinSize(static_cast<float>(a.hough_bin * v));
    hough.setHoughThreshold(a.hough_threshold);
    hough.setUseInterpolation(true);
    hough.setUseDistanceWeight(false);
    hough.setInputCloud(m.keys);
    hough.setInputRf(m.rf);
    hough.setSceneCloud(scene_keys);
    hough.setSceneRf(scene_rf);
    hough.setModelSceneCorrespondences(corrs);
    hough.recognize(poses, clustered);
  }
  if (a.verbose)
    std::fprintf(stderr,
                 "cg: %zu scene points, %zu keypoints, %zu correspondences, %zu poses (%.0f ms)\n",
                 scene->size(), scene_keys->size(), corrs->size(), poses.size(), ms_since(a.start));

  // Refine every hypothesis, then verify them together.
  pcl::KdTreeFLANN<PointN> tree;
  tree.setInputCloud(scene_down);
  std::vector<Found> hyps;
  std::vector<pcl::PointCloud<Point>::ConstPtr> posed_models;
  for (std::size_t h = 0; h < poses.size(); ++h) {
    const double before = fitness(*model_down, tree, poses[h], v);
    const Eigen::Matrix4f T = refine(model_down, scene_down, poses[h], v);
    hyps.push_back({T, fitness(*model_down, tree, T, v), before, clustered[h].size()});
    Cloud::Ptr posed(new Cloud);
    pcl::copyPointCloud(*model_down, *posed);
    pcl::transformPointCloud(*posed, *posed, T);
    posed_models.push_back(posed);
  }
  std::vector<bool> keep(hyps.size(), true);
  if (a.verify && !hyps.empty()) {
    Cloud::Ptr scene_xyz(new Cloud);
    pcl::copyPointCloud(*scene_down, *scene_xyz);
    pcl::GlobalHypothesesVerification<Point, Point> go;
    go.setSceneCloud(scene_xyz);
    go.addModels(posed_models, a.occlusion);
    go.setResolution(static_cast<float>(v / 2));
    go.setInlierThreshold(static_cast<float>(v));
    go.setOcclusionThreshold(static_cast<float>(v));
    go.setRegularizer(3);
    go.setRadiusClutter(static_cast<float>(3 * v));
    go.setClutterRegularizer(5);
    go.setDetectClutter(true);
    go.setRadiusNormals(static_cast<float>(2 * v));
    go.setResolutionOccupancyGrid(static_cast<float>(v));  // its default, 0.01, assumes metres
    try {
      go.verify();
      go.getMask(keep);
    } catch (const std::length_error&) {
      // PCL 1.13's GO throws (vector::_M_fill_insert) on some scenes, often with one hypothesis:
      // the hypotheses then stand on their fitness alone (reported as verify_failed).
      keep.assign(hyps.size(), true);
      run.verify_failed = true;
    }
  }
  if (a.verbose) {
    for (std::size_t h = 0; h < hyps.size(); ++h)
      std::fprintf(stderr, "  hypothesis %zu: %zu correspondences, fitness %.3f -> %.3f, kept %d\n",
                   h, hyps[h].votes, hyps[h].fitness_before, hyps[h].score,
                   static_cast<int>(keep[h]));
    std::fprintf(stderr, "cg: verified (%.0f ms)\n", ms_since(a.start));
  }
  std::vector<std::size_t> order(hyps.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t x, std::size_t y) { return hyps[x].score > hyps[y].score; });
  const Eigen::Vector4f centre = [&] {
    Eigen::Vector4f c = Eigen::Vector4f::Zero();
    for (const PointN& p : *model_down) c.head<3>() += p.getVector3fMap();
    c.head<3>() /= static_cast<float>(model_down->size());
    c[3] = 1;
    return c;
  }();
  const double diameter = v / a.voxel_fraction;
  for (std::size_t i : order) {
    if (!keep[i] || hyps[i].score < a.min_fitness) continue;
    const Eigen::Vector4f c = hyps[i].T * centre;
    bool duplicate = false;
    for (const Found& f : run.found) duplicate |= ((f.T * centre) - c).norm() < 0.2 * diameter;
    if (!duplicate) run.found.push_back(hyps[i]);
  }
  return run;
}

Args parse(int argc, char** argv) {
  Args a;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--verbose") {
      a.verbose = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0) {
      positional.push_back(arg);
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
    const std::string value = argv[++i];
    if (arg == "--method")
      a.method = value;
    else if (arg == "--shot-radius")
      a.shot_radius = std::stod(value);
    else if (arg == "--rf-radius")
      a.rf_radius = std::stod(value);
    else if (arg == "--scene-keys")
      a.scene_keys = std::stod(value);
    else if (arg == "--model-keys")
      a.model_keys = std::stod(value);
    else if (arg == "--hough-bin")
      a.hough_bin = std::stod(value);
    else if (arg == "--hough-threshold")
      a.hough_threshold = std::stod(value);
    else if (arg == "--match")
      a.match = std::stod(value);
    else if (arg == "--normal-radius")
      a.normal_radius = std::stod(value);
    else if (arg == "--grouping")
      a.grouping = value;
    else if (arg == "--occlusion")
      a.occlusion = value != "0";
    else if (arg == "--verify")
      a.verify = value != "0";
    else if (arg == "--threads")
      a.threads = std::stoi(value);
    else if (arg == "--budget")
      a.budget_s = std::stod(value);
    else if (arg == "--voxel-fraction")
      a.voxel_fraction = std::stod(value);
    else if (arg == "--min-fitness")
      a.min_fitness = std::stod(value);
    else if (arg == "--max-tries")
      a.max_tries = std::stoi(value);
    else
      throw std::invalid_argument("unknown option " + arg);
  }
  if (positional.size() != 2) throw std::invalid_argument("expected MODEL.stl SCENE.pcd");
  if (a.method != "cg" && a.method != "ppf") throw std::invalid_argument("--method cg or ppf");
  a.model = positional[0];
  a.scene = positional[1];
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = parse(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr,
                 "pcl_find_run: %s\nusage: pcl_find_run MODEL.stl SCENE.pcd [--method cg|ppf] "
                 "[--threads T] [--budget S] [--voxel-fraction F] [--min-fitness F] "
                 "[--max-tries N]\n",
                 e.what());
    return 2;
  }
  try {
    omp_set_num_threads(a.threads);
    pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
    const std::vector<Triangle> tris = read_stl(a.model);
    Cloud::Ptr scene(new Cloud);
    if (pcl::io::loadPCDFile(a.scene, *scene) < 0)
      throw std::runtime_error(a.scene + ": unreadable");
    {
      Cloud::Ptr finite(new Cloud);
      pcl::Indices unused;
      scene->is_dense = false;
      pcl::removeNaNFromPointCloud(*scene, *finite, unused);
      scene = finite;
    }

    bench::Report timing;  // only its clocks
    const auto t0 = Clock::now();
    const Model model = prepare_model(a, tris);
    const double model_ms = ms_since(t0), v = model.v;
    if (a.verbose)
      std::fprintf(stderr, "model: %zu points, %zu downsampled, %zu keypoints (%.0f ms)\n",
                   model.dense->size(), model.down->size(), model.keys ? model.keys->size() : 0,
                   model_ms);
    Run run;
    std::size_t plane_points = 0;
    const auto start = a.start = Clock::now();
    bench::timed(timing, [&] {
      plane_points = remove_planes(scene, v);
      Cloud::Ptr down = voxel_grid<Point>(scene, v);
      CloudN::Ptr scene_down = with_normals(down, a.threads, 2 * v, 0);
      if (a.method == "ppf")
        run = run_ppf(a, model, scene_down, start);
      else
        run = run_cg(a, model, scene, scene_down);
    });
    std::string s = "{\"system\":\"PCL\",\"method\":" + bench::json_string(a.method);
    s += ",\"instances\":[";
    for (std::size_t i = 0; i < run.found.size(); ++i) {
      const Found& f = run.found[i];
      if (i) s += ',';
      s += "{\"transformation\":[";
      for (int r = 0; r < 4; ++r) {
        s += r ? ",[" : "[";
        for (int c = 0; c < 4; ++c) {
          if (c) s += ',';
          s += bench::json_number(f.T(r, c));
        }
        s += ']';
      }
      s += "],\"score\":" + bench::json_number(f.score);
      s += ",\"fitness_before_icp\":" + bench::json_number(f.fitness_before);
      s += ",\"correspondences\":" + std::to_string(f.votes) + "}";
    }
    s += "],\"model_ms\":" + bench::json_number(model_ms);
    s += ",\"time_ms\":" + bench::json_number(timing.time_ms);
    s += ",\"cpu_ms\":" + bench::json_number(timing.cpu_ms);
    s += std::string(",\"capped\":") + (run.capped ? "true" : "false");
    s += std::string(",\"verify_failed\":") + (run.verify_failed ? "true" : "false");
    s += ",\"voxel\":" + bench::json_number(v);
    s += ",\"plane_points\":" + std::to_string(plane_points);
    s += ",\"scene_points\":" + std::to_string(run.scene_points);
    s += ",\"peak_rss_kb\":" + std::to_string(bench::peak_rss_kb()) + "}";
    std::printf("%s\n", s.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pcl_find_run: %s\n", e.what());
    return 1;
  }
}
