#include "align3d/coarse/ppf.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "align3d/coarse/target_cache.hpp"
#include "align3d/error.hpp"
#include "align3d/icp/icp.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/voxel.hpp"
#include "detail/bucket_scatter.hpp"
#include "detail/fast_angle.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr std::size_t kMinPoints = 10;
constexpr std::size_t kMaxModelPoints = 1500;
constexpr int kNormalNeighbours = 15;
// A bucket with more pairs than this × the mean bucket size is a stop feature (header).
constexpr double kMaxBucketFactor = 20;
// The model's radix sort (build_ppf_model): bits of the key a pass.
constexpr int kKeyDigitBits = 11;
constexpr std::size_t kSceneReferenceStep = 5;  // every 5th scene point is a reference (Drost: 1/5)
constexpr std::size_t kPeaksPerReference = 3;
constexpr double kClusterRotationDeg = 12;
constexpr double kClusterVoxels = 2;  // cluster / distinctness radius of the moved scene centroid
constexpr std::size_t kVerifiedClusters = 10;
constexpr int kRefineIterations = 20;  // per verified cluster
constexpr int kFinalIterations = 40;   // more for the winner (a plane slides slowly)

// Throws DataError(what, …) unless `down` has enough points, not all on one line.
void check_usable(const PointCloud& down, const std::string& what, double voxel) {
  const std::string after = " after downsampling to voxel " + std::to_string(voxel);
  if (down.size() < kMinPoints)
    throw DataError(what, std::to_string(down.size()) + " points" + after +
                              "; ppf needs at least " + std::to_string(kMinPoints) +
                              " (a smaller voxel keeps more)");
  const Eigen::Vector3d c = centroid(down);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : down.positions) cov.noalias() += (p - c) * (p - c).transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();
  if (!(ev(1) > 1e-9 * ev(2))) throw DataError(what, "all points lie on a line" + after);
}

// How the PCA normals of a downsampled cloud are signed: away from its centroid (the header's
// rule), as the cloud's own normals (outward ones, of a model from its CAD), or toward a camera.
enum class Orient { kAwayFromCentroid, kAsGiven, kToward };

// Voxel centroids with PCA normals of kNormalNeighbours points, signed by `orient`.
PointCloud oriented_downsample(const PointCloud& cloud, double voxel, int threads,
                               const std::string& what, Orient orient = Orient::kAwayFromCentroid,
                               const Eigen::Vector3d& viewpoint = Eigen::Vector3d::Zero()) {
  PointCloud down = voxel_downsample(cloud, voxel);  // averages the cloud's normals per voxel
  const std::vector<Eigen::Vector3d> given = std::move(down.normals);
  down.normals.clear();
  check_usable(down, what, voxel);
  NormalSettings normal_settings;
  normal_settings.k = kNormalNeighbours;
  normal_settings.viewpoint = orient == Orient::kToward ? viewpoint : centroid(down);
  normal_settings.threads = threads;
  estimate_normals(down, normal_settings);  // toward the viewpoint or the centroid ...
  if (orient == Orient::kAwayFromCentroid) {
    for (auto& n : down.normals) n = -n;  // ... so away from it
  } else if (orient == Orient::kAsGiven) {
    for (std::size_t i = 0; i < down.size(); ++i)
      if (down.normals[i].dot(given[i]) < 0) down.normals[i] = -down.normals[i];
  }
  return down;
}

// F in bin units: ‖d‖ / voxel and the three angles / (π / bins). False for coincident points.
bool feature_values(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2,
                    const Eigen::Vector3d& n2, double voxel, std::uint32_t bins,
                    std::array<double, 4>& f) {
  Eigen::Vector3d d = p2 - p1;
  const double distance = d.norm();
  if (!(distance > 0)) return false;
  d /= distance;
  const double step = std::numbers::pi / bins;
  const auto angle = [&](double cosine) { return detail::fast_acos(cosine) / step; };
  f = {distance / voxel, angle(n1.dot(d)), angle(n2.dot(d)), angle(n1.dot(n2))};
  return true;
}

std::uint64_t compose_key(std::uint64_t distance_bin, std::uint64_t a1, std::uint64_t a2,
                          std::uint64_t a3, std::uint32_t bins) {
  return ((distance_bin * bins + a1) * bins + a2) * bins + a3;
}

// Quantised feature F (header). Returns false for coincident points.
bool feature_key(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2,
                 const Eigen::Vector3d& n2, double voxel, std::uint32_t bins, std::uint64_t& key) {
  std::array<double, 4> f;
  if (!feature_values(p1, n1, p2, n2, voxel, bins, f)) return false;
  const auto bin = [&](double v) {
    return std::min<std::uint64_t>(bins - 1, static_cast<std::uint64_t>(v));
  };
  key = compose_key(static_cast<std::uint64_t>(f[0]), bin(f[1]), bin(f[2]), bin(f[3]), bins);
  return true;
}

// T_g: the rigid move taking (p, n) to the origin and the +x axis (Drost, section 3.3).
Eigen::Isometry3d to_x_axis(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = shortest_arc(n, Eigen::Vector3d::UnitX());  // a half turn about ŷ for n = −x̂
  T.translation() = -(T.linear() * p);
  return T;
}

// The angle α with R_x(α)·(T_g·p) in the half-plane {z = 0, y > 0}.
double half_plane_angle(const Eigen::Isometry3d& T_g, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = T_g * p;
  return std::atan2(-q.z(), q.y());
}

struct Peak {
  std::uint32_t votes = 0;
  std::uint32_t cell = 0;  // model reference × angle_bins + α bin
};

struct Candidate {
  Eigen::Isometry3d T;
  double votes;
};

struct Cluster {
  Eigen::Quaterniond q_first;  // the cluster's strongest pose, which new members are compared to
  Eigen::Vector3d x_first;     // where that pose puts the scene centroid
  Eigen::Vector4d q_sum = Eigen::Vector4d::Zero();  // vote-weighted, sign-aligned quaternions
  Eigen::Vector3d x_sum = Eigen::Vector3d::Zero();
  double votes = 0;
};

