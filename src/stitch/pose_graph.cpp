// Ceres does the optimisation (Debian's libceres-dev): sparse Levenberg-Marquardt, a quaternion
// manifold and robust losses are what a pose graph needs, and none of it is worth writing again.
#include "align3d/stitch/pose_graph.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

namespace align3d {

namespace {

// (ω, v) of E = X_t⁻¹·X_s·T⁻¹, weighted: Lᵀ·(ω, v) with Ω = L·Lᵀ.
struct EdgeCost {
  Eigen::Quaterniond r_inv;  // of T⁻¹
  Eigen::Vector3d t_inv;
  Matrix6d sqrt_information_t;  // Lᵀ

  template <class S>
  bool operator()(const S* q_source, const S* t_source, const S* q_target, const S* t_target,
                  S* residual) const {
    using Vec3 = Eigen::Matrix<S, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<S>> qs(q_source), qt(q_target);
    const Eigen::Map<const Vec3> ts(t_source), tt(t_target);
    const Eigen::Quaternion<S> q_ts = qt.conjugate() * qs;
    const Vec3 t_ts = qt.conjugate() * (ts - tt);
    const Eigen::Quaternion<S> q_e = q_ts * r_inv.cast<S>();
    const Vec3 t_e = q_ts * t_inv.cast<S>() + t_ts;
    const S wxyz[4] = {q_e.w(), q_e.x(), q_e.y(), q_e.z()};
    Eigen::Matrix<S, 6, 1> r;
    ceres::QuaternionToAngleAxis(wxyz, r.data());
    r.template tail<3>() = t_e;
    Eigen::Map<Eigen::Matrix<S, 6, 1>> weighted(residual);
    weighted = sqrt_information_t.cast<S>() * r;
    return true;
  }
};

void check_edges(std::size_t nodes, const std::vector<PoseGraphEdge>& edges) {
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    const std::string name = "optimize_pose_graph: edge " + std::to_string(e);
    if (edge.source >= nodes || edge.target >= nodes)
      throw std::invalid_argument(name + " names a node beyond " + std::to_string(nodes));
    if (edge.source == edge.target) throw std::invalid_argument(name + " joins a node to itself");
    if (!edge.transformation.matrix().allFinite() || !edge.information.allFinite() ||
        !std::isfinite(edge.sigma) || !(edge.sigma > 0) || edge.pairs == 0)
      throw std::invalid_argument(name + " has a non-finite pose or information");
  }
}

// Poses chained from node 0 along a maximum spanning tree of the kept edges by weight (Prim);
// `connected` says which nodes it reached.
void spanning_tree_poses(std::size_t nodes, const std::vector<PoseGraphEdge>& edges,
                         const std::vector<bool>& kept, PoseGraphResult& out) {
  out.poses.assign(nodes, Eigen::Isometry3d::Identity());
  out.connected.assign(nodes, false);
  out.connected[0] = true;
  for (;;) {
    std::size_t best = edges.size();
    for (std::size_t e = 0; e < edges.size(); ++e) {
      if (!kept[e] || out.connected[edges[e].source] == out.connected[edges[e].target]) continue;
      if (best == edges.size() || edges[e].weight > edges[best].weight) best = e;
    }
    if (best == edges.size()) return;
    const PoseGraphEdge& edge = edges[best];
    if (out.connected[edge.target]) {
      out.poses[edge.source] = out.poses[edge.target] * edge.transformation;
      out.connected[edge.source] = true;
    } else {
      out.poses[edge.target] = out.poses[edge.source] * edge.transformation.inverse();
      out.connected[edge.target] = true;
    }
  }
}

// One Ceres solve over the connected nodes and kept edges, from out.poses; `robust` adds the
// Cauchy loss.
void solve(const std::vector<PoseGraphEdge>& edges, const std::vector<bool>& kept,
           const PoseGraphSettings& settings, bool robust, PoseGraphResult& out) {
  const std::size_t nodes = out.poses.size();
  std::vector<Eigen::Quaterniond> q(nodes);
  std::vector<Eigen::Vector3d> t(nodes);
  for (std::size_t k = 0; k < nodes; ++k) {
    q[k] = Eigen::Quaterniond(out.poses[k].rotation());
    t[k] = out.poses[k].translation();
  }
  ceres::Problem problem;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    if (!kept[e] || !out.connected[edge.source] || !out.connected[edge.target]) continue;
    // A tiny ridge keeps the Cholesky factor of a rank-deficient information (a plane) defined.
    const Matrix6d info =
        edge.information + 1e-12 * edge.information.trace() * Matrix6d::Identity();
    const Matrix6d L = info.llt().matrixL();
    auto* cost = new ceres::AutoDiffCostFunction<EdgeCost, 6, 4, 3, 4, 3>(new EdgeCost{
        Eigen::Quaterniond(edge.transformation.rotation()).conjugate(),
        -(edge.transformation.rotation().transpose() * edge.transformation.translation()),
        L.transpose()});
    const double knee =
        settings.robust_distance * std::sqrt(static_cast<double>(edge.pairs)) / edge.sigma;
    problem.AddResidualBlock(cost, robust ? new ceres::CauchyLoss(knee) : nullptr,
                             q[edge.source].coeffs().data(), t[edge.source].data(),
                             q[edge.target].coeffs().data(), t[edge.target].data());
  }
  for (std::size_t k = 0; k < nodes; ++k) {
    if (!problem.HasParameterBlock(q[k].coeffs().data())) continue;
    problem.SetManifold(q[k].coeffs().data(), new ceres::EigenQuaternionManifold);
  }
  if (!problem.HasParameterBlock(t[0].data())) return;  // node 0 has no edge
  problem.SetParameterBlockConstant(q[0].coeffs().data());
  problem.SetParameterBlockConstant(t[0].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = settings.max_iterations;
  options.num_threads = 1;  // small problems; one thread keeps the bits
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  for (std::size_t k = 0; k < nodes; ++k) {
    out.poses[k] = Eigen::Isometry3d::Identity();
    out.poses[k].linear() = q[k].normalized().toRotationMatrix();
    out.poses[k].translation() = t[k];
  }
  ++out.solves;
}

void measure_residuals(const std::vector<PoseGraphEdge>& edges, PoseGraphResult& out) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.rotation_residual_deg.assign(edges.size(), nan);
  out.translation_residual.assign(edges.size(), nan);
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    if (!out.connected[edge.source] || !out.connected[edge.target]) continue;
    const EdgeResidual r = edge_residual(edge.transformation, edge.centroid, out.poses[edge.source],
                                         out.poses[edge.target]);
    out.rotation_residual_deg[e] = r.rotation_deg;
    out.translation_residual[e] = r.translation;
  }
}

}  // namespace

