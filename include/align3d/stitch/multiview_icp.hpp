// Multi-view ICP: every scan against its neighbours at once, all poses solved together (the
// last step of stitch.hpp), so that a loop's residual is spread over all its scans instead of
// being left on the edges a pose graph could not see inside.
//
// Each iteration pairs, for every link (a, b) and both ways, the sampled points of one scan with
// their nearest point of the other (in node 0's frame at the current poses) within `max_distance`,
// (a partner whose normal differs by more than 45° is on another face: no pair), the pair's cost
// one of the ICP layer's (icp/factors.hpp; point-to-plane by default, with the other's normal),
// written for both poses moving, weighted by a robust kernel of its point-to-plane distance
// (Geman-McClure of scale max_distance / 2 by default); the Gauss-Newton step of all poses (left
// updates about the scans' common centroid; node 0 held fixed) is one dense 6N × 6N solve. A
// link's sums are kept from the iteration before while neither of its scans has moved by the
// tolerance since they were taken: once most scans have settled, only the links of those still
// moving are paired again; and a link remembers which sampled points lay within twice
// max_distance of the other scan, each with its partner, and searches only those (each from its
// partner's distance) until the poses have drifted by max_distance: the same pairs, fewer and
// shorter searches. It stops when every scan has settled (moved by less than the tolerance)
// but those that slide: moved by the tolerance in each of the last ten iterations, the last step
// at least half the one five before (a right scan's creep shrinks faster).
// Written here rather than with Ceres:
// the pairs are found again at every iteration, and the normal equations are LinearSystem6's sums
// (icp/factors.hpp) laid out in blocks, a few hundred unknowns at most.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "align3d/icp/factors.hpp"
#include "align3d/icp/kernels.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

struct MultiviewScan {
  const PointCloud* cloud = nullptr;  // its own frame, with normals
  const KdTree* tree = nullptr;       // indexes *cloud
  std::vector<std::uint32_t> sample;  // the points it pairs with its neighbours
};

struct MultiviewSettings {
  double max_distance = 1;  // data units
  int max_iterations = 30;
  // Stop when no pose moves by more than this (rotation in radians times `length`, plus
  // translation, in data units).
  double tolerance = 1e-6;
  double length = 1;  // the object's size, for the rotation part of the tolerance
  IcpMethod method = IcpMethod::kPointToPlane;
  RobustKernel kernel = RobustKernel::kGemanMcClure;
  double kernel_scale = 0;  // data units; 0: max_distance / 2
  int threads = 0;
};

struct MultiviewPairs {
  std::size_t count = 0;
  std::vector<double> distances;  // |point-to-plane| of each pair, unweighted
};

struct MultiviewResult {
  std::vector<Eigen::Isometry3d> poses;
  int iterations = 0;
  // How far each pose moved in the last iteration (the tolerance's units): at or above the
  // tolerance when that scan had not settled (the iterations ran out, or it kept sliding while
  // the others settled: multiview_icp.cpp's kRestlessIterations).
  std::vector<double> last_step;
  // Per scan, its sampled points' pairs in the final poses (point-to-plane distances).
  std::vector<MultiviewPairs> residuals;
};

// One pair's terms: x_a = T_a·p and x_b = T_b·q in node 0's frame, n_a and n_b their scans'
// normals turned likewise. The residual e (its first `rows` entries: 1 for point-to-plane,
// n_b·(x_a − x_b), and symmetric, (n_a + n_b)·(x_a − x_b); 3 for point-to-point and GICP,
// x_a − x_b, weighed by M: I, or GICP's (C(n_a) + C(n_b))⁻¹ held over the step), and its
// Jacobians for left updates of each pose about `centre`, x ← x + ω × (x − c) + v, the normals
// turning with their scan.
struct MultiviewPairTerms {
  int rows = 1;
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 3, 6> ja = Eigen::Matrix<double, 3, 6>::Zero();
  Eigen::Matrix<double, 3, 6> jb = Eigen::Matrix<double, 3, 6>::Zero();
  Eigen::Matrix3d M = Eigen::Matrix3d::Identity();
};
MultiviewPairTerms multiview_pair_terms(IcpMethod method, const Eigen::Vector3d& xa,
                                        const Eigen::Vector3d& xb, const Eigen::Vector3d& na,
                                        const Eigen::Vector3d& nb, const Eigen::Vector3d& centre);

// `poses[k]` maps scan k into node 0's frame; `links` are pairs of scan indices (each once).
// Scans in no link keep their pose.
MultiviewResult multiview_icp(const std::vector<MultiviewScan>& scans,
                              const std::vector<std::pair<std::size_t, std::size_t>>& links,
                              std::vector<Eigen::Isometry3d> poses,
                              const MultiviewSettings& settings);

}  // namespace align3d
