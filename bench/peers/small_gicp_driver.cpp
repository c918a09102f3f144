// small_gicp_driver: runs koide3/small_gicp (MIT) on two given point clouds, for the side-by-side
// comparison with align3d. small_gicp's code is NOT part of this repository: the driver is compiled
// against an external small_gicp tree by bench/peers/build_small_gicp_driver.sh (header-only use).
//
//   small_gicp_driver SOURCE.xyz TARGET.xyz [--method gicp|vgicp|icp|plane_icp] [--threads N]
//       [--neighbors K] [--max-distance D] [--max-iterations M] [--voxel-resolution V]
//       [--init INIT.txt] [--repeat R]
//
// Inputs: whitespace-separated text, one point "x y z" a line (further columns are ignored; blank
// lines and lines starting with '#' are skipped). INIT.txt: 16 numbers, 4 rows of 4, the initial
// guess of T mapping SOURCE into TARGET's frame (target ~ T * source); identity if not given.
//
// What runs (no downsampling: the given points are registered as they are):
//   preprocess  KdTree<PointCloud> of both clouds (KdTreeBuilderOMP(N)), then per-point features
//               from K neighbours with the OpenMP estimators: covariances for gicp and vgicp,
//               normals and covariances for plane_icp, none for icp. vgicp also builds the target's
//               GaussianVoxelMap (voxel size V) here.
//   register    Registration<Factor, ParallelReductionOMP>::align from INIT, Factor = GICPFactor
//               (gicp, vgicp), ICPFactor (icp), PointToPlaneICPFactor (plane_icp); small_gicp's
//               default LevenbergMarquardtOptimizer and TerminationCriteria (rotation 0.1 deg,
//               translation 1e-3), DistanceRejector with max_dist_sq = D^2 (vgicp: the voxel map's
//               own nearest-voxel lookup, D unused), optimizer.max_iterations = M,
//               reduction.num_threads = N.
// --repeat R repeats the whole thing (fresh clouds, trees, features, registration) R times; the
// times are medians over the repeats, the result is the last run's.
//
// Output: one JSON object on stdout, e.g.
//   {"transformation": [[...],[...],[...],[...]], "iterations": 5, "converged": true,
//    "num_inliers": 19873, "error": 12.3, "time_ms": {"preprocess": 8.1, "register": 6.0,
//    "total": 14.1}, ...}
// "iterations" counts the LM outer iterations run (small_gicp's RegistrationResult::iterations is
// the 0-based index of the last one; it is also printed as "iterations_small_gicp"). "error" is
// small_gicp's final error (sum of the per-point factor errors, 0.5 r^T W r). "total" is the median
// of preprocess+register (file reading is not timed).
// Errors (missing file, bad number, bad option): one line on stderr, exit code 2.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <small_gicp/ann/gaussian_voxelmap.hpp>
#include <small_gicp/ann/kdtree.hpp>
#include <small_gicp/ann/kdtree_omp.hpp>
#include <small_gicp/factors/gicp_factor.hpp>
#include <small_gicp/factors/icp_factor.hpp>
#include <small_gicp/factors/plane_icp_factor.hpp>
#include <small_gicp/points/point_cloud.hpp>
#include <small_gicp/registration/reduction_omp.hpp>
#include <small_gicp/registration/registration.hpp>
#include <small_gicp/util/normal_estimation_omp.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Options {
  std::string source_path;
  std::string target_path;
  std::string method = "gicp";
  int threads = 1;
  int neighbors = 20;         // small_gicp's default for normal/covariance estimation
  double max_distance = 1.0;  // small_gicp's default max correspondence distance
  int max_iterations = 64;
  double voxel_resolution = 1.0;  // small_gicp's RegistrationSetting default (vgicp only)
  std::string init_path;
  int repeat = 1;
};

double parse_double(const std::string& text, const std::string& what) {
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(v)) throw std::invalid_argument(text);
    return v;
  } catch (const std::exception&) {
    throw UsageError(what + ": not a number: '" + text + "'");
  }
}

int parse_int(const std::string& text, const std::string& what) {
  try {
    size_t used = 0;
    const long v = std::stol(text, &used);
    if (used != text.size() || v < -2147483647L || v > 2147483647L)
      throw std::invalid_argument(text);
    return static_cast<int>(v);
  } catch (const std::exception&) {
    throw UsageError(what + ": not an integer: '" + text + "'");
  }
}

