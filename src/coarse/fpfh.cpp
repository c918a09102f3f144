#include "align3d/coarse/fpfh.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <queue>
#include <stdexcept>

#include "detail/fast_angle.hpp"
#include "detail/parallel.hpp"

namespace align3d {
namespace {

constexpr int kBins = 11;
constexpr double kSeedLever = 0.05;      // seed: |n·(p − c)| >= this share of the radius
constexpr std::size_t kPropagation = 8;  // neighbours an orientation propagates to

int bin(double value, double lo, double hi) {
  const int b = static_cast<int>(std::floor(kBins * (value - lo) / (hi - lo)));
  return std::clamp(b, 0, kBins - 1);
}

// θ's bin for θ = atan2(y, x); θ = −π counts as π (antiparallel normals give ±π with the sign of
// a round-off: one configuration, one bin). libm's atan2 decides only within 1e-7 rad of a bin's
// edge, so the bins are its own.
int theta_bin(double y, double x) {
  constexpr double kPi = std::numbers::pi;
  if (x != 0 || y != 0) {  // at the origin the signs of zero decide: libm's
    const double t = (detail::fast_atan2(y, x) + kPi) * (kBins / (2 * kPi));
    if (std::abs(t - std::round(t)) > 1e-7 * kBins / (2 * kPi))
      return std::clamp(static_cast<int>(t), 0, kBins - 1);
  }
  double theta = std::atan2(y, x);
  if (theta < -kPi + 1e-9) theta = kPi;
  return bin(theta, -kPi, kPi);
}

// θ (as the y and x of its atan2), α, φ of the pair (PCL's computePairFeatures; the header gives
// the formulas). Returns false for coincident points. When d is parallel to the frame's normal the
// frame is undefined: α = θ = 0.
bool pair_features(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2,
                   const Eigen::Vector3d& n2, double& theta_y, double& theta_x, double& alpha,
                   double& phi) {
  Eigen::Vector3d d = p2 - p1;
  const double length = d.norm();
  if (length == 0.0) return false;
  const double angle1 = n1.dot(d) / length;
  const double angle2 = n2.dot(d) / length;
  const Eigen::Vector3d* u = &n1;
  const Eigen::Vector3d* other = &n2;
  // The frame sits on the point whose normal is closer to the line (|cos| larger).
  if (std::abs(angle1) < std::abs(angle2)) {
    u = &n2;
    other = &n1;
    d = -d;
    phi = -angle2;
  } else {
    phi = angle1;
  }
  Eigen::Vector3d v = d.cross(*u);
  const double v_norm = v.norm();
  if (v_norm == 0.0) {
    theta_y = alpha = 0.0;
    theta_x = 1.0;
    return true;
  }
  v /= v_norm;
  const Eigen::Vector3d w = u->cross(v);
  alpha = v.dot(*other);
  theta_y = w.dot(*other);
  theta_x = u->dot(*other);
  return true;
}

}  // namespace

Neighbourhoods radius_neighbourhoods(const PointCloud& cloud, const KdTree& tree, double radius,
                                     int max_neighbors, int threads) {
  Neighbourhoods out(cloud.size());
  const auto cap = static_cast<std::size_t>(max_neighbors) + 1;
  parallel_for(cloud.size(), threads, [&](std::size_t i) {
    tree.radius(cloud.positions[i], radius * radius, out[i]);
    if (max_neighbors > 0 && out[i].size() > cap) out[i].resize(cap);
    out[i].shrink_to_fit();
  });
  return out;
}

std::vector<FpfhDescriptor> compute_fpfh(const PointCloud& cloud, const KdTree& tree,
                                         const FpfhSettings& settings) {
  if (!(settings.radius > 0)) throw std::invalid_argument("compute_fpfh: radius must be positive");
  return compute_fpfh(
      cloud,
      radius_neighbourhoods(cloud, tree, settings.radius, settings.max_neighbors, settings.threads),
      settings.threads);
}

std::vector<FpfhDescriptor> compute_fpfh(const PointCloud& cloud, const Neighbourhoods& neighbours,
                                         int threads) {
  if (!cloud.has_normals()) throw std::invalid_argument("compute_fpfh: the cloud needs normals");
  if (neighbours.size() != cloud.size())
    throw std::invalid_argument("compute_fpfh: one neighbourhood per point needed");
  const std::size_t n = cloud.size();

  // Pass 1: SPFH of every point.
  std::vector<FpfhDescriptor> spfh(n, FpfhDescriptor::Zero());
  parallel_for(n, threads, [&](std::size_t i) {
    std::array<int, 3 * kBins> count{};
    int pairs = 0;
    for (const Neighbor& m : neighbours[i]) {
      if (m.index == i) continue;
      double theta_y, theta_x, alpha, phi;
      if (!pair_features(cloud.positions[i], cloud.normals[i], cloud.positions[m.index],
                         cloud.normals[m.index], theta_y, theta_x, alpha, phi))
        continue;  // a coincident point carries no direction
      ++count[theta_bin(theta_y, theta_x)];
      ++count[kBins + bin(alpha, -1, 1)];
      ++count[2 * kBins + bin(phi, -1, 1)];
      ++pairs;
    }
    if (pairs == 0) return;
    const double increment = 100.0 / pairs;
    for (int b = 0; b < 3 * kBins; ++b) spfh[i](b) = static_cast<float>(count[b] * increment);
  });

  // Pass 2: FPFH = SPFH(p) + Σ SPFH(p_k)/‖p − p_k‖², the sum's blocks rescaled to 100 (Open3D).
  std::vector<FpfhDescriptor> fpfh(n, FpfhDescriptor::Zero());
  parallel_for(n, threads, [&](std::size_t i) {
    Eigen::Matrix<double, 33, 1> sum = Eigen::Matrix<double, 33, 1>::Zero();
    for (const Neighbor& m : neighbours[i]) {
      if (m.index == i || m.sq_distance == 0.0) continue;
      sum += spfh[m.index].cast<double>() * (1.0 / m.sq_distance);
    }
    for (int block = 0; block < 3; ++block) {
      const double total = sum.segment<kBins>(block * kBins).sum();
      if (total > 0) sum.segment<kBins>(block * kBins) *= 100.0 / total;
    }
    fpfh[i] = (sum + spfh[i].cast<double>()).cast<float>();
  });
  return fpfh;
}

void orient_normals_consistently(PointCloud& cloud, const KdTree& tree, double radius,
                                 int threads) {
  orient_normals_consistently(cloud, radius_neighbourhoods(cloud, tree, radius, 0, threads),
                              threads);
}

void orient_normals_consistently(PointCloud& cloud, const Neighbourhoods& neighbours, int threads) {
  if (!cloud.has_normals() || neighbours.size() != cloud.size())
    throw std::invalid_argument(
        "orient_normals_consistently: the cloud needs normals and one neighbourhood per point");
  const std::size_t n = cloud.size();
  // Seeds: the sign away from the neighbourhood centroid, where that centroid is clearly off the
  // tangent plane (curved or next to other structure).
  std::vector<unsigned char> done(n, 0);
  parallel_for(n, threads, [&](std::size_t i) {
    const std::vector<Neighbor>& nb = neighbours[i];
    if (nb.empty()) return;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Neighbor& m : nb) mean += cloud.positions[m.index];
    mean /= static_cast<double>(nb.size());
    const double lever = cloud.normals[i].dot(cloud.positions[i] - mean);
    if (lever < 0) cloud.normals[i] = -cloud.normals[i];
    const double reach = std::sqrt(nb.back().sq_distance);  // the neighbourhood's extent
    done[i] = std::abs(lever) >= kSeedLever * reach;
  });
  // The rest: a maximum spanning forest of |n_i·n_j| grown from the seeds over each point's
  // kPropagation nearest neighbours (Hoppe et al. 1992), each point taking the sign that agrees
  // with the point it is reached from. Ties break by index, so the order is deterministic.
  struct Edge {
    double weight;
    std::uint32_t from, to;
    bool operator<(const Edge& o) const {  // max-heap: larger weight, then smaller indices first
      if (weight != o.weight) return weight < o.weight;
      if (to != o.to) return to > o.to;
      return from > o.from;
    }
  };
  std::priority_queue<Edge> heap;
  auto push_edges = [&](std::size_t i) {
    const std::vector<Neighbor>& nb = neighbours[i];
    const std::size_t count = std::min(nb.size(), kPropagation + 1);
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t j = nb[k].index;
      if (done[j]) continue;
      heap.push({std::abs(cloud.normals[i].dot(cloud.normals[j])), static_cast<std::uint32_t>(i),
                 static_cast<std::uint32_t>(j)});
    }
  };
  for (std::size_t i = 0; i < n; ++i)
    if (done[i]) push_edges(i);
  while (!heap.empty()) {
    const Edge e = heap.top();
    heap.pop();
    if (done[e.to]) continue;
    if (cloud.normals[e.from].dot(cloud.normals[e.to]) < 0)
      cloud.normals[e.to] = -cloud.normals[e.to];
    done[e.to] = 1;
    push_edges(e.to);
  }
}

}  // namespace align3d