// Point-to-point ICP (icp/icp.hpp) on the downsampled clouds, pairs closer than 2 voxels, until
// an update turns by less than 1e-7 rad and moves by less than 1e-7 voxel.
Eigen::Isometry3d refine(const PointCloud& source, const PointCloud& target, const KdTree& tree,
                         const Eigen::Isometry3d& T, double voxel, int iterations, int threads) {
  IcpSettings s;
  s.method = IcpMethod::kPointToPoint;
  s.rejection = RejectionRule::max_distance(kClusterVoxels * voxel);
  s.termination = {iterations, 0.0, false, 1e-7, 1e-7 * voxel / bounding_box_diagonal(target)};
  s.threads = threads;
  return icp(source, target, tree, T, s).T_target_source;
}

std::string percent(double share) {
  const long tenths = std::lround(share * 1000);
  return std::to_string(tenths / 10) + "." + std::to_string(tenths % 10) + " %";
}

// The kPeaksPerReference highest accumulator cells of one scene reference.
using Peaks = std::array<Peak, kPeaksPerReference>;

// Adds the votes of scene reference r (Drost, section 3.4): each scene pair (r, m) whose feature
// is in the model's table votes for every (model reference, α bin) cell stored under that key.
void accumulate_votes(const PpfModel& model, const PointCloud& down, const KdTree& scene_tree,
                      std::size_t r, std::vector<std::uint32_t>& votes) {
  thread_local std::vector<Neighbor> nb;
  const double voxel = model.voxel;
  const std::uint32_t bins = model.angle_bins;
  const double alpha_step = 2 * std::numbers::pi / bins;
  const double sq_diameter = model.diameter * model.diameter;
  const Eigen::Vector3d& p_r = down.positions[r];
  const Eigen::Vector3d& n_r = down.normals[r];
  const Eigen::Isometry3d T_s = to_x_axis(p_r, n_r);
  scene_tree.radius_unsorted(p_r, sq_diameter, nb);  // counts: the order does not matter
  for (const Neighbor& m : nb) {
    std::uint64_t key;
    if (m.index == r ||
        !feature_key(p_r, n_r, down.positions[m.index], down.normals[m.index], voxel, bins, key))
      continue;
    const auto it = std::lower_bound(model.keys.begin(), model.keys.end(), key);
    if (it == model.keys.end() || *it != key) continue;
    const auto k = static_cast<std::size_t>(it - model.keys.begin());
    const double alpha_s = half_plane_angle(T_s, down.positions[m.index]);
    for (std::uint32_t e = model.offsets[k]; e < model.offsets[k + 1]; ++e) {
      double alpha = model.alphas[e] - alpha_s;  // α = α_m − α_s, wrapped to [−π, π)
      if (alpha < -std::numbers::pi) alpha += 2 * std::numbers::pi;
      if (alpha >= std::numbers::pi) alpha -= 2 * std::numbers::pi;
      const auto b = std::min<std::uint32_t>(
          bins - 1,
          static_cast<std::uint32_t>(std::max(0.0, (alpha + std::numbers::pi) / alpha_step)));
      ++votes[static_cast<std::size_t>(model.refs[e]) * bins + b];
    }
  }
}

// The highest cells of an accumulator, descending by votes; ties keep the lower cell.
Peaks highest_cells(const std::vector<std::uint32_t>& votes) {
  Peaks top;
  for (std::size_t c = 0; c < votes.size(); ++c) {
    if (votes[c] <= top.back().votes) continue;
    std::size_t at = kPeaksPerReference - 1;
    while (at > 0 && votes[c] > top[at - 1].votes) {
      top[at] = top[at - 1];
      --at;
    }
    top[at] = {votes[c], static_cast<std::uint32_t>(c)};
  }
  return top;
}

// Voting (Drost, section 3.4): one accumulator over (model reference, α bin) per scene reference
// (every kSceneReferenceStep-th scene point); its kPeaksPerReference highest cells are kept.
std::vector<Peaks> vote(const PpfModel& model, const PointCloud& down, const KdTree& scene_tree,
                        int threads) {
  const std::size_t references = (down.size() + kSceneReferenceStep - 1) / kSceneReferenceStep;
  const std::size_t cells = model.points.size() * model.angle_bins;
  std::vector<Peaks> peaks(references);
  parallel_for(references, threads, [&](std::size_t j) {
    thread_local std::vector<std::uint32_t> votes;
    votes.assign(cells, 0);
    accumulate_votes(model, down, scene_tree, j * kSceneReferenceStep, votes);
    peaks[j] = highest_cells(votes);
  });
  return peaks;
}

// Poses of the peaks, strongest first: T_model_scene = T_m⁻¹ · R_x(α_s − α_m) · T_s, with α at
// the bin centre.
std::vector<Candidate> peak_poses(const PpfModel& model, const PointCloud& down,
                                  const std::vector<Peaks>& peaks) {
  const std::uint32_t bins = model.angle_bins;
  const double alpha_step = 2 * std::numbers::pi / bins;
  std::vector<Candidate> candidates;
  for (std::size_t j = 0; j < peaks.size(); ++j) {
    const std::size_t r = j * kSceneReferenceStep;
    const Eigen::Isometry3d T_s = to_x_axis(down.positions[r], down.normals[r]);
    for (const Peak& peak : peaks[j]) {
      if (peak.votes == 0) break;
      const std::size_t m = peak.cell / bins;
      const double alpha = -std::numbers::pi + (peak.cell % bins + 0.5) * alpha_step;
      const Eigen::Isometry3d T_m = to_x_axis(model.points.positions[m], model.points.normals[m]);
      candidates.push_back(
          {T_m.inverse() * Eigen::AngleAxisd(-alpha, Eigen::Vector3d::UnitX()) * T_s,
           static_cast<double>(peak.votes)});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.votes > b.votes; });
  return candidates;
}

