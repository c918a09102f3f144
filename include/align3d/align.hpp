// The pipeline: one call from two clouds to a pose, and the only place that assembles the stages
// (every command and the chapter's experiments call it). The stages remain callable on their own:
// global_register (coarse/global.hpp), refine (icp/refine.hpp), icp (icp/icp.hpp).
//
// Convention: the result maps SOURCE into TARGET's frame, target ≈ T·source (the measured scan is
// usually the source, the model the target). Units are the data's; every default distance follows
// the data (refine.hpp, global.hpp, support.hpp), so the same clouds in mm or m give the same pose.
//
// The initial pose (AlignSettings::init):
//   identity, pose  ICP (refine) from the identity or from initial_pose;
//   global          the global stage (fpfh or ppf), then ICP from its pose; no pose with enough
//                   support is no solution (success false);
//   auto (default)  ICP from initial_pose; when its answer is weak (support.hpp: overlap below
//                   kWeakOverlap; its fit at the noise, icp/fit.hpp, above kWeakFit; free
//                   directions (degeneracy.hpp), no convergence) or merely unconfirmed (overlap
//                   below kConfirmedOverlap, or a fit above kConfirmedFit: a partial view slid
//                   face on face, or turned by a quarter about a box-like part, can fit that
//                   well), the
//                   global stage runs too, ICP refines its pose, and the better supported of the
//                   two answers is kept: the global one only when its overlap is clearly larger
//                   (by kClearlyBetter). When it is not (or the global stage found nothing),
//                   the first ICP continues with step 3 of its schedule (refine.hpp: basin
//                   hopping, the GICP candidate; RefineSettings::resume), which it left out,
//                   and its answer is kept when clearly better than the first. Two distinct poses
//                   supported alike are ambiguous (a warning; the initial pose's answer is
//                   kept). `path` says which answer was kept, `reason` why the global stage ran.
// ICP direction: when the target is a point cloud, the source is the object and the target is
// much wider (its robust extent more than kReverseExtentRatio × the source's: a part registered
// into a scene), ICP runs the other way round, the target onto the source, and its answer is
// inverted: every scene point near the part then finds a partner on the part's whole surface, where
// the part's hidden faces would find only clutter and floor in the scene (measured on a generated
// depth-camera bin: 18° off the right way, 0.16° reversed). `reversed` says so; the refine fields
// then describe that run. A mesh target is never reversed: its surface is exact and has no clutter.
// Whatever the path, a result that may be wrong comes with warnings (never silently): ICP hit its
// iteration cap, free directions, weak overlap, residuals far above the noise, an ambiguous global
// pose, a global stage that found nothing in auto mode.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "align3d/coarse/global.hpp"
#include "align3d/coarse/ppf.hpp"
#include "align3d/icp/refine.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/prepared_target.hpp"
#include "align3d/progress.hpp"
#include "align3d/support.hpp"
#include "align3d/warning.hpp"

