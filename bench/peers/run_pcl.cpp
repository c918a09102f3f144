// pcl_run: PCL 1.13's runner for the side-by-side comparison (bench/compare.py); the contract is in
// bench/runner_common.hpp. PCL as Debian's libpcl-dev ships it, with its default float scalar:
//   normals    NormalEstimationOMP (setKSearch(K), T threads), its default kd-tree (FLANN)
//   icp-point  IterativeClosestPoint<PointXYZ> (single-threaded in PCL: no OMP variant)
//   icp-plane  NormalEstimationOMP on the target (K, T threads) + IterativeClosestPointWithNormals
//              <PointNormal> (TransformationEstimationPointToPlaneLLS, not symmetric;
//              single-threaded)
//              Both: setMaxCorrespondenceDistance(D), setMaximumIterations(N), no rejectors, and
//              termination equivalent to align3d's: setEuclideanFitnessEpsilon(2e-6) — in 1.13 it
//              is the *relative* MSE change |ΔMSE|/MSE (impl/icp.hpp: setRelativeMSE), and
//              MSE = RMS², so 2e-6 on MSE ≈ 1e-6 on RMS; setTransformationEpsilon((1e-8 L)²) and
//              setTransformationRotationEpsilon(cos 1e-7) mirror align3d's update criterion (L:
//              the target's bounding-box diagonal; PCL compares the squared translation and the
//              cosine of the increment's angle).
//   global     VoxelGrid(V) + NormalEstimationOMP (K) + FPFHEstimationOMP (radius 5 V) +
//              SampleConsensusPrerejective (3 samples, correspondence randomness 1 = nearest
//              descriptor only, polygon similarity 0.9 = the edge-length check, inliers within
//              1.5 V, inlier fraction 0.15 = align3d's min_overlap, 100000 iterations). PCL has no
//              confidence-based early stop: it always draws all 100000 samples.
#include <omp.h>
#include <pcl/common/common.h>
#include <pcl/common/io.h>
#include <pcl/features/fpfh_omp.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/ply_io.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/sample_consensus_prerejective.h>

#include <cmath>
#include <string>

#include "runner_common.hpp"

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using NormalCloud = pcl::PointCloud<pcl::PointNormal>;

// Exposes the number of ICP updates (a protected member in PCL).
template <class Base>
struct Counting : Base {
  int iterations() const { return this->nr_iterations_; }
  int state() const { return static_cast<int>(this->convergence_criteria_->getConvergenceState()); }
};

Cloud::Ptr load(const std::string& path) {
  Cloud::Ptr cloud(new Cloud);
  if (pcl::io::loadPLYFile(path, *cloud) < 0 || cloud->empty())
    throw std::runtime_error(path + ": PCL could not read it (or it has no points)");
  return cloud;
}

bench::Matrix4 to_matrix4(const Eigen::Matrix4f& T) {
  bench::Matrix4 m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m[i][j] = T(i, j);
  return m;
}

double diagonal(const Cloud& cloud) {
  pcl::PointXYZ lo, hi;
  pcl::getMinMax3D(cloud, lo, hi);
  return (hi.getVector3fMap() - lo.getVector3fMap()).cast<double>().norm();
}

// The common untimed evaluation (runner_common.hpp: Report::rms, fitness).
void evaluate(const Cloud& source, const Cloud::Ptr& target, const Eigen::Matrix4f& T,
              double max_distance, bench::Report& r) {
  if (!(max_distance > 0)) return;
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
  tree.setInputCloud(target);
  const Eigen::Matrix4d Td = T.cast<double>();
  pcl::Indices index(1);
  std::vector<float> sq(1);
  double sum = 0;
  std::size_t pairs = 0;
  for (const auto& p : source) {
    const Eigen::Vector3d q = (Td * p.getVector4fMap().cast<double>()).head<3>();
    pcl::PointXYZ query(static_cast<float>(q.x()), static_cast<float>(q.y()),
                        static_cast<float>(q.z()));
    if (tree.nearestKSearch(query, 1, index, sq) == 1) {
      const double d2 = (target->at(index[0]).getVector3fMap().cast<double>() - q).squaredNorm();
      if (d2 < max_distance * max_distance) {
        sum += d2;
        ++pairs;
      }
    }
  }
  r.rms = pairs ? std::sqrt(sum / static_cast<double>(pairs)) : NAN;
  r.fitness = static_cast<double>(pairs) / static_cast<double>(source.size());
}

template <class Icp>
void configure(Icp& icp, const bench::RunnerArgs& a, double diag) {
  icp.setMaxCorrespondenceDistance(a.max_distance);
  icp.setMaximumIterations(a.max_iterations);
  icp.setEuclideanFitnessEpsilon(2e-6);
  icp.setTransformationEpsilon((1e-8 * diag) * (1e-8 * diag));
  icp.setTransformationRotationEpsilon(std::cos(1e-7));
}