// Pose clustering (Drost, section 3.5): greedy, strongest first; a pose joins the first cluster
// whose strongest pose is within 12° and moves `centre` to within 2 voxels of it. Comparing moved
// centres, not raw translations, keeps the test independent of the frame. Clusters are found
// through a grid of cluster-radius cells over the moved centres (the 27 cells around a pose hold
// every cluster it may join; of those it joins the first made, as a scan of all would).
// Returns the clusters, most votes first.
std::vector<Cluster> cluster_poses(const std::vector<Candidate>& candidates,
                                   const Eigen::Vector3d& centre, double voxel) {
  const double cos_half_rotation = std::cos(deg_to_rad(kClusterRotationDeg) / 2);
  const double cluster_radius = kClusterVoxels * voxel;
  using Cell = std::array<long long, 3>;
  struct CellHash {
    std::size_t operator()(const Cell& c) const {
      return std::hash<long long>()(c[0] * 73856093LL ^ c[1] * 19349663LL ^ c[2] * 83492791LL);
    }
  };
  std::unordered_map<Cell, std::vector<std::size_t>, CellHash> grid;
  const auto cell_of = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d c = (x / cluster_radius).array().floor();
    return Cell{static_cast<long long>(c.x()), static_cast<long long>(c.y()),
                static_cast<long long>(c.z())};
  };
  std::vector<Cluster> clusters;
  for (const Candidate& cand : candidates) {
    const Eigen::Quaterniond q(cand.T.linear());
    const Eigen::Vector3d x = cand.T * centre;
    const Cell at = cell_of(x);
    std::size_t home = clusters.size();
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({at[0] + dx, at[1] + dy, at[2] + dz});
          if (it == grid.end()) continue;
          for (std::size_t c : it->second)
            if (c < home && (clusters[c].x_first - x).norm() < cluster_radius &&
                std::abs(clusters[c].q_first.dot(q)) >= cos_half_rotation)
              home = c;
        }
    if (home == clusters.size()) {
      clusters.push_back({q, x});
      grid[at].push_back(home);
    }
    Cluster& cl = clusters[home];
    const double sign = cl.q_first.dot(q) < 0 ? -1.0 : 1.0;
    cl.q_sum += sign * cand.votes * q.coeffs();
    cl.x_sum += cand.votes * x;
    cl.votes += cand.votes;
  }
  std::stable_sort(clusters.begin(), clusters.end(),
                   [](const Cluster& a, const Cluster& b) { return a.votes > b.votes; });
  return clusters;
}

// The refined poses of the strongest clusters (index c: clusters[c]), their surface fits and the
// best fitting one.
struct Verified {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> fits;
  std::size_t best = 0;
};

// Verification: refine the strongest clusters and keep the pose that lays most of the model onto
// the scene's surface (surface_fit, global.hpp: nearness alone barely separates a plane slid over
// a plane from the true pose; counted on the model's side, because a pose that lays a face of the
// model on a wide floor lays many scene points onto the model but few of the model's). The winner
// is refined further.
Verified verify_clusters(const PpfModel& model, const PointCloud& down, const KdTree& scene_tree,
                         const Eigen::Vector3d& scene_centre, const std::vector<Cluster>& clusters,
                         int threads) {
  const double voxel = model.voxel;
  const KdTree model_tree(model.points.positions, threads);
  const std::size_t verified = std::min(kVerifiedClusters, clusters.size());
  Verified v;
  v.poses.resize(verified);
  v.fits.resize(verified);
  for (std::size_t c = 0; c < verified; ++c) {
    const Cluster& cl = clusters[c];
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(Eigen::Vector4d(cl.q_sum.normalized())).toRotationMatrix();
    T.translation() = cl.x_sum / cl.votes - T.linear() * scene_centre;
    v.poses[c] = refine(down, model.points, model_tree, T, voxel, kRefineIterations, threads);
    v.fits[c] = surface_fit(model.points, down, scene_tree, v.poses[c].inverse(), voxel, threads);
    if (v.fits[c] > v.fits[v.best]) v.best = c;
  }
  const std::size_t best = v.best;
  v.poses[best] =
      refine(down, model.points, model_tree, v.poses[best], voxel, kFinalIterations, threads);
  v.fits[best] =
      surface_fit(model.points, down, scene_tree, v.poses[best].inverse(), voxel, threads);
  return v;
}

// Ambiguity (coarse/global.hpp): the best-fitting runner-up distinct from the winner, compared by
// the same fit; marks `result` ambiguous when it fits within ambiguity_ratio of the winner.
void note_ambiguity(const Verified& v, const Eigen::Vector3d& scene_centre, double voxel,
                    const GlobalSettings& settings, GlobalResult& result) {
  const double cluster_radius = kClusterVoxels * voxel;
  const std::size_t verified = v.poses.size(), best = v.best;
  std::size_t second = verified;
  for (std::size_t c = 0; c < verified; ++c) {
    if (c == best) continue;
    const double rotation =
        rad_to_deg(rotation_angle(v.poses[c].linear().transpose() * v.poses[best].linear()));
    const double shift = (v.poses[c] * scene_centre - v.poses[best] * scene_centre).norm();
    const bool distinct = rotation > settings.distinct_rotation_deg || shift > cluster_radius;
    if (distinct && (second == verified || v.fits[c] > v.fits[second])) second = c;
  }
  if (result.success && second < verified &&
      v.fits[second] >= settings.ambiguity_ratio * v.fits[best]) {
    result.ambiguous = true;
    result.second_T_target_source = v.poses[second];
    result.second_score = v.fits[second];
    const std::string note = "ppf: ambiguous: a distinct pose fits " + percent(v.fits[second]) +
                             " of the scene to the model surface against " + percent(v.fits[best]) +
                             " (a symmetric part?)";
    result.message = result.message.empty() ? note : result.message + "; " + note;
  }
}

