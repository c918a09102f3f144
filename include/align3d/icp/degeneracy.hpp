// Directions of the pose that the data does not constrain (a single plane leaves two translations
// and one rotation free, a cylinder its axis and the turn about it) and a solve that does not move
// along them (after Zhang, Kaess and Singh 2016, "On degeneracy of optimization-based state
// estimation", with damping instead of their hard cut so that weak but real structure, such as a
// small part on a large plane, still pulls the pose over the iterations).
//
// The 6×6 point-to-plane system H = Σ w JᵀJ (unknowns ω, v about the target centroid) mixes radians
// and data units, so it is first made dimensionless: ω is scaled by L, with L² = tr(H_ωω) /
// tr(H_vv) (the pairs' RMS lever arm, from H itself), so that a unit step in any direction moves
// the points about as much. A direction is weak when its eigenvalue of the scaled system is below
// kWeakRatio × the largest: on scanner data, normal noise alone leaves ~1e-4 along a plane, while a
// part's side faces holding a few percent of the points give ~1e-2.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "align3d/se3.hpp"

namespace align3d {

constexpr double kWeakRatio = 1e-3;

struct WeakDirection {
  Eigen::Vector3d rotation;     // ω part of the unit eigenvector (scaled by L: dimensionless)
  Eigen::Vector3d translation;  // v part; rotation² + translation² = 1
  double strength = 0;          // eigenvalue ÷ largest eigenvalue
};

struct ConstrainedSolve {
  Vector6d x = Vector6d::Zero();    // the update (ω, v), zero along the weak directions
  std::vector<WeakDirection> weak;  // weakest first
};

// Solves H·x = rhs, damped by μ = kWeakRatio × the largest eigenvalue of the scaled system, and
// lists the directions with an eigenvalue below μ. A zero or non-finite H gives x = 0 with all six
// directions weak.
ConstrainedSolve solve_constrained(const Matrix6d& H, const Vector6d& rhs);

}  // namespace align3d
