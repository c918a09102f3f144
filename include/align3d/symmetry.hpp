// Symmetries of a rigid part, which make several poses equally right: a turned part (a flange, a
// bushing) looks the same after any turn about its axis (continuous), a square plate after a
// quarter turn (discrete, 4-fold). `align3d find` reports each instance once, in a canonical pose.
//
// Detection: the model's points (with normals) are turned about candidate axes, its principal
// axes through its centroid, each first refined by aligning the model turned a quarter turn back
// onto itself (ICP; kept only when that turn fits). The part is symmetric about an axis when the
// turned points lie within `tolerance` of the model's surface on average (the distance to the
// tangent plane of the nearest model point, or to that point when it is farther than 1.5 point
// spacings). Continuous: seven unrelated angles all pass; else discrete of order n (the largest n
// in 2..12 whose turn by 360°/n passes). One axis is reported: the first continuous one, else the
// one of highest order.
//
// Canonical pose: of the equivalent poses T·R(θ) (R a turn about the axis), the one whose
// reference direction (`reference`, a fixed unit vector normal to the symmetry axis) turns
// closest to the scene frame's +x axis projected onto the plane normal to the mapped axis; for
// discrete symmetry θ is a multiple of 360°/n. So two poses of one part differ only by what the
// symmetry cannot tell.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d {

struct Symmetry {
  enum class Kind { kNone, kDiscrete, kContinuous };
  Kind kind = Kind::kNone;
  int order = 1;                                         // discrete: n-fold
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();       // model frame, unit
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();      // a point on the axis (model frame)
  Eigen::Vector3d reference = Eigen::Vector3d::UnitX();  // unit, normal to axis

  // "none", "continuous about z (0, 0, 1)", "4-fold about (0.707, 0.707, 0)"
  std::string name() const;
  // The turn about the axis by `angle` radians, as a rigid move of the model frame.
  Eigen::Isometry3d turn(double angle) const;
};

// The symmetry of the model points (see above); tolerance in data units.
Symmetry detect_symmetry(const PointCloud& model, double tolerance, int threads = 0);

// The declared symmetry "none", "x", "y", "z" (continuous about that model axis through the
// points' centroid) or "z:4" (n-fold); std::invalid_argument naming the text otherwise.
Symmetry parse_symmetry(const std::string& text, const PointCloud& model);

// The canonical one of the poses T·turn(θ) (see above).
Eigen::Isometry3d canonical_pose(const Eigen::Isometry3d& T_scene_model, const Symmetry& symmetry);

}  // namespace align3d