// Fills `result` with the verified winner and whether its fit reaches min_overlap.
void take_winner(const Verified& v, const std::vector<Cluster>& clusters,
                 const GlobalSettings& settings, GlobalResult& result) {
  result.T_target_source = v.poses[v.best];
  // The model is the object: the overlap is its fit (global.hpp).
  result.overlap = v.fits[v.best];
  result.score = v.fits[v.best];
  result.votes = clusters[v.best].votes;
  result.candidates = v.poses.size();
  result.success = result.overlap >= settings.min_overlap;
  if (!result.success)
    result.message = "ppf: the best pose explains only " + percent(result.overlap) +
                     " of the model's points within 1.5 voxels (minimum " +
                     percent(settings.min_overlap) + ")";
}

// ---- binary format helpers (little-endian, independent of the host) ----

constexpr char kMagic[8] = {'A', '3', 'D', 'P', 'P', 'F', '\r', '\n'};
// Version 1: normals away from the centroid; version 2, the same layout: outward normals.
constexpr std::uint32_t kVersion = 1, kVersionOutward = 2;
constexpr std::uint64_t kHeaderBytes = 56;
constexpr std::uint64_t kPointBytes = 48, kKeyBytes = 8, kOffsetBytes = 4, kEntryBytes = 8;

void put_bytes(std::string& out, std::uint64_t value, int bytes) {
  for (int b = 0; b < bytes; ++b) out.push_back(static_cast<char>((value >> (8 * b)) & 0xff));
}
void put_u32(std::string& out, std::uint32_t v) { put_bytes(out, v, 4); }
void put_u64(std::string& out, std::uint64_t v) { put_bytes(out, v, 8); }
void put_f32(std::string& out, float v) { put_bytes(out, std::bit_cast<std::uint32_t>(v), 4); }
void put_f64(std::string& out, double v) { put_bytes(out, std::bit_cast<std::uint64_t>(v), 8); }

std::uint64_t get_bytes(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int b = 0; b < bytes; ++b) v |= static_cast<std::uint64_t>(p[b]) << (8 * b);
  return v;
}
std::uint32_t get_u32(const unsigned char* p) {
  return static_cast<std::uint32_t>(get_bytes(p, 4));
}
std::uint64_t get_u64(const unsigned char* p) { return get_bytes(p, 8); }
float get_f32(const unsigned char* p) { return std::bit_cast<float>(get_u32(p)); }
double get_f64(const unsigned char* p) { return std::bit_cast<double>(get_u64(p)); }

// ---- reading a model file (load_ppf_model) ----

// The error for a malformed model file: "PATH: WHAT at byte offset N".
IoError format_error(const std::filesystem::path& path, const std::string& what,
                     std::uint64_t offset) {
  return IoError(path, what + " at byte offset " + std::to_string(offset));
}

// The table sizes a model file's header declares.
struct TableCounts {
  std::uint64_t points, keys, entries;
};

// Throws unless the declared tables fill a file of `size` bytes exactly and fit the format.
void check_counts(const TableCounts& n, std::uint64_t size, const std::filesystem::path& path) {
  // Sizes against the file before any allocation; each count is bounded first, so the sum
  // cannot overflow.
  const std::uint64_t body = size - kHeaderBytes;
  if (n.points > body / kPointBytes || n.keys > body / (kKeyBytes + kOffsetBytes) ||
      n.entries > body / kEntryBytes ||
      kHeaderBytes + n.points * kPointBytes + n.keys * (kKeyBytes + kOffsetBytes) + kOffsetBytes +
              n.entries * kEntryBytes !=
          size)
    throw format_error(path,
                       "the header's counts (" + std::to_string(n.points) + " points, " +
                           std::to_string(n.keys) + " keys, " + std::to_string(n.entries) +
                           " entries) do not match the file size of " + std::to_string(size) +
                           " bytes",
                       32);
  if (n.points < kMinPoints) throw format_error(path, "fewer than 10 model points", 32);
  if (n.entries > std::numeric_limits<std::uint32_t>::max())
    throw format_error(path, "too many entries", 48);
}

// Reads and checks the header of a file of `size` bytes (`in` at its start), sets the model's
// angle bins, voxel and diameter, and returns the table sizes, checked against the file size.
TableCounts read_header(std::istream& in, std::uint64_t size, const std::filesystem::path& path,
                        PpfModel& model) {
  auto error = [&](const std::string& what, std::uint64_t offset) {
    return format_error(path, what, offset);
  };
  unsigned char header[kHeaderBytes] = {};
  const auto head = static_cast<std::size_t>(std::min(size, kHeaderBytes));
  if (!in.read(reinterpret_cast<char*>(header), static_cast<std::streamsize>(head)))
    throw error("read failed", 0);
  // The magic first (over what the file has of it), so a file of another type is named as such.
  if (std::memcmp(header, kMagic, std::min(head, sizeof kMagic)) != 0 || head < sizeof kMagic)
    throw error("not an align3d PPF model (wrong magic)", 0);
  if (size < kHeaderBytes)
    throw error("truncated header (" + std::to_string(size) + " bytes)", size);
  const std::uint32_t version = get_u32(header + 8);
  if (version != kVersion && version != kVersionOutward)
    throw error("unsupported version " + std::to_string(version), 8);
  model.outward = version == kVersionOutward;
  model.angle_bins = get_u32(header + 12);
  if (model.angle_bins < 1 || model.angle_bins > 360)
    throw error("angle bin count " + std::to_string(model.angle_bins) + " out of range", 12);
  model.voxel = get_f64(header + 16);
  if (!(model.voxel > 0) || !std::isfinite(model.voxel)) throw error("voxel not positive", 16);
  model.diameter = get_f64(header + 24);
  if (!(model.diameter >= 0) || !std::isfinite(model.diameter))
    throw error("diameter not finite", 24);
  const TableCounts n{get_u64(header + 32), get_u64(header + 40), get_u64(header + 48)};
  check_counts(n, size, path);
  return n;
}

