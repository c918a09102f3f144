// Registration of a source cloud onto a target: the public entry point behind `align3d register`.
//
// With a fixed rejection rule this is one ICP run (chapter 39.1-39.4). With the default `auto`
// rejection it is a coarse-to-fine schedule that does not let the dominant plane of a conveyor
// scene capture the estimate (the failure of the median rule on such scenes):
//   1. scales from the data: L = target bounding-box diagonal, s = target point spacing (median
//      nearest-neighbour distance), so the same data in mm or m behaves the same;
//   2. point-to-plane ICP with a maximum correspondence distance τ that starts at L/8 and halves
//      each time a stage has settled, pairs weighted by a Geman-McClure kernel of scale τ/2, so far
//      pairs (outliers, the intruder wall) pull little while the distinctive structure (box, cap)
//      stays in reach long enough to fix x, y and yaw;
//   3. once τ is down to 3 s, the requested metric runs to convergence with τ = max(3 s, 4 σ̂)
//      (σ̂: the point-to-plane RMS of the last stage, i.e. the noise), still weighted.
// On large clouds the coarse stages of step 2 use an even thinning of the source to at most 50 000
// points (every m-th point along a Morton curve); the final stage uses every point.
// Target normals are used for `auto` whatever the final metric. Measured on the conveyor
// variants and partial object views of tests/registration_test.cpp; the point-to-point coarse
// stages we tried first slid along the plane toward the intruder wall on the wide-plane variant.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "align3d/icp/icp.hpp"
#include "align3d/normals.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

struct RegistrationSettings {
  IcpMethod method = IcpMethod::kPointToPlane;  // the final metric
  std::optional<RejectionRule> rejection;       // empty: `auto`, the schedule above
  // The cap on ICP iterations: for a fixed rule, of the single run; for `auto`, of the final stage
  // (the coarse stages have their own cap of 30 each).
  int max_iterations = 60;
  double tolerance = 1e-5;          // |ΔRMS| / RMS below which a run has converged
  bool tolerance_relative = true;   // false: |ΔRMS| < tolerance in data units (the chapter's rule)
  bool transform_criterion = true;  // also stop when the update is negligible (termination.hpp)
  NormalSettings normals;           // for target normals when point-to-plane needs them
  int threads = 0;
};

struct StageRecord {
  std::string metric;       // "point-to-point" or "point-to-plane"
  double max_distance = 0;  // τ of the stage (infinity for none, per-iteration for median)
  int first_iteration = 0;  // index into the combined history of the stage's first evaluation
                            // (a stage has iterations + 1 records: its start pose, then one per
                            // update)
  int iterations = 0;
};

struct RegistrationResult {
  IcpResult icp;                         // the final stage; T_target_source is the answer
  std::vector<IterationRecord> history;  // every iteration of every stage, in order
  std::vector<StageRecord> stages;
  int total_iterations = 0;
  double point_spacing = 0;  // the target spacing s used for `auto` (0 otherwise)
  // Target normals estimated here when the target has none: only where pairs needed them
  // (normals.hpp, NormalCache), and of those, the neighbourhoods with no plane.
  std::size_t estimated_normals = 0;
  std::size_t undefined_normals = 0;
};

// Throws DataError when a cloud has too few points (fewer than 6, or fewer than the normal
// neighbourhood for point-to-plane) or is degenerate (all points on one line or at one spot).
RegistrationResult register_clouds(const PointCloud& source, const PointCloud& target,
                                   const Eigen::Isometry3d& init,
                                   const RegistrationSettings& settings = {});

// Checks a cloud can take part in registration (see above); `what` names it in the message.
void check_registrable(const PointCloud& cloud, const std::string& what);

// Median nearest-neighbour distance between distinct points of `cloud` (on at most `samples`
// evenly spaced points): the point spacing. 0 for fewer than 2 points.
double point_spacing(const PointCloud& cloud, const KdTree& tree, std::size_t samples = 2000);

}  // namespace align3d
