// align3d_run: align3d's runner for the side-by-side comparison (bench/compare.py); the contract is
// in bench/runner_common.hpp. Uses only the public API.
//   normals    KdTree + estimate_normals (k = K)
//   icp-*      refine() (the ICP layer, as Open3D's registration_icp) with rejection distance:D
//              (one ICP run, plain least squares: no robust kernel), tolerance 1e-6 relative,
//              the transform criterion left on (its default); target normals are estimated
//              inside (k = K) for point-to-plane.
//              Target normals are estimated only for the target points that pairs use
//              (NormalCache); --all-normals estimates all of them first (timed), as Open3D and PCL
//              do. --auto: the whole pipeline as `align3d register` runs it from --init: align()
//              with its defaults (init auto: the `auto` schedule, the support measurement, and the
//              global stage when the answer from the initial pose is weak).
//   global     global_register, FPFH + RANSAC (the `--init global` coarse stage), seed 1
#include <Eigen/Geometry>
#include <cmath>

#include "align3d/align.hpp"
#include "align3d/coarse/global.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "runner_common.hpp"

namespace {

using align3d::PointCloud;

bench::Matrix4 to_matrix4(const Eigen::Isometry3d& T) {
  bench::Matrix4 m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) m[i][j] = T.matrix()(i, j);
  return m;
}

// The common untimed evaluation (runner_common.hpp: Report::rms, fitness).
void evaluate(const PointCloud& source, const PointCloud& target, const Eigen::Isometry3d& T,
              double max_distance, bench::Report& r) {
  if (!(max_distance > 0)) return;
  const align3d::KdTree tree(target.positions);
  double sum = 0;
  std::size_t pairs = 0;
  align3d::Neighbor nb;
  for (const auto& p : source.positions) {
    if (tree.nearest(T * p, nb, max_distance * max_distance)) {
      sum += nb.sq_distance;
      ++pairs;
    }
  }
  r.rms = pairs ? std::sqrt(sum / static_cast<double>(pairs)) : NAN;
  r.fitness = static_cast<double>(pairs) / static_cast<double>(source.size());
}

bench::Report run(const bench::RunnerArgs& a) {
  const bool automatic = a.flags.count("--auto") > 0;
  const bool all_normals = a.flags.count("--all-normals") > 0;
  bench::Report r;
  r.system = automatic ? "align3d (auto)" : all_normals ? "align3d (all normals)" : "align3d";
  r.task = a.task;
  const PointCloud source = align3d::io::read_point_cloud(a.source);
  PointCloud target = align3d::io::read_point_cloud(a.target);
  target.normals.clear();  // every system estimates them, inside the timed region
  r.points_source = source.size();
  r.points_target = target.size();
  const Eigen::Isometry3d init =
      a.init.empty() ? Eigen::Isometry3d::Identity() : align3d::io::read_matrix(a.init);

  if (a.task == "normals") {
    align3d::NormalSettings ns;
    ns.k = a.k;
    ns.threads = a.threads;
    std::size_t undefined = 0;
    bench::timed(r, [&] {
      const align3d::KdTree tree(target.positions, a.threads);
      undefined = align3d::estimate_normals(target, tree, ns).undefined;
    });
    double sum_abs_z = 0;
    for (const auto& n : target.normals) sum_abs_z += std::abs(n.z());
    r.extra["normals_mean_abs_z"] =
        bench::json_number(sum_abs_z / static_cast<double>(target.size()));
    r.extra["normals_undefined"] = std::to_string(undefined);
    return r;
  }

  if (a.task == "global") {
    align3d::GlobalSettings gs;
    gs.method = align3d::GlobalMethod::kFpfh;
    gs.voxel = a.voxel;
    gs.threads = a.threads;
    gs.seed = 1;
    align3d::GlobalResult g;
    bench::timed(r, [&] { g = align3d::global_register(source, target, gs); });
    r.transformation = to_matrix4(g.T_target_source);
    r.extra["success"] = g.success ? "true" : "false";
    r.extra["hypotheses"] = std::to_string(g.candidates);
    r.extra["voxel"] = bench::json_number(g.voxel);
    evaluate(source, target, g.T_target_source, a.max_distance, r);
    return r;
  }

  if (automatic) {
    align3d::AlignSettings as;
    as.initial_pose = init;
    as.refine.normals.k = a.k;
    as.threads = a.threads;
    align3d::AlignResult result;
    bench::timed(r, [&] { result = align3d::align(source, target, as); });
    r.iterations = result.refine.total_iterations;
    r.transformation = to_matrix4(result.transformation);
    r.extra["path"] = bench::json_string(result.path);
    r.extra["stop"] = bench::json_string(align3d::to_string(result.refine.icp.stop_reason));
    evaluate(source, target, result.transformation, a.max_distance, r);
    return r;
  }
  align3d::RefineSettings rs;
  rs.method =
      a.task == "icp-point" ? align3d::IcpMethod::kPointToPoint : align3d::IcpMethod::kPointToPlane;
  rs.rejection = align3d::RejectionRule::max_distance(a.max_distance);
  rs.termination.max_iterations = a.max_iterations;
  rs.termination.rms_change = 1e-6;
  rs.normals.k = a.k;
  rs.threads = a.threads;
  align3d::RefineResult result;
  bench::timed(r, [&] {
    if (all_normals && rs.method == align3d::IcpMethod::kPointToPlane) {
      align3d::NormalSettings ns = rs.normals;
      ns.threads = a.threads;
      align3d::estimate_normals(target, ns);  // then refine uses them as given
    }
    result = align3d::refine(source, target, init, rs);
  });
  r.iterations = result.total_iterations;
  r.transformation = to_matrix4(result.icp.T_target_source);
  r.extra["converged"] = result.icp.converged ? "true" : "false";
  r.extra["stop"] = bench::json_string(align3d::to_string(result.icp.stop_reason));
  evaluate(source, target, result.icp.T_target_source, a.max_distance, r);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  return bench::runner_main(argc, argv, "align3d", run, {"--auto", "--all-normals"});
}