// A read position in the body (the tables after the header); errors name it as a file offset.
struct BodyReader {
  const std::filesystem::path& path;
  const unsigned char* begin;
  const unsigned char* at;
  IoError error(const std::string& what, const unsigned char* p) const {
    return format_error(path, what, kHeaderBytes + static_cast<std::uint64_t>(p - begin));
  }
};

// Reads the points and their normals, which must be finite and of unit length.
void read_points(BodyReader& body, std::uint64_t points, PpfModel& model) {
  model.points.positions.resize(points);
  model.points.normals.resize(points);
  for (std::uint64_t i = 0; i < points; ++i, body.at += kPointBytes) {
    const unsigned char* at = body.at;
    Eigen::Vector3d p, n;
    for (int a = 0; a < 3; ++a) p(a) = get_f64(at + 8 * a), n(a) = get_f64(at + 24 + 8 * a);
    if (!p.allFinite()) throw body.error("point " + std::to_string(i) + " is not finite", at);
    if (!n.allFinite() || std::abs(n.norm() - 1) > 1e-6)
      throw body.error("normal " + std::to_string(i) + " is not a unit vector", at + 24);
    model.points.positions[i] = p;
    model.points.normals[i] = n;
  }
}

// Reads the feature keys (strictly increasing) and the bucket offsets (from 0, strictly
// increasing, the last one the entry count).
void read_buckets(BodyReader& body, const TableCounts& n, PpfModel& model) {
  model.keys.resize(n.keys);
  for (std::uint64_t k = 0; k < n.keys; ++k, body.at += kKeyBytes) {
    model.keys[k] = get_u64(body.at);
    if (k > 0 && model.keys[k] <= model.keys[k - 1])
      throw body.error("feature keys not strictly increasing", body.at);
  }
  model.offsets.resize(n.keys + 1);
  for (std::uint64_t k = 0; k <= n.keys; ++k, body.at += kOffsetBytes) {
    model.offsets[k] = get_u32(body.at);
    const bool ok = k == 0 ? model.offsets[k] == 0
                           : model.offsets[k] > model.offsets[k - 1] &&
                                 (k < n.keys || model.offsets[k] == n.entries);
    if (!ok) throw body.error("bucket offset " + std::to_string(k) + " is inconsistent", body.at);
  }
}

// Reads the entries: a model point index below the point count and an angle α within [-π, π].
void read_entries(BodyReader& body, const TableCounts& n, PpfModel& model) {
  model.refs.resize(n.entries);
  model.alphas.resize(n.entries);
  for (std::uint64_t e = 0; e < n.entries; ++e, body.at += kEntryBytes) {
    const unsigned char* at = body.at;
    model.refs[e] = get_u32(at);
    model.alphas[e] = get_f32(at + 4);
    if (model.refs[e] >= n.points)
      throw body.error("entry " + std::to_string(e) + " names point " +
                           std::to_string(model.refs[e]) + " of " + std::to_string(n.points),
                       at);
    if (!(std::abs(model.alphas[e]) <= std::numbers::pi + 1e-5))
      throw body.error("entry " + std::to_string(e) + " has an angle outside [-pi, pi]", at + 4);
  }
}

}  // namespace

double ppf_model_voxel(const PointCloud& model, double voxel) {
  if (!(voxel > 0) || !std::isfinite(voxel))
    throw std::invalid_argument("PPF model: voxel size must be positive");
  // Bound the table (N² pairs): enlarge the voxel until at most kMaxModelPoints remain.
  std::size_t count = voxel_downsample(model, voxel).size();
  while (count > kMaxModelPoints) {
    voxel *= std::max(1.05, std::sqrt(static_cast<double>(count) / kMaxModelPoints));
    count = voxel_downsample(model, voxel).size();
  }
  return voxel;
}

PpfModel build_ppf_model(const PointCloud& model, double voxel, int threads, bool outward) {
  voxel = ppf_model_voxel(model, voxel);
  if (outward && !model.has_normals())
    throw std::invalid_argument("build_ppf_model: outward normals need a model with normals");
  PpfModel out;
  out.voxel = voxel;
  out.outward = outward;
  out.points = oriented_downsample(model, voxel, threads, "model",
                                   outward ? Orient::kAsGiven : Orient::kAwayFromCentroid);
  out.diameter = bounding_box_diagonal(out.points);
  const std::size_t n = out.points.size();
  const auto& pos = out.points.positions;
  const auto& nrm = out.points.normals;

  // Every ordered pair (all lie within the bounding-box diagonal), built per reference point in
  // parallel, then joined in reference order and stably sorted by key: the order is fixed.
  struct Item {
    std::uint64_t key;
    std::uint32_t ref;
    float alpha;
  };
  std::vector<std::vector<Item>> rows(n);
  parallel_for(n, threads, [&](std::size_t r) {
    const Eigen::Isometry3d T_g = to_x_axis(pos[r], nrm[r]);
    rows[r].reserve(n - 1);
    for (std::size_t i = 0; i < n; ++i) {
      std::uint64_t key;
      if (i == r || !feature_key(pos[r], nrm[r], pos[i], nrm[i], voxel, out.angle_bins, key))
        continue;
      rows[r].push_back(
          {key, static_cast<std::uint32_t>(r), static_cast<float>(half_plane_angle(T_g, pos[i]))});
    }
  });
  std::vector<Item> items;
  items.reserve(n * (n - 1));
  for (auto& row : rows) {
    items.insert(items.end(), row.begin(), row.end());
    std::vector<Item>().swap(row);
  }
  // Stably by key: radix passes of kKeyDigitBits (detail/bucket_scatter.hpp), the order
  // std::stable_sort gave. Measured (2026-11-28, a bracket scan's model, 1.5 M pairs, the same
  // model bit for bit): the whole build 245 → 187 ms on one thread, 192 → 128 ms on two.
  std::uint64_t max_key = 0;
  for (const Item& item : items) max_key = std::max(max_key, item.key);
  std::vector<Item> sorted(items.size());
  for (int shift = 0; shift == 0 || (shift < 64 && (max_key >> shift) != 0);
       shift += kKeyDigitBits) {
    detail::scatter_by_bucket(
        items.data(), sorted.data(), items.size(), std::size_t{1} << kKeyDigitBits, threads,
        [&](const Item& item) { return (item.key >> shift) & ((1u << kKeyDigitBits) - 1); });
    items.swap(sorted);
  }
  std::vector<Item>().swap(sorted);

  std::size_t unique_keys = 0;
  for (std::size_t i = 0; i < items.size(); ++i)
    unique_keys += (i == 0 || items[i].key != items[i - 1].key) ? 1 : 0;
  const double mean_bucket =
      unique_keys ? static_cast<double>(items.size()) / static_cast<double>(unique_keys) : 0;
  const double max_bucket = kMaxBucketFactor * mean_bucket;
  out.offsets.push_back(0);
  for (std::size_t begin = 0; begin < items.size();) {
    std::size_t end = begin;
    while (end < items.size() && items[end].key == items[begin].key) ++end;
    if (static_cast<double>(end - begin) <= max_bucket) {  // else a stop feature (header)
      out.keys.push_back(items[begin].key);
      for (std::size_t e = begin; e < end; ++e) {
        out.refs.push_back(items[e].ref);
        out.alphas.push_back(items[e].alpha);
      }
      out.offsets.push_back(static_cast<std::uint32_t>(out.refs.size()));
    }
    begin = end;
  }
  return out;
}