EdgeResidual edge_residual(const Eigen::Isometry3d& T, const Eigen::Vector3d& centroid,
                           const Eigen::Isometry3d& X_source, const Eigen::Isometry3d& X_target) {
  const Eigen::Isometry3d E = X_target.inverse() * X_source * T.inverse();
  return {rad_to_deg(rotation_angle(E.linear())), (E * centroid - centroid).norm()};
}

PoseGraphResult optimize_pose_graph(std::size_t nodes, const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphSettings& settings) {
  if (nodes == 0) throw std::invalid_argument("optimize_pose_graph: no node");
  check_edges(nodes, edges);
  PoseGraphResult out;
  out.kept.assign(edges.size(), true);
  for (;;) {
    spanning_tree_poses(nodes, edges, out.kept, out);
    solve(edges, out.kept, settings, false, out);
    solve(edges, out.kept, settings, true, out);
    measure_residuals(edges, out);
    std::size_t worst = edges.size();
    double worst_ratio = 1;
    for (std::size_t e = 0; e < edges.size(); ++e) {
      if (!out.kept[e] || std::isnan(out.rotation_residual_deg[e])) continue;
      const double ratio = std::max(out.rotation_residual_deg[e] / settings.prune_rotation_deg,
                                    out.translation_residual[e] / settings.prune_translation);
      if (ratio > worst_ratio) worst = e, worst_ratio = ratio;
    }
    if (worst == edges.size()) return out;
    out.kept[worst] = false;
  }
}

}  // namespace align3d