Options parse_args(int argc, char** argv) {
  Options o;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; i++) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError("option " + a + " needs a value");
      return argv[++i];
    };
    if (a == "--method")
      o.method = value();
    else if (a == "--threads")
      o.threads = parse_int(value(), a);
    else if (a == "--neighbors")
      o.neighbors = parse_int(value(), a);
    else if (a == "--max-distance")
      o.max_distance = parse_double(value(), a);
    else if (a == "--max-iterations")
      o.max_iterations = parse_int(value(), a);
    else if (a == "--voxel-resolution")
      o.voxel_resolution = parse_double(value(), a);
    else if (a == "--init")
      o.init_path = value();
    else if (a == "--repeat")
      o.repeat = parse_int(value(), a);
    else if (a.size() > 1 && a[0] == '-' && a[1] == '-')
      throw UsageError("unknown option " + a);
    else
      positional.push_back(a);
  }
  if (positional.size() != 2) {
    throw UsageError(
        "usage: small_gicp_driver SOURCE.xyz TARGET.xyz [--method gicp|vgicp|icp|plane_icp] "
        "[--threads N] "
        "[--neighbors K] [--max-distance D] [--max-iterations M] [--voxel-resolution V] [--init "
        "INIT.txt] [--repeat R]");
  }
  o.source_path = positional[0];
  o.target_path = positional[1];
  if (o.method != "gicp" && o.method != "vgicp" && o.method != "icp" && o.method != "plane_icp")
    throw UsageError("--method: unknown method '" + o.method + "' (gicp, vgicp, icp, plane_icp)");
  if (o.threads < 1) throw UsageError("--threads must be >= 1");
  if (o.neighbors < 5)
    throw UsageError("--neighbors must be >= 5 (small_gicp needs 5 neighbours for a feature)");
  if (!(o.max_distance > 0.0)) throw UsageError("--max-distance must be > 0");
  if (o.max_iterations < 1) throw UsageError("--max-iterations must be >= 1");
  if (!(o.voxel_resolution > 0.0)) throw UsageError("--voxel-resolution must be > 0");
  if (o.repeat < 1) throw UsageError("--repeat must be >= 1");
  return o;
}

// Reads "x y z [...]" lines; further columns are ignored.
std::vector<Eigen::Vector4d> read_xyz(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw UsageError(path + ": cannot open");
  std::vector<Eigen::Vector4d> points;
  std::string line;
  size_t line_no = 0;
  while (std::getline(in, line)) {
    line_no++;
    std::istringstream ls(line);
    std::string tok[3];
    if (!(ls >> tok[0])) continue;  // blank line
    if (tok[0][0] == '#') continue;
    if (!(ls >> tok[1] >> tok[2]))
      throw UsageError(path + ":" + std::to_string(line_no) + ": fewer than 3 numbers");
    Eigen::Vector4d p;
    for (int k = 0; k < 3; k++) p[k] = parse_double(tok[k], path + ":" + std::to_string(line_no));
    p[3] = 1.0;
    points.push_back(p);
  }
  if (points.empty()) throw UsageError(path + ": no points");
  return points;
}

Eigen::Isometry3d read_init(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw UsageError(path + ": cannot open");
  std::vector<double> v;
  std::string tok;
  while (in >> tok) v.push_back(parse_double(tok, path));
  if (v.size() != 16)
    throw UsageError(path + ": expected 16 numbers (4 rows of 4), found " +
                     std::to_string(v.size()));
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; r++)
    for (int c = 0; c < 4; c++) m(r, c) = v[r * 4 + c];
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = m.block<3, 3>(0, 0);
  T.translation() = m.block<3, 1>(0, 3);
  return T;
}

std::shared_ptr<small_gicp::PointCloud> make_cloud(const std::vector<Eigen::Vector4d>& pts) {
  auto cloud = std::make_shared<small_gicp::PointCloud>();
  cloud->resize(pts.size());
  for (size_t i = 0; i < pts.size(); i++) cloud->point(i) = pts[i];
  return cloud;
}

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct RunResult {
  small_gicp::RegistrationResult result;
  double preprocess_ms = 0.0;
  double register_ms = 0.0;
};

template <typename Factor, typename Target, typename TargetTree>
small_gicp::RegistrationResult align_with(const Options& o, const Target& target,
                                          const small_gicp::PointCloud& source,
                                          const TargetTree& tree, const Eigen::Isometry3d& init) {
  small_gicp::Registration<Factor, small_gicp::ParallelReductionOMP> registration;
  registration.reduction.num_threads = o.threads;
  registration.rejector.max_dist_sq = o.max_distance * o.max_distance;
  registration.optimizer.max_iterations = o.max_iterations;
  return registration.align(target, source, tree, init);
}