GlobalResult ppf_match(const PpfModel& model, const PointCloud& scene,
                       const GlobalSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
  if (!(model.voxel > 0) || model.angle_bins == 0 || model.points.size() < kMinPoints ||
      !model.points.has_normals() || model.offsets.size() != model.keys.size() + 1)
    throw std::invalid_argument("ppf_match: the model is empty or inconsistent");
  const int threads = settings.threads;
  const double voxel = model.voxel;
  GlobalResult result;
  result.method = GlobalMethod::kPpf;
  result.voxel = voxel;
  const PointCloud down = oriented_downsample(scene, voxel, threads, "scene");
  const KdTree scene_tree(down.positions, threads);
  const Eigen::Vector3d scene_centre = centroid(down);
  const auto elapsed_ms = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
  };

  const std::vector<Candidate> candidates =
      peak_poses(model, down, vote(model, down, scene_tree, threads));
  if (candidates.empty()) {
    result.message = "ppf: no scene point pair matched a model feature";
    result.time_ms = elapsed_ms();
    return result;
  }
  const std::vector<Cluster> clusters = cluster_poses(candidates, scene_centre, voxel);
  const Verified verified =
      verify_clusters(model, down, scene_tree, scene_centre, clusters, threads);
  take_winner(verified, clusters, settings, result);
  note_ambiguity(verified, scene_centre, voxel, settings, result);
  result.time_ms = elapsed_ms();
  return result;
}

GlobalResult ppf_register(const PointCloud& source, const PointCloud& target,
                          const GlobalSettings& settings, const GlobalContext& context) {
  const auto start = std::chrono::steady_clock::now();
  // The model description is built from the object (global.hpp), the other cloud is the scene.
  const auto [object, voxel] = plan_global(source, target, settings, context);
  const bool source_is_object = object == Role::kSource;
  const auto role_named = [](const char* role, auto&& step) {
    try {
      return step();
    } catch (const DataError& e) {
      throw DataError(role, e.problem());
    }
  };
  const std::shared_ptr<const PpfModel> kept = role_named(to_string(object), [&] {
    if (!source_is_object && context.target_cache)
      return context.target_cache->ppf_model(voxel, settings.threads);
    return std::make_shared<const PpfModel>(
        build_ppf_model(source_is_object ? source : target, voxel, settings.threads));
  });
  const PpfModel& model = *kept;
  GlobalResult result = role_named(source_is_object ? "target" : "source", [&] {
    return ppf_match(model, source_is_object ? target : source, settings);
  });
  result.object = object;
  if (source_is_object) {  // ppf_match mapped the target (scene) into the source (model)
    result.T_target_source = result.T_target_source.inverse();
    result.second_T_target_source = result.second_T_target_source.inverse();
  }
  if (model.voxel > voxel * (1 + 1e-9)) {
    const std::string note = "ppf: the voxel was enlarged from " + std::to_string(voxel) + " to " +
                             std::to_string(model.voxel) + " to keep the model at " +
                             std::to_string(kMaxModelPoints) + " points or fewer";
    result.message = result.message.empty() ? note : result.message + "; " + note;
  }
  result.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

void save_ppf_model(const std::filesystem::path& path, const PpfModel& model) {
  const std::size_t p = model.points.size();
  if (!model.points.has_normals() || model.offsets.size() != model.keys.size() + 1 ||
      model.refs.size() != model.alphas.size() || model.offsets.back() != model.refs.size())
    throw std::invalid_argument("save_ppf_model: the model is inconsistent");
  std::string bytes;
  bytes.reserve(kHeaderBytes + p * kPointBytes + model.keys.size() * (kKeyBytes + kOffsetBytes) +
                model.refs.size() * kEntryBytes + kOffsetBytes);
  bytes.append(kMagic, sizeof kMagic);
  put_u32(bytes, model.outward ? kVersionOutward : kVersion);
  put_u32(bytes, model.angle_bins);
  put_f64(bytes, model.voxel);
  put_f64(bytes, model.diameter);
  put_u64(bytes, p);
  put_u64(bytes, model.keys.size());
  put_u64(bytes, model.refs.size());
  for (std::size_t i = 0; i < p; ++i) {
    for (int a = 0; a < 3; ++a) put_f64(bytes, model.points.positions[i](a));
    for (int a = 0; a < 3; ++a) put_f64(bytes, model.points.normals[i](a));
  }
  for (std::uint64_t key : model.keys) put_u64(bytes, key);
  for (std::uint32_t offset : model.offsets) put_u32(bytes, offset);
  for (std::size_t e = 0; e < model.refs.size(); ++e) {
    put_u32(bytes, model.refs[e]);
    put_f32(bytes, model.alphas[e]);
  }
  io::write_atomically(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

PpfModel load_ppf_model(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path, "cannot open the PPF model file");
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  if (end < 0) throw IoError(path, "cannot determine the file size");
  const auto size = static_cast<std::uint64_t>(end);
  in.seekg(0, std::ios::beg);
  PpfModel model;
  const TableCounts counts = read_header(in, size, path, model);
  std::vector<unsigned char> data(size - kHeaderBytes);
  if (!in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size())))
    throw format_error(path, "read failed (file changed?)", kHeaderBytes);

  BodyReader body{path, data.data(), data.data()};
  read_points(body, counts.points, model);
  read_buckets(body, counts, model);
  if (counts.keys == 0 && counts.entries != 0) throw format_error(path, "entries without keys", 48);
  read_entries(body, counts, model);
  return model;
}

