// Step 2 of a stitch (stitch.hpp): one pose per scan from the pairs' candidates (several a pair,
// stitch/pair_candidates.hpp), chosen for the whole set at once. Internal to the engine.
//
// The scans are joined into groups (Kruskal), each join by one candidate, in order of support:
//   - a candidate (i, j, T) is supported by each third scan k through which candidates of (i, k)
//     and (k, j) compose to T (within kAgreeDeg and kAgreeShare of the object's diameter): the
//     smaller of their scores, the best such path per k, summed over k. Right poses close loops
//     with each other; a wrong turn of a look-alike face rarely closes one. Candidates are taken
//     by support plus their own score;
//   - a join must not make any scan of one group contradict any scan of the other (free space,
//     stitch/views.hpp, facing points, more than kMaxJoinFreeSpace): two pairs' candidates may
//     each be self-consistent and still put two scans through each other (a box's side views
//     turned by a half, each fitting its neighbour), and only scans no candidate joins show it.
// Then each scan moves to another placement its candidates give it when, refined on the other
// scans of its group, that covers clearly more of it (its points on their surfaces at the noise)
// and contradicts none of them: a near-symmetric view turned onto a look-alike face can fit one
// neighbour better than the truth fits two, but its asymmetric details lie on no surface. Then a
// part of the group (one scan or several) moves as one by a motion more candidates, from more
// scans, give it across its cut than agree with where it lies, when that contradicts no other
// scan and lays it on their surfaces as well or clears a contradiction: each scan of a part can
// be placed by its own wrong pair, the part no branch of the joins' tree.
// Last, the scans whose placement other candidates contest are named (Selection::ambiguous), alone
// or as a part of the group turned as a whole.
// The first scan's group gives the frame; scans no accepted join reaches stay apart.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "stitch/pair_candidates.hpp"
#include "stitch/views.hpp"

namespace align3d::detail {

struct Selection {
  std::vector<Eigen::Isometry3d> poses;  // scan k into the frame of its group's first scan
  std::vector<std::size_t> group;        // the first (smallest) scan of k's group
  // Per candidate: whether it agrees with the chosen poses (its scans in one group, its pose
  // within kAgreeDeg and kAgreeShare of theirs): the edges the pose graph refines.
  std::vector<bool> agrees;
  // Scans an alternative choice places elsewhere (by more than kAgreeDeg or kAgreeShare of the
  // diameter, relative to the first scan) while explaining nearly as many candidates (at least
  // kAmbiguousShare of the chosen score) and covering nearly as much of the scan (within
  // kCoverGain), or explaining more, from as many other scans (two or more), whatever it covers;
  // and the scans of a part of the group (beyond one join of the tree that joined it, or that
  // candidates would move as one) that candidates across its cut place elsewhere as a whole, as
  // strongly, or nearly and contradicting nothing and covering as much: the data do not decide
  // their poses. Ascending.
  std::vector<std::size_t> ambiguous;
  double score = 0;  // Σ score of the candidates that agree with the chosen poses
};

Selection select_poses(const std::vector<PairCandidate>& candidates,
                       const std::vector<ScanData>& scans, const std::vector<DepthMap>& maps,
                       const std::vector<PairSearchScan>& search, double diameter, double voxel,
                       int threads);

}  // namespace align3d::detail
