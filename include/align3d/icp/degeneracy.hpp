// Directions of the pose that the data does not constrain (a single plane leaves two translations
// and one rotation free, a cylinder its axis and the turn about it), and a solve that does not move
// along them (after Zhang, Kaess and Singh 2016, "On degeneracy of optimization-based state
// estimation": the update is zeroed along the free eigenvectors).
//
// The 6×6 point-to-plane system H = Σ w JᵀJ (unknowns ω, v about the target centroid) mixes radians
// and data units, so it is made dimensionless first: ω is scaled by L, L² = tr(H_ωω) / tr(H_vv)
// (the pairs' RMS lever arm, from H itself). An eigenvalue alone cannot tell a free direction from
// a weakly held one: on a noisy plane the noise in the normals gives the free directions ~1e-4 of
// the largest eigenvalue, the same as a small part on a wide plane gives its real ones. What
// differs is who holds the direction: a few pairs that each constrain it strongly (the part's side
// faces), or every pair a little (noise). So a candidate direction (eigenvalue below
// kCandidateRatio × the largest) is free unless at least kSupportShare of its eigenvalue comes from
// pairs whose scaled Jacobian lies within acos(kAlignedCosine) ≈ 84° of it.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "align3d/se3.hpp"

namespace align3d {

constexpr double kCandidateRatio = 1e-2;
constexpr double kAlignedCosine = 0.1;
constexpr double kSupportShare = 0.5;

struct SystemAnalysis {
  Vector6d scale = Vector6d::Ones();        // x = scale ⊙ y, y the dimensionless unknowns
  Matrix6d vectors = Matrix6d::Identity();  // eigenvectors of the scaled system (columns)
  Vector6d values = Vector6d::Zero();       // its eigenvalues, ascending
  bool usable = false;                      // false: H zero or not finite
  bool candidate(int i) const { return !usable || values(i) < kCandidateRatio * values(5); }
};
SystemAnalysis analyse_system(const Matrix6d& H);

struct WeakDirection {
  Eigen::Vector3d rotation;     // ω part of the unit eigenvector (scaled by L: dimensionless)
  Eigen::Vector3d translation;  // v part; rotation² + translation² = 1
  double strength = 0;          // eigenvalue ÷ largest eigenvalue
};

struct ConstrainedSolve {
  Vector6d x = Vector6d::Zero();    // the update (ω, v), zero along the free directions
  std::vector<WeakDirection> weak;  // the free directions, weakest first
};

// Solves H·x = rhs without moving along free directions. aligned(i) = Σ w (J_s·v_i)² over the pairs
// with |J_s·v_i| ≥ kAlignedCosine·|J_s| (J_s = scale ⊙ J, v_i eigenvector i; the ICP loop sums it
// for the candidates, other entries are not read). A zero or non-finite H gives x = 0, all six
// free.
ConstrainedSolve solve_constrained(const SystemAnalysis& a, const Vector6d& rhs,
                                   const Vector6d& aligned);

}  // namespace align3d
