#include "align3d/symmetry.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

#include "align3d/cloud_stats.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/kdtree.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr int kMaxOrder = 12;
// Turns a continuous symmetry must survive: unrelated to every n-fold turn up to kMaxOrder.
constexpr std::array<double, 7> kContinuousTestDeg = {23, 41, 67, 97, 131, 163, 211};

// Mean distance of the turned points to the model's surface: to the tangent plane of the nearest
// model point when that lies within `near` (so the sampling's own spacing does not count), else
// to the point itself (a point turned off the surface, maybe onto a plane's extension).
double turned_misfit(const PointCloud& model, const KdTree& tree, const Eigen::Isometry3d& turn,
                     double near, int threads) {
  std::vector<double> d(model.size());
  parallel_for(model.size(), threads, [&](std::size_t i) {
    const Eigen::Vector3d p = turn * model.positions[i];
    Neighbor nn;
    tree.nearest(p, nn);
    const Eigen::Vector3d off = p - model.positions[nn.index];
    const double plane = model.has_normals() ? std::abs(model.normals[nn.index].dot(off)) : 0;
    d[i] = model.has_normals() && off.norm() <= near ? plane : off.norm();
  });
  double sum = 0;
  for (double x : d) sum += x;  // in order: the same sum at any thread count
  return sum / static_cast<double>(d.size());
}

// Refines a candidate axis (through `centre`): the model turned by kRefineDeg about it is aligned
// back onto the model by point-to-plane ICP; when that correction is small and the composed move
// (a turn about the better axis) lays the model onto itself within `tolerance`, the candidate
// takes that axis. Parts whose symmetry has no quarter turn keep the principal axis.
constexpr double kRefineDeg = 90;
void refine_axis(const PointCloud& model, const KdTree& tree, double near, double tolerance,
                 int threads, Eigen::Vector3d& axis, Eigen::Vector3d& centre) {
  if (!model.has_normals()) return;
  Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
  turn.linear() = Eigen::AngleAxisd(kRefineDeg * std::numbers::pi / 180, axis).toRotationMatrix();
  turn.translation() = centre - turn.linear() * centre;
  IcpSettings s;
  s.rejection = RejectionRule::max_distance(2 * near);
  s.termination.max_iterations = 30;
  s.threads = threads;
  const Eigen::Isometry3d T = icp(model, model, tree, turn, s).T_target_source;
  const Eigen::AngleAxisd aa(T.linear());
  const double angle_change = std::abs(aa.angle() - kRefineDeg * std::numbers::pi / 180);
  if (angle_change > 10 * std::numbers::pi / 180 ||
      aa.axis().dot(axis) < std::cos(10 * std::numbers::pi / 180) ||
      turned_misfit(model, tree, T, near, threads) > tolerance)
    return;
  axis = aa.axis().normalized();
  // A point on the axis: (I − R)·x = t in the plane normal to the axis. I − R is singular along
  // the axis a only (R·a = a), so I − R + a·aᵀ is invertible, and its solution x satisfies
  // (I − R)·x = t's component in the plane (both sides of its equation dotted with a give a·x =
  // a·t, since aᵀ(I − R) = 0). A closed-form 3 × 3 inverse: a least-squares decomposition finds a
  // point of the same axis but was half of this file's compile time.
  const Eigen::Matrix3d A = Eigen::Matrix3d::Identity() - T.linear() + axis * axis.transpose();
  const Eigen::Vector3d x = A.inverse() * T.translation();
  centre = x + axis * axis.dot(centre - x);
}

Symmetry about(const Eigen::Vector3d& axis, const Eigen::Vector3d& centre, int order) {
  Symmetry s;
  s.kind = order == 0 ? Symmetry::Kind::kContinuous : Symmetry::Kind::kDiscrete;
  s.order = order == 0 ? 1 : order;
  s.axis = axis.normalized();
  s.centre = centre;
  s.reference = s.axis.unitOrthogonal();
  return s;
}

std::string vector_text(const Eigen::Vector3d& v) {
  char text[96];
  std::snprintf(text, sizeof text, "(%.3g, %.3g, %.3g)", v.x() == 0 ? 0.0 : v.x(),
                v.y() == 0 ? 0.0 : v.y(), v.z() == 0 ? 0.0 : v.z());
  return text;
}

}  // namespace

