// Fast Point Feature Histograms (Rusu, Blodow and Beetz 2009, "Fast Point Feature Histograms
// (FPFH) for 3D registration"), as computed by PCL and Open3D.
//
// For a pair (p_s, n_s), (p_t, n_t) with d = p_t − p_s, the source of the Darboux frame is the
// point whose normal makes the smaller angle with the line (|n·d| larger); with u = n_s,
// v = d × u / |d × u| and w = u × v the pair feature is (PCL's computePairFeatures)
//   α = v·n_t,  φ = u·d / |d|,  θ = atan2(w·n_t, u·n_t),
// with θ = π (not −π) for exactly antiparallel normals.
// SPFH(p): for every neighbour within `radius`, θ, α and φ each add 100/(neighbours) to one of 11
// equal bins over [−π, π], [−1, 1] and [−1, 1] (so each 11-bin block sums to 100).
// FPFH(p) = SPFH(p) + Σ_k SPFH(p_k) / ‖p − p_k‖², each block of the sum rescaled to 100
// (Open3D's weighting: the paper's 1/k Σ (1/ω_k) with ω_k the squared distance, normalised).
//
// The features are invariant under rigid motions of the cloud *when the normals move with it*,
// sign included; orient_normals_consistently gives such a sign (see there).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "align3d/kdtree.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d {

using FpfhDescriptor = Eigen::Matrix<float, 33, 1>;  // bins: θ 0-10, α 11-21, φ 22-32 (as PCL)

struct FpfhSettings {
  double radius = 0;  // neighbourhood radius (data units, > 0); Open3D's usual choice: 5 voxels
  int max_neighbors = 100;  // closest neighbours kept per point (Open3D's hybrid search); 0: all
  int threads = 0;          // 0: all cores; the result does not depend on it
};

// Every point's neighbours within `radius` (itself included), closest first, at most
// max_neighbors + 1 of them (0: all). Computed once, shared by the orientation and the descriptors.
using Neighbourhoods = std::vector<std::vector<Neighbor>>;
Neighbourhoods radius_neighbourhoods(const PointCloud& cloud, const KdTree& tree, double radius,
                                     int max_neighbors, int threads = 0);

// One descriptor per point of `cloud`, which must have normals; `tree` must index
// cloud.positions. A point with no neighbour within the radius (other than coincident points) gets
// the zero descriptor. Throws std::invalid_argument without normals or with radius <= 0.
std::vector<FpfhDescriptor> compute_fpfh(const PointCloud& cloud, const KdTree& tree,
                                         const FpfhSettings& settings);
// The same on neighbourhoods from radius_neighbourhoods(cloud, tree, radius, max_neighbors).
std::vector<FpfhDescriptor> compute_fpfh(const PointCloud& cloud, const Neighbourhoods& neighbours,
                                         int threads = 0);

// Gives the normals signs that move with the cloud, as the descriptors need ("toward +Z" or a fixed
// viewpoint do not: a scan turned by 180° would get different features). Seeds: points whose
// neighbourhood centroid c lies clearly off the tangent plane, |n·(p − c)| >= 5 % of the
// neighbourhood's extent, point away from it (outward on convex parts). Every other point takes
// the sign agreeing with the neighbour it is reached from along a maximum spanning forest of
// |n_i·n_j| grown from the seeds over the 8 nearest neighbours (Hoppe et al. 1992), so a flat
// region inherits the sign of the structure next to it instead of a noise-decided one. Every
// step depends only on distances and angles: the result commutes with rigid motions (up to
// floating-point ties). Deterministic; `tree` indexes the positions; the neighbourhoods of
// `radius` are those compute_fpfh uses.
void orient_normals_consistently(PointCloud& cloud, const KdTree& tree, double radius,
                                 int threads = 0);
void orient_normals_consistently(PointCloud& cloud, const Neighbourhoods& neighbours,
                                 int threads = 0);

}  // namespace align3d