// ---- Many instances (ppf.hpp: ppf_scene, ppf_hypotheses) ----

namespace {

constexpr double kSpreadMargin = 0.25;    // a neighbouring bin is looked up within this of the edge
constexpr double kPlaceDiameters = 0.25;  // ppf_hypotheses: one place, in model diameters
constexpr std::size_t kMaxDenseKeys = std::size_t{1} << 24;
constexpr std::size_t kReferencesPerTask = 16;
// Every kPartnerStep-th neighbour of a reference (in the tree's order, spread evenly over its
// ball) is its pair partner: measured on the development scenes of bench/compare_find.py, half
// the partners lost no instance and saved 30 % of find's time.
constexpr std::size_t kPartnerStep = 2;

// The table as the voting of many instances reads it: the bucket of every feature key through a
// dense array over the key range (one load per lookup; the keys span a few hundred thousand values
// at 30 bins), or a binary search when too large; and per entry its accumulator row (reference ×
// bins) and α_m's bin, so a vote is integer arithmetic (α = α_m − α_s in bins, as Drost quantises
// both angles).
class VoteTable {
 public:
  explicit VoteTable(const PpfModel& model) : keys_(model.keys), bins_(model.angle_bins) {
    if (!keys_.empty() && keys_.back() < kMaxDenseKeys) {
      dense_.assign(keys_.back() + 1, kNone);
      for (std::size_t k = 0; k < keys_.size(); ++k)
        dense_[keys_[k]] = static_cast<std::uint32_t>(k);
    }
    row_.resize(model.refs.size());
    alpha_bin_.resize(model.refs.size());
    for (std::size_t e = 0; e < model.refs.size(); ++e) {
      row_[e] = model.refs[e] * bins_;
      alpha_bin_[e] = alpha_bin(model.alphas[e]);
    }
  }
  // The bucket of `key`, or kNone.
  std::uint32_t find(std::uint64_t key) const {
    if (!dense_.empty()) return key < dense_.size() ? dense_[key] : kNone;
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    return it != keys_.end() && *it == key ? static_cast<std::uint32_t>(it - keys_.begin()) : kNone;
  }
  // The bin of an angle in [−π, π].
  std::uint32_t alpha_bin(double alpha) const {
    const auto b = static_cast<std::uint32_t>(
        std::max(0.0, (alpha + std::numbers::pi) / (2 * std::numbers::pi) * bins_));
    return std::min(b, bins_ - 1);
  }
  std::uint32_t row(std::size_t e) const { return row_[e]; }
  std::uint32_t alpha(std::size_t e) const { return alpha_bin_[e]; }
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