namespace align3d {

enum class InitPolicy { kIdentity, kPose, kGlobal, kAuto };
const char* to_string(InitPolicy p);

// Support below either bound makes an answer weak (see above).
constexpr double kWeakOverlap = 0.2;
constexpr double kConfirmedOverlap =
    0.5;  // kConfirmedFit, kWeakFit, kClearlyBetter: icp/refine.hpp
// ICP's next update longer than this many standard deviations of its covariance
// (IcpResult::pending_sigmas): it stopped short of its stationary point (warning stopped_short).
constexpr double kStoppedShortSigmas = 2.0;
constexpr double kReverseExtentRatio = 2.0;

struct AlignSettings {
  InitPolicy init = InitPolicy::kAuto;
  // The pose ICP starts from for kPose and kAuto (target ≈ T·source); identity: the clouds as
  // given.
  Eigen::Isometry3d initial_pose = Eigen::Isometry3d::Identity();
  RefineSettings refine;  // the ICP layer (its threads are replaced by `threads`)
  GlobalSettings global;  // the global stage (its threads and seed are replaced by these)
  // A model description of the TARGET built once (build_ppf_model / `align3d ppf-model`), used by
  // the global stage instead of building one (implies the ppf method). Not owned; may be null.
  const PpfModel* ppf_model = nullptr;
  int threads = 0;  // 0: all cores; the result does not depend on it
  std::uint64_t seed = 1;
  ProgressCallback progress;  // optional
};

// One answer considered by the auto policy, with its support.
struct AlignCandidate {
  std::string path;  // "initial" (ICP from the initial pose) or "global"
  Eigen::Isometry3d transformation = Eigen::Isometry3d::Identity();
  Support support;
  double rms = 0;
  FitEvidence fit;    // its ICP's fit at the noise (icp/fit.hpp)
  bool weak = false;  // has warnings (align.hpp)
};

// Wall time of align()'s steps. prepare_ms: the target's side (its tree, scale, sampling) unless
// a PreparedTarget holds it, and the source's tree and scale; total_ms: the whole call, prepare_ms
// included.
struct AlignTimings {
  double prepare_ms = 0, global_ms = 0, refine_ms = 0, support_ms = 0, total_ms = 0;
};

struct AlignResult {
  // false: no solution (the global stage found no pose with enough support under kGlobal, or ICP
  // kept too few pairs); `failure` says why, `transformation` is then the identity or the last
  // pose tried and must not be used.
  bool success = false;
  std::string failure;
  Eigen::Isometry3d transformation = Eigen::Isometry3d::Identity();  // target ≈ T·source
  std::string path;    // the answer kept: "initial" or "global"
  std::string reason;  // why the auto policy ran the global stage, or empty
  // ICP of the kept answer: history, stages, stop reason (of the reversed run, target onto source,
  // when `reversed`).
  RefineResult refine;
  bool reversed = false;
  // The 6×6 covariance of `transformation` (icp.hpp, IcpResult::covariance: the noise's part,
  // point-to-plane's model error, the step not taken): rotation (radians) then translation, for
  // T ← exp(ξ)·T about the target frame's origin (se3.hpp); carried over from the reversed run
  // when `reversed`. The accuracy of a correct convergence only: a wrong minimum is not covered
  // (the warnings are).
  Matrix6d covariance = Matrix6d::Zero();
  std::optional<GlobalResult> global;      // when the global stage ran
  Support support;                         // of the kept answer
  std::vector<AlignCandidate> candidates;  // every answer considered, in order
  std::vector<Warning> warnings;           // empty when clean
  AlignTimings timings;
};

// Throws DataError("source"/"target", …) for clouds that cannot be registered (a NaN or Inf
// coordinate, too few points, all on a line; refine.hpp, global.hpp) and std::invalid_argument,
// naming the field, for settings no run can use (an iteration cap below 1, a negative or
// non-finite tolerance or voxel, k below 3, negative threads, ...).
AlignResult align(const PointCloud& source, const PointCloud& target,
                  const AlignSettings& settings = {});
// The same onto a mesh (a CAD model): ICP pairs the source with the exact closest points of its
// triangles, the global stage and the support measure use an even sample of its surface
// (refine.hpp, RefineTarget); ICP always runs source onto mesh (never reversed). Throws
// DataError("target", …) for a mesh with nothing to measure (mesh_index.hpp).
AlignResult align(const PointCloud& source, const TriangleMesh& target,
                  const AlignSettings& settings = {});
// The same against a target prepared once for many sources (prepared_target.hpp): the same pose,
// to the bit. Throws std::invalid_argument when settings.refine.normals.k differs from the
// target's preparation.
AlignResult align(const PointCloud& source, const PreparedTarget& target,
                  const AlignSettings& settings = {});
// (A mesh PreparedTarget too: the same as align(source, mesh).)

}  // namespace align3d