std::string Symmetry::name() const {
  if (kind == Kind::kNone) return "none";
  const std::string where = "about " + vector_text(axis) + " through " + vector_text(centre);
  if (kind == Kind::kContinuous) return "continuous " + where;
  return std::to_string(order) + "-fold " + where;
}

Eigen::Isometry3d Symmetry::turn(double angle) const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  T.translation() = centre - T.linear() * centre;
  return T;
}

Symmetry detect_symmetry(const PointCloud& model, double tolerance, int threads) {
  if (model.size() < 3) return {};
  const KdTree tree(model.positions, threads);
  const double near = 1.5 * point_spacing(model, tree);
  const Eigen::Vector3d c = centroid(model);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : model.positions) cov.noalias() += (p - c) * (p - c).transpose();
  const Eigen::Matrix3d axes = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors();
  Symmetry best;
  for (int a = 0; a < 3; ++a) {
    Eigen::Vector3d axis = axes.col(a);
    Eigen::Vector3d centre = c;
    // The axis from principal components of a sampled surface is off by a little (enough to move
    // the far side of a turned part by a voxel): refined first by aligning the model turned by a
    // test angle back onto itself (ICP); the composed turn's axis is the refined one.
    refine_axis(model, tree, near, tolerance, threads, axis, centre);
    const auto passes = [&](double angle) {
      return turned_misfit(model, tree, about(axis, centre, 0).turn(angle), near, threads) <=
             tolerance;
    };
    bool continuous = true;
    for (double deg : kContinuousTestDeg)
      continuous = continuous && passes(deg * std::numbers::pi / 180);
    if (continuous) return about(axis, centre, 0);  // nothing ranks above a continuous symmetry
    for (int n = kMaxOrder; n >= 2 && n > best.order; --n)
      if (passes(2 * std::numbers::pi / n)) {
        best = about(axis, centre, n);
        break;
      }
  }
  return best;
}

Symmetry parse_symmetry(const std::string& text, const PointCloud& model) {
  if (text == "none") return {};
  const auto bad = [&] {
    return std::invalid_argument("symmetry '" + text +
                                 "': expected none, x, y or z (continuous about that model axis "
                                 "through the centroid), or AXIS:N for N-fold (2 to 12)");
  };
  if (text.empty() || text.find_first_of("xyz") != 0) throw bad();
  int order = 0;
  if (text.size() > 1) {
    if (text[1] != ':') throw bad();
    try {
      std::size_t used = 0;
      order = std::stoi(text.substr(2), &used);
      if (used != text.size() - 2) throw bad();
    } catch (const std::logic_error&) {
      throw bad();
    }
    if (order < 2 || order > kMaxOrder) throw bad();
  }
  const Eigen::Vector3d c = model.empty() ? Eigen::Vector3d::Zero() : centroid(model);
  return about(Eigen::Vector3d::Unit(text[0] - 'x'), c, order);
}

Eigen::Isometry3d canonical_pose(const Eigen::Isometry3d& T_scene_model, const Symmetry& symmetry) {
  if (symmetry.kind == Symmetry::Kind::kNone) return T_scene_model;
  const Eigen::Matrix3d& R = T_scene_model.linear();
  const Eigen::Vector3d A = R * symmetry.axis;
  // The target direction: the scene's x (or y, when x lies along the axis) normal to the axis.
  Eigen::Vector3d X = Eigen::Vector3d::UnitX() - A.x() * A;
  if (X.norm() < 0.3) X = Eigen::Vector3d::UnitY() - A.y() * A;
  const Eigen::Vector3d E = R * symmetry.reference, F = R * symmetry.axis.cross(symmetry.reference);
  double angle = std::atan2(X.dot(F), X.dot(E));  // turn of the reference onto X
  if (symmetry.kind == Symmetry::Kind::kDiscrete) {
    const double step = 2 * std::numbers::pi / symmetry.order;
    angle = step * std::round(angle / step);
  }
  return T_scene_model * symmetry.turn(angle);
}

}  // namespace align3d