 private:
  const std::vector<std::uint64_t>& keys_;
  std::uint32_t bins_;
  std::vector<std::uint32_t> dense_, row_, alpha_bin_;
};

// The bins a feature value is looked up in: its own, and the neighbour on the near side when it
// lies within kSpreadMargin of that edge (and that bin exists). Returns how many (1 or 2).
int spread_bins(double value, std::uint64_t last, std::array<std::uint64_t, 2>& out) {
  const auto bin = std::min<std::uint64_t>(last, static_cast<std::uint64_t>(value));
  out[0] = bin;
  const double frac = value - static_cast<double>(bin);
  if (frac < kSpreadMargin && bin > 0) return out[1] = bin - 1, 2;
  if (frac > 1 - kSpreadMargin && bin < last) return out[1] = bin + 1, 2;
  return 1;
}

// Per-thread accumulator: votes per (model reference, α bin) cell and, per cell, the last scene
// pair that voted for it (one vote per pair and cell).
struct Accumulator {
  std::vector<std::uint32_t> votes, last_pair;
  std::uint32_t pair = 0;
  void reset(std::size_t cells) {
    votes.assign(cells, 0);
    if (last_pair.size() != cells || pair > std::numeric_limits<std::uint32_t>::max() / 2) {
      last_pair.assign(cells, 0);
      pair = 0;
    }
  }
};

// The votes of scene reference r (ppf.hpp: neighbouring bins, one vote per pair and cell).
void accumulate_spread_votes(const PpfModel& model, const VoteTable& table, const PointCloud& down,
                             const KdTree& scene_tree, std::size_t r, Accumulator& acc) {
  thread_local std::vector<Neighbor> nb;
  const std::uint32_t bins = model.angle_bins;
  const Eigen::Vector3d& p_r = down.positions[r];
  const Eigen::Vector3d& n_r = down.normals[r];
  const Eigen::Isometry3d T_s = to_x_axis(p_r, n_r);
  const auto last_distance_bin = static_cast<std::uint64_t>(model.diameter / model.voxel) + 1;
  scene_tree.radius_unsorted(p_r, model.diameter * model.diameter, nb);  // counts: any order
  std::array<std::uint32_t, 16> buckets;
  for (std::size_t partner = 0; partner < nb.size(); partner += kPartnerStep) {
    const Neighbor& m = nb[partner];
    std::array<double, 4> f;
    if (m.index == r || !feature_values(p_r, n_r, down.positions[m.index], down.normals[m.index],
                                        model.voxel, bins, f))
      continue;
    std::array<std::array<std::uint64_t, 2>, 4> b;
    std::array<int, 4> count;
    count[0] = spread_bins(f[0], last_distance_bin, b[0]);
    for (int a = 1; a < 4; ++a) count[a] = spread_bins(f[a], bins - 1, b[a]);
    int found = 0;
    for (int i0 = 0; i0 < count[0]; ++i0)
      for (int i1 = 0; i1 < count[1]; ++i1)
        for (int i2 = 0; i2 < count[2]; ++i2)
          for (int i3 = 0; i3 < count[3]; ++i3) {
            const std::uint32_t k =
                table.find(compose_key(b[0][i0], b[1][i1], b[2][i2], b[3][i3], bins));
            if (k != VoteTable::kNone) buckets[found++] = k;
          }
    if (found == 0) continue;  // most pairs (a plane's, whose buckets the model dropped): no α
    // The bin of α = α_m − α_s is that of α_m (bins from −π) less ⌊α_s / step⌋, modulo bins.
    const auto alpha_s = static_cast<long>(
        std::floor(half_plane_angle(T_s, down.positions[m.index]) / (2 * std::numbers::pi) * bins));
    const auto shift =
        static_cast<std::uint32_t>(((-alpha_s) % static_cast<long>(bins) + bins) % bins);
    const std::uint32_t pair = ++acc.pair;
    for (int i = 0; i < found; ++i)
      for (std::uint32_t e = model.offsets[buckets[i]]; e < model.offsets[buckets[i] + 1]; ++e) {
        std::uint32_t a = table.alpha(e) + shift;
        a = a >= bins ? a - bins : a;
        const std::size_t cell = table.row(e) + a;
        if (acc.last_pair[cell] == pair) continue;
        acc.last_pair[cell] = pair;
        ++acc.votes[cell];
      }
  }
}

}  // namespace

PointCloud ppf_scene(const PointCloud& scene, double voxel, const Eigen::Vector3d& viewpoint,
                     int threads) {
  return oriented_downsample(scene, voxel, threads, "scene", Orient::kToward, viewpoint);
}

std::vector<PpfHypothesis> ppf_hypotheses(const PpfModel& model, const PointCloud& scene,
                                          const Symmetry& symmetry, std::size_t max_hypotheses,
                                          int threads, std::size_t max_per_place) {
  if (!model.outward || !(model.voxel > 0) || model.angle_bins == 0 ||
      model.points.size() < kMinPoints || !model.points.has_normals() ||
      model.offsets.size() != model.keys.size() + 1)
    throw std::invalid_argument(
        "ppf_hypotheses: the model is inconsistent or was not built with outward normals");
  if (scene.size() < 2 || !scene.has_normals()) return {};
  const KdTree scene_tree(scene.positions, threads);
  const VoteTable table(model);
  const std::size_t references = (scene.size() + kSceneReferenceStep - 1) / kSceneReferenceStep;
  const std::size_t cells = model.points.size() * model.angle_bins;
  std::vector<Peaks> peaks(references);
  // Tasks of kReferencesPerTask references: a reference votes with thousands of pairs, and
  // parallel_for's runs of 256 would leave one thread the last run alone.
  const std::size_t tasks = (references + kReferencesPerTask - 1) / kReferencesPerTask;
  parallel_tasks(tasks, threads, [&](std::size_t t) {
    thread_local Accumulator acc;
    for (std::size_t j = t * kReferencesPerTask;
         j < std::min(references, (t + 1) * kReferencesPerTask); ++j) {
      acc.reset(cells);
      accumulate_spread_votes(model, table, scene, scene_tree, j * kSceneReferenceStep, acc);
      peaks[j] = highest_cells(acc.votes);
    }
  });
  // peak_poses gives T_model_scene; each pose, inverted and in canonical form, is clustered by
  // where it puts the model's centroid.
  std::vector<Candidate> candidates = peak_poses(model, scene, peaks);
  for (Candidate& c : candidates) c.T = canonical_pose(c.T.inverse(), symmetry);
  const Eigen::Vector3d model_centre = centroid(model.points);
  const std::vector<Cluster> clusters = cluster_poses(candidates, model_centre, model.voxel);
  // Places: where the first hypothesis of each put the model's centroid, and how many it holds.
  // A linear scan: there are at most max_hypotheses places, and a few thousand clusters.
  std::vector<std::pair<Eigen::Vector3d, std::size_t>> places;
  const double place_radius = kPlaceDiameters * model.diameter;
  std::vector<PpfHypothesis> out;
  for (std::size_t c = 0; c < clusters.size() && out.size() < max_hypotheses; ++c) {
    const Cluster& cl = clusters[c];
    const Eigen::Vector3d centre = cl.x_sum / cl.votes;
    if (max_per_place > 0) {
      auto place = std::find_if(places.begin(), places.end(), [&](const auto& p) {
        return (p.first - centre).norm() <= place_radius;
      });
      if (place == places.end()) place = places.insert(places.end(), {centre, 0});
      if (place->second++ >= max_per_place) continue;
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(Eigen::Vector4d(cl.q_sum.normalized())).toRotationMatrix();
    T.translation() = centre - T.linear() * model_centre;
    out.push_back({T, cl.votes});
  }
  return out;
}

}  // namespace align3d