RunResult run_once(const Options& o, const std::vector<Eigen::Vector4d>& src_pts,
                   const std::vector<Eigen::Vector4d>& tgt_pts, const Eigen::Isometry3d& init) {
  using namespace small_gicp;
  RunResult out;

  const auto t0 = Clock::now();
  auto source = make_cloud(src_pts);
  auto target = make_cloud(tgt_pts);
  auto target_tree = std::make_shared<KdTree<PointCloud>>(target, KdTreeBuilderOMP(o.threads));
  auto source_tree = std::make_shared<KdTree<PointCloud>>(source, KdTreeBuilderOMP(o.threads));
  std::shared_ptr<GaussianVoxelMap> target_voxelmap;
  if (o.method == "gicp" || o.method == "vgicp") {
    estimate_covariances_omp(*target, *target_tree, o.neighbors, o.threads);
    estimate_covariances_omp(*source, *source_tree, o.neighbors, o.threads);
  } else if (o.method == "plane_icp") {
    estimate_normals_covariances_omp(*target, *target_tree, o.neighbors, o.threads);
    estimate_normals_covariances_omp(*source, *source_tree, o.neighbors, o.threads);
  }
  if (o.method == "vgicp") {
    target_voxelmap = std::make_shared<GaussianVoxelMap>(o.voxel_resolution);
    target_voxelmap->insert(*target);
  }
  out.preprocess_ms = ms_since(t0);

  const auto t1 = Clock::now();
  if (o.method == "gicp") {
    out.result = align_with<GICPFactor>(o, *target, *source, *target_tree, init);
  } else if (o.method == "icp") {
    out.result = align_with<ICPFactor>(o, *target, *source, *target_tree, init);
  } else if (o.method == "plane_icp") {
    out.result = align_with<PointToPlaneICPFactor>(o, *target, *source, *target_tree, init);
  } else {
    out.result = align_with<GICPFactor>(o, *target_voxelmap, *source, *target_voxelmap, init);
  }
  out.register_ms = ms_since(t1);
  return out;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  std::vector<Eigen::Vector4d> src_pts, tgt_pts;
  Eigen::Isometry3d init = Eigen::Isometry3d::Identity();
  try {
    o = parse_args(argc, argv);
    src_pts = read_xyz(o.source_path);
    tgt_pts = read_xyz(o.target_path);
    if (!o.init_path.empty()) init = read_init(o.init_path);
  } catch (const std::exception& e) {
    std::cerr << "small_gicp_driver: " << e.what() << std::endl;
    return 2;
  }

  std::vector<double> pre, reg, tot;
  RunResult last;
  for (int r = 0; r < o.repeat; r++) {
    last = run_once(o, src_pts, tgt_pts, init);
    pre.push_back(last.preprocess_ms);
    reg.push_back(last.register_ms);
    tot.push_back(last.preprocess_ms + last.register_ms);
  }

  const Eigen::Matrix4d T = last.result.T_target_source.matrix();
  std::ostringstream js;
  js << "{\"transformation\": [";
  for (int r = 0; r < 4; r++) {
    js << (r ? ", [" : "[");
    for (int c = 0; c < 4; c++) js << (c ? ", " : "") << num(T(r, c));
    js << "]";
  }
  js << "], \"iterations\": " << (last.result.iterations + 1)  // outer LM iterations run
     << ", \"iterations_small_gicp\": " << last.result.iterations
     << ", \"converged\": " << (last.result.converged ? "true" : "false")
     << ", \"num_inliers\": " << last.result.num_inliers
     << ", \"error\": " << num(last.result.error)
     << ", \"time_ms\": {\"preprocess\": " << num(median(pre))
     << ", \"register\": " << num(median(reg)) << ", \"total\": " << num(median(tot)) << "}"
     << ", \"method\": \"" << o.method << "\", \"threads\": " << o.threads
     << ", \"neighbors\": " << o.neighbors << ", \"max_distance\": " << num(o.max_distance)
     << ", \"max_iterations\": " << o.max_iterations;
  if (o.method == "vgicp") js << ", \"voxel_resolution\": " << num(o.voxel_resolution);
  js << ", \"source_points\": " << src_pts.size() << ", \"target_points\": " << tgt_pts.size()
     << ", \"repeat\": " << o.repeat << ", \"library\": \"small_gicp\"}";
  std::cout << js.str() << std::endl;
  return 0;
}
