// open3d_run: Open3D 0.16's runner for the side-by-side comparison (bench/compare.py); the contract
// is in bench/runner_common.hpp. Open3D's C++ API as Debian's libopen3d-dev ships it:
//   normals    PointCloud::EstimateNormals(KDTreeSearchParamKNN(K)) (its default fast, closed-form
//              3×3 eigen solver)
//   icp-*      RegistrationICP with max_correspondence_distance D and
//              ICPConvergenceCriteria(1e-6, 1e-6, N); icp-plane estimates the target normals first
//              (KNN K) inside the timed region. Iterations are counted by wrapping the estimation's
//              ComputeTransformation (one call per ICP update; 0.16's result has no count).
//   global     as bench/compare_global.py: VoxelDownSample(V), EstimateNormals (KNN K, as
//              align3d's coarse stage, instead of compare_global.py's 2-voxel hybrid), FPFH
//              (hybrid radius 5 V, at most 100 neighbours),
//              RegistrationRANSACBasedOnFeatureMatching (no mutual filter, 1.5 V, ransac_n 3,
//              edge-length checker 0.9, RANSACConvergenceCriteria(100000, 0.9999)), random seed 1.
// Threads: Open3D parallelises with OpenMP and caps its regions at EstimateMaxThreads(), which in
// 0.16 honours OMP_NUM_THREADS (otherwise it uses the physical cores); both are set to T.
#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>

#include "open3d/geometry/KDTreeSearchParam.h"
#include "open3d/geometry/PointCloud.h"
#include "open3d/io/PointCloudIO.h"
#include "open3d/pipelines/registration/CorrespondenceChecker.h"
#include "open3d/pipelines/registration/Feature.h"
#include "open3d/pipelines/registration/Registration.h"
#include "open3d/pipelines/registration/TransformationEstimation.h"
#include "open3d/utility/Logging.h"
#include "open3d/utility/Random.h"
#include "runner_common.hpp"

namespace {

namespace o3d = open3d;
namespace reg = open3d::pipelines::registration;

// Counts the ICP updates: RegistrationICP calls ComputeTransformation once per iteration.
template <class Base>
class Counting : public Base {
 public:
  Eigen::Matrix4d ComputeTransformation(const o3d::geometry::PointCloud& source,
                                        const o3d::geometry::PointCloud& target,
                                        const reg::CorrespondenceSet& corres) const override {
    ++calls;
    return Base::ComputeTransformation(source, target, corres);
  }
  mutable int calls = 0;
};

o3d::geometry::PointCloud load(const std::string& path) {
  o3d::geometry::PointCloud cloud;
  if (!o3d::io::ReadPointCloud(path, cloud) || cloud.points_.empty())
    throw std::runtime_error(path + ": Open3D could not read it (or it has no points)");
  cloud.normals_.clear();  // every system estimates them, inside the timed region
  cloud.colors_.clear();
  return cloud;
}

bench::Matrix4 to_matrix4(const Eigen::Matrix4d& T) {
  bench::Matrix4 m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m[i][j] = T(i, j);
  return m;
}

Eigen::Matrix4d from_matrix4(const bench::Matrix4& m) {
  Eigen::Matrix4d T;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) T(i, j) = m[i][j];
  return T;
}

// The common untimed evaluation (runner_common.hpp): Open3D's EvaluateRegistration computes exactly
// it (nearest target point within D; fitness over the source points, Euclidean inlier RMSE).
void evaluate(const o3d::geometry::PointCloud& source, const o3d::geometry::PointCloud& target,
              const Eigen::Matrix4d& T, double max_distance, bench::Report& r) {
  if (!(max_distance > 0)) return;
  const reg::RegistrationResult e = reg::EvaluateRegistration(source, target, max_distance, T);
  r.fitness = e.fitness_;
  r.rms = e.correspondence_set_.empty() ? NAN : e.inlier_rmse_;
}

bench::Report run(const bench::RunnerArgs& a) {
  setenv("OMP_NUM_THREADS", std::to_string(a.threads).c_str(), 1);
  omp_set_num_threads(a.threads);
  o3d::utility::SetVerbosityLevel(o3d::utility::VerbosityLevel::Error);
  bench::Report r;
  r.system = "Open3D";
  r.task = a.task;
  const o3d::geometry::PointCloud source = load(a.source);
  o3d::geometry::PointCloud target = load(a.target);
  r.points_source = source.points_.size();
  r.points_target = target.points_.size();
  const Eigen::Matrix4d init = from_matrix4(bench::read_matrix4(a.init));

  if (a.task == "normals") {
    bench::timed(r, [&] { target.EstimateNormals(o3d::geometry::KDTreeSearchParamKNN(a.k)); });
    double sum_abs_z = 0;
    for (const auto& n : target.normals_) sum_abs_z += std::abs(n.z());
    r.extra["normals_mean_abs_z"] =
        bench::json_number(sum_abs_z / static_cast<double>(target.normals_.size()));
    return r;
  }

  if (a.task == "global") {
    const double voxel =
        a.voxel > 0 ? a.voxel : (target.GetMaxBound() - target.GetMinBound()).norm() / 50.0;
    o3d::utility::random::Seed(1);
    reg::RegistrationResult g;
    bench::timed(r, [&] {
      auto prepare = [&](const o3d::geometry::PointCloud& cloud) {
        std::shared_ptr<o3d::geometry::PointCloud> down = cloud.VoxelDownSample(voxel);
        down->EstimateNormals(o3d::geometry::KDTreeSearchParamKNN(a.k));
        std::shared_ptr<reg::Feature> fpfh =
            reg::ComputeFPFHFeature(*down, o3d::geometry::KDTreeSearchParamHybrid(5 * voxel, 100));
        return std::make_pair(down, fpfh);
      };
      const auto [sd, sf] = prepare(source);
      const auto [td, tf] = prepare(target);
      const reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
      g = reg::RegistrationRANSACBasedOnFeatureMatching(
          *sd, *td, *sf, *tf, false, 1.5 * voxel, reg::TransformationEstimationPointToPoint(false),
          3, {edge}, reg::RANSACConvergenceCriteria(100000, 0.9999));
    });
    r.transformation = to_matrix4(g.transformation_);
    r.extra["voxel"] = bench::json_number(voxel);
    r.extra["ransac_fitness"] = bench::json_number(g.fitness_);
    evaluate(source, target, g.transformation_, a.max_distance, r);
    return r;
  }

  const reg::ICPConvergenceCriteria criteria(1e-6, 1e-6, a.max_iterations);
  reg::RegistrationResult result;
  if (a.task == "icp-point") {
    const Counting<reg::TransformationEstimationPointToPoint> estimation;
    bench::timed(r, [&] {
      result = reg::RegistrationICP(source, target, a.max_distance, init, estimation, criteria);
    });
    r.iterations = estimation.calls;
  } else {
    const Counting<reg::TransformationEstimationPointToPlane> estimation;
    bench::timed(r, [&] {
      target.EstimateNormals(o3d::geometry::KDTreeSearchParamKNN(a.k));
      result = reg::RegistrationICP(source, target, a.max_distance, init, estimation, criteria);
    });
    r.iterations = estimation.calls;
  }
  r.transformation = to_matrix4(result.transformation_);
  r.extra["stop"] = bench::json_string(r.iterations < a.max_iterations ? "relative_rmse_and_fitness"
                                                                       : "max_iterations");
  evaluate(source, target, result.transformation_, a.max_distance, r);
  return r;
}

}  // namespace

int main(int argc, char** argv) { return bench::runner_main(argc, argv, "Open3D", run); }
