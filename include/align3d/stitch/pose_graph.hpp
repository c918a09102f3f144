// The pose graph of a multi-view stitch: scans are nodes, pairwise registrations are edges, and
// every pose is optimised at once (Ceres Solver, Levenberg-Marquardt on SE(3) with a quaternion
// manifold), node 0 held fixed.
//
// Node k's pose X_k maps scan k into node 0's frame. An edge (s, t, T) says target ≈ T·source,
// i.e. X_s ≈ X_t·T; its error E = X_t⁻¹·X_s·T⁻¹ (the identity when they agree) is taken as the
// twist (ω, v) of a left update in the target's frame, the frame the edge's information matrix
// is expressed in (icp/information.hpp), and costs (ω, v)ᵀ·Ω·(ω, v).
//
// Robustness (a wrong pairwise result must not bend the model):
//   - start: poses chained along a maximum spanning tree of the edges by `weight` (their overlap),
//     from node 0;
//   - a least-squares solve, then one with a Cauchy loss on each edge whose knee lies where the
//     edge's pairs move by `robust_distance` on average (Ω·σ² / pairs is the mean squared
//     displacement per pair: the loss is geometric whatever the edge's point count and noise);
//   - pruning: the edge that disagrees most with the optimised graph, when its rotation residual
//     exceeds prune_rotation_deg or its translation residual (at the centroid of its pairs)
//     exceeds prune_translation, is dropped and the graph started again from a spanning tree of
//     the rest; until no edge is out.
// An edge whose removal disconnects its scan (a bridge) cannot be checked by the rest: the caller
// warns. Nodes no edge reaches from node 0 are not connected; their poses are the identity.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "align3d/se3.hpp"

namespace align3d {

struct PoseGraphEdge {
  std::size_t source = 0, target = 0;
  Eigen::Isometry3d transformation = Eigen::Isometry3d::Identity();  // target ≈ T·source
  Matrix6d information = Matrix6d::Identity();
  std::size_t pairs = 1;                               // the pairs the information was summed over
  double sigma = 1;                                    // their RMS residual
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  // of the pairs, target frame
  double weight = 1;                                   // spanning tree preference (overlap)
};

struct PoseGraphSettings {
  double robust_distance = 1;  // data units
  double prune_rotation_deg = 1;
  double prune_translation = 1;  // data units
  int max_iterations = 100;      // of each Ceres solve
};

struct PoseGraphResult {
  std::vector<Eigen::Isometry3d> poses;  // X_k: node 0 ≈ X_k·node k
  std::vector<bool> connected;           // reached from node 0 through kept edges
  std::vector<bool> kept;                // per edge
  // Per edge, against the final poses: the rotation angle (degrees) of E and the distance E moves
  // the centroid of its pairs.
  std::vector<double> rotation_residual_deg, translation_residual;
  int solves = 0;
};

// How far poses X_s, X_t disagree with an edge's transformation T: the rotation angle (degrees)
// of E = X_t⁻¹·X_s·T⁻¹ and the distance E moves `centroid` (target frame).
struct EdgeResidual {
  double rotation_deg = 0, translation = 0;
};
EdgeResidual edge_residual(const Eigen::Isometry3d& T, const Eigen::Vector3d& centroid,
                           const Eigen::Isometry3d& X_source, const Eigen::Isometry3d& X_target);

// Throws std::invalid_argument for an edge naming a node ≥ nodes, a self edge or a non-finite
// transformation or information.
PoseGraphResult optimize_pose_graph(std::size_t nodes, const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphSettings& settings);

}  // namespace align3d