bench::Report run(const bench::RunnerArgs& a) {
  omp_set_num_threads(a.threads);
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  bench::Report r;
  r.system = "PCL";
  r.task = a.task;
  const Cloud::Ptr source = load(a.source);
  const Cloud::Ptr target = load(a.target);
  r.points_source = source->size();
  r.points_target = target->size();
  Eigen::Matrix4f init;
  const bench::Matrix4 m = bench::read_matrix4(a.init);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) init(i, j) = static_cast<float>(m[i][j]);
  const double diag = diagonal(*target);

  if (a.task == "normals") {
    pcl::PointCloud<pcl::Normal> normals;
    bench::timed(r, [&] {
      pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(a.threads);
      ne.setInputCloud(target);
      ne.setKSearch(a.k);
      ne.compute(normals);
    });
    double sum_abs_z = 0;
    for (const auto& n : normals) sum_abs_z += std::abs(n.normal_z);
    r.extra["normals_mean_abs_z"] =
        bench::json_number(sum_abs_z / static_cast<double>(normals.size()));
    return r;
  }

  if (a.task == "global") {
    const double voxel = a.voxel > 0 ? a.voxel : diag / 50.0;
    const auto leaf = static_cast<float>(voxel);
    using Features = pcl::PointCloud<pcl::FPFHSignature33>;
    Eigen::Matrix4f T = Eigen::Matrix4f::Identity();
    bool converged = false;
    std::size_t inliers = 0;
    bench::timed(r, [&] {
      auto prepare = [&](const Cloud::Ptr& cloud, Cloud::Ptr& down, Features::Ptr& features) {
        down.reset(new Cloud);
        pcl::VoxelGrid<pcl::PointXYZ> grid;
        grid.setInputCloud(cloud);
        grid.setLeafSize(leaf, leaf, leaf);
        grid.filter(*down);
        pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
        pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne(a.threads);
        ne.setInputCloud(down);
        ne.setKSearch(a.k);
        ne.compute(*normals);
        features.reset(new Features);
        pcl::FPFHEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::FPFHSignature33> fe(a.threads);
        fe.setInputCloud(down);
        fe.setInputNormals(normals);
        fe.setRadiusSearch(5 * voxel);
        fe.compute(*features);
      };
      Cloud::Ptr sd, td;
      Features::Ptr sf, tf;
      prepare(source, sd, sf);
      prepare(target, td, tf);
      pcl::SampleConsensusPrerejective<pcl::PointXYZ, pcl::PointXYZ, pcl::FPFHSignature33> align;
      align.setInputSource(sd);
      align.setSourceFeatures(sf);
      align.setInputTarget(td);
      align.setTargetFeatures(tf);
      align.setMaximumIterations(100000);
      align.setNumberOfSamples(3);
      align.setCorrespondenceRandomness(1);
      align.setSimilarityThreshold(0.9f);
      align.setMaxCorrespondenceDistance(1.5 * voxel);
      align.setInlierFraction(0.15f);
      Cloud aligned;
      align.align(aligned);
      converged = align.hasConverged();
      T = align.getFinalTransformation();
      inliers = align.getInliers().size();
    });
    r.transformation = to_matrix4(T);
    r.extra["success"] = converged ? "true" : "false";
    r.extra["ransac_inliers"] = std::to_string(inliers);
    r.extra["voxel"] = bench::json_number(voxel);
    evaluate(*source, target, T, a.max_distance, r);
    return r;
  }

  Eigen::Matrix4f T;
  bool converged = false;
  int state = 0;
  if (a.task == "icp-point") {
    Counting<pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>> icp;
    configure(icp, a, diag);
    Cloud aligned;
    bench::timed(r, [&] {
      icp.setInputSource(source);
      icp.setInputTarget(target);
      icp.align(aligned, init);
    });
    r.iterations = icp.iterations();
    converged = icp.hasConverged();
    state = icp.state();
    T = icp.getFinalTransformation();
  } else {
    // Copies into the PointNormal type the point-to-plane ICP needs, outside the timed region; the
    // normals are written into `target_n` inside it.
    NormalCloud::Ptr source_n(new NormalCloud), target_n(new NormalCloud);
    pcl::copyPointCloud(*source, *source_n);
    pcl::copyPointCloud(*target, *target_n);
    Counting<pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal>> icp;
    configure(icp, a, diag);
    NormalCloud aligned;
    bench::timed(r, [&] {
      pcl::NormalEstimationOMP<pcl::PointNormal, pcl::PointNormal> ne(a.threads);
      ne.setInputCloud(target_n);
      ne.setKSearch(a.k);
      ne.compute(*target_n);
      icp.setInputSource(source_n);
      icp.setInputTarget(target_n);
      icp.align(aligned, init);
    });
    r.iterations = icp.iterations();
    converged = icp.hasConverged();
    state = icp.state();
    T = icp.getFinalTransformation();
  }
  // pcl::registration::DefaultConvergenceCriteria::ConvergenceState
  static const char* kStates[] = {"not_converged",
                                  "max_iterations",
                                  "transform_change",
                                  "abs_mse_change",
                                  "rel_mse_change",
                                  "no_correspondences",
                                  "failure_after_max_iterations"};
  r.extra["converged"] = converged ? "true" : "false";
  r.extra["stop"] = bench::json_string(state >= 0 && state < 7 ? kStates[state] : "unknown");
  r.transformation = to_matrix4(T);
  evaluate(*source, target, T, a.max_distance, r);
  return r;
}

}  // namespace

int main(int argc, char** argv) { return bench::runner_main(argc, argv, "PCL", run); }
