#include "align3d/stitch/multiview_icp.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>

#include "align3d/icp/kernels.hpp"
#include "align3d/se3.hpp"
#include "detail/parallel.hpp"

namespace align3d {

namespace {

// Pairs whose normals differ by more than 45° are not the same surface.
constexpr double kMinNormalCosine = 0.7071;
// A scan that has moved by the tolerance in each of the last kRestlessIterations iterations, and
// by more than half as much in the last as kSlowdownSpan iterations before, does not converge: it
// slides, and does not hold the others back. Measured on the bracket's rings (2026-11-28): a view
// turned onto a look-alike face slid by 1–100 tolerances an iteration, its steps shrinking by
// 0.5–0.9 over 5 iterations, while the right scans settled within 8; a near-symmetric part's
// group of right scans creeping about its axis shrank its steps to 0.15–0.26 over 5.
constexpr int kRestlessIterations = 10, kSlowdownSpan = 5;
constexpr double kSlowdown = 0.5;

// The sums of one directed link a → b: the blocks of the normal equations it touches.
struct LinkSums {
  Matrix6d aa = Matrix6d::Zero(), ab = Matrix6d::Zero(), bb = Matrix6d::Zero();
  Vector6d ga = Vector6d::Zero(), gb = Vector6d::Zero();
  std::vector<double> distances;  // filled when collecting residuals

  void operator+=(const LinkSums& o) {
    aa += o.aa, ab += o.ab, bb += o.bb, ga += o.ga, gb += o.gb;
    distances.insert(distances.end(), o.distances.begin(), o.distances.end());
  }
};

// A directed link's memory (Pass::remember): the sampled points of a near b when it was made, by
// index into a's sample, each with its nearest point of b as last found (its index, and a copy of
// its position and normal: read in order, where b's cloud would be read at random), where the
// point lay in b's frame at that search and half the gap between its nearest's distance and the
// next one's (a point that has moved by less keeps its nearest: Pass::link), and where they all
// lay when the memory was made (a_in_b, their centre and radius about it).
struct LinkMemory {
  std::vector<std::uint32_t> points, partners;
  std::vector<Eigen::Vector3d> partner_points, partner_normals, searched_at;
  std::vector<double> slack;
  Eigen::Isometry3d a_in_b = Eigen::Isometry3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
  bool valid = false;
};

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

// A search's slack (LinkMemory): half the gap between its nearest's distance and the next one's.
double slack(const Neighbor& nearest, double sq_second) {
  return (std::sqrt(sq_second) - std::sqrt(nearest.sq_distance)) / 2;
}

struct Pass {
  const std::vector<MultiviewScan>& scans;
  const std::vector<Eigen::Isometry3d>& poses;
  Eigen::Vector3d centre;
  const MultiviewSettings& settings;
  bool collect;

  static void add_pair(LinkSums& acc, const MultiviewPairTerms& t, double w) {
    if (t.rows == 1) {
      accumulate<1>(acc, t.ja.topRows<1>(), t.jb.topRows<1>(), t.e.head<1>(),
                    Eigen::Matrix<double, 1, 1>::Identity(), w);
    } else {
      accumulate<3>(acc, t.ja, t.jb, t.e, t.M, w);
    }
  }

  template <int R>
  static void accumulate(LinkSums& acc, const Eigen::Matrix<double, R, 6>& ja,
                         const Eigen::Matrix<double, R, 6>& jb,
                         const Eigen::Matrix<double, R, 1>& e, const Eigen::Matrix<double, R, R>& M,
                         double w) {
    const Eigen::Matrix<double, 6, R> ja_m = w * ja.transpose() * M;
    const Eigen::Matrix<double, 6, R> jb_m = w * jb.transpose() * M;
    acc.aa.noalias() += ja_m * ja;
    acc.ab.noalias() += ja_m * jb;
    acc.bb.noalias() += jb_m * jb;
    acc.ga.noalias() += ja_m * e;
    acc.gb.noalias() += jb_m * e;
  }

  Eigen::Isometry3d a_in_b(std::size_t a, std::size_t b) const {
    return poses[b].inverse() * poses[a];
  }

  // Which of a's sampled points lie within twice the reach of b's points, each with its nearest,
  // and where all of them lie in b's frame (LinkMemory).
  LinkMemory remember(std::size_t a, std::size_t b) const {
    const MultiviewScan& sa = scans[a];
    const double sq_wide = 4 * settings.max_distance * settings.max_distance;
    LinkMemory m;
    m.valid = true;
    m.a_in_b = a_in_b(a, b);
    const std::size_t n = sa.sample.size();
    std::vector<Eigen::Vector3d> in_b(n);
    std::vector<std::uint32_t> partner(n, kNone);
    std::vector<double> gap(n);
    parallel_for(n, settings.threads, [&](std::size_t i) {
      in_b[i] = m.a_in_b * sa.cloud->positions[sa.sample[i]];
      Neighbor nb;
      double sq_second = 0;
      if (!scans[b].tree->nearest_two(in_b[i], nb, sq_second, sq_wide)) return;
      partner[i] = static_cast<std::uint32_t>(nb.index);
      gap[i] = slack(nb, sq_second);
    });
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < n; ++i) {
      sum += in_b[i];
      if (partner[i] == kNone) continue;
      m.points.push_back(static_cast<std::uint32_t>(i));
      m.partners.push_back(partner[i]);
      m.partner_points.push_back(scans[b].cloud->positions[partner[i]]);
      m.partner_normals.push_back(scans[b].cloud->normals[partner[i]]);
      m.searched_at.push_back(in_b[i]);
      m.slack.push_back(gap[i]);
    }
    if (n > 0) m.centre = sum / static_cast<double>(n);
    for (const Eigen::Vector3d& y : in_b) m.radius = std::max(m.radius, (y - m.centre).norm());
    return m;
  }

  // At most how far any of a's sampled points has moved relative to b since the memory was made:
  // the turn times their radius about their centre, plus the centre's move.
  double drift(const LinkMemory& m, std::size_t a, std::size_t b) const {
    const Eigen::Isometry3d d = a_in_b(a, b) * m.a_in_b.inverse();
    return rotation_angle(d.linear()) * m.radius + (d * m.centre - m.centre).norm();
  }

  // The link's sums over the remembered points: a point more than twice the reach from b when the
  // memory was made is still beyond the reach while the drift is below the reach, so no pair is
  // lost; a point that has moved by less than its slack since its last search keeps its nearest
  // (that point is nearer than every other by more than twice the move), and the others are
  // searched again. The same pairs as searching every sampled point afresh; measured (2026-11-29,
  // 2 threads, the same poses to the bit): the multi-view stage 27-44 % faster on the generated
  // sets (bracket_ring 715 -> 522 ms, flange_ring 934 -> 542, bracket12 2855 -> 1606).
  LinkSums link(std::size_t a, std::size_t b, LinkMemory& m) const {
    const bool fresh = !m.valid || drift(m, a, b) >= settings.max_distance;
    if (fresh) m = remember(a, b);
    const MultiviewScan& sa = scans[a];
    const MultiviewScan& sb = scans[b];
    const Eigen::Isometry3d to_b = a_in_b(a, b);
    const double sq_max = settings.max_distance * settings.max_distance;
    const double scale =
        settings.kernel_scale > 0 ? settings.kernel_scale : settings.max_distance / 2;
    return parallel_reduce(
        m.points.size(), settings.threads, LinkSums{},
        [&](LinkSums& acc, std::size_t k) {
          const Eigen::Vector3d& p = sa.cloud->positions[sa.sample[m.points[k]]];
          const Eigen::Vector3d q = to_b * p;
          if (!fresh && !((q - m.searched_at[k]).norm() < m.slack[k])) {
            Neighbor nb;
            double sq_second = 0;
            if (!sb.tree->nearest_two(q, nb, sq_second, sq_max)) return;
            if (nb.index != m.partners[k]) {
              m.partners[k] = static_cast<std::uint32_t>(nb.index);
              m.partner_points[k] = sb.cloud->positions[nb.index];
              m.partner_normals[k] = sb.cloud->normals[nb.index];
            }
            m.searched_at[k] = q;
            m.slack[k] = slack(nb, sq_second);
          }
          // The squared distance as the tree's leaf scan computes it.
          const Eigen::Vector3d& y = m.partner_points[k];
          const double dx = q.x() - y.x(), dy = q.y() - y.y(), dz = q.z() - y.z();
          if (!(dx * dx + dy * dy + dz * dz < sq_max)) return;
          const Eigen::Vector3d xa = poses[a] * p;
          const Eigen::Vector3d xb = poses[b] * m.partner_points[k];
          const Eigen::Vector3d na = poses[a].linear() * sa.cloud->normals[sa.sample[m.points[k]]];
          const Eigen::Vector3d n = poses[b].linear() * m.partner_normals[k];
          // Both scans see the surface from outside, their normals towards their sensors: a
          // partner whose normal turns away lies on another face (across an edge, the far side
          // of a thin wall), which the other scan may not see at all.
          if (n.dot(na) < kMinNormalCosine) return;
          const double r = n.dot(xa - xb);
          if (collect) acc.distances.push_back(std::abs(r));
          add_pair(acc, multiview_pair_terms(settings.method, xa, xb, na, n, centre),
                   kernel_weight(settings.kernel, r, scale));
        },
        [](LinkSums& x, const LinkSums& y) { x += y; });
  }
};

}  // namespace

MultiviewPairTerms multiview_pair_terms(IcpMethod method, const Eigen::Vector3d& xa,
                                        const Eigen::Vector3d& xb, const Eigen::Vector3d& na,
                                        const Eigen::Vector3d& nb, const Eigen::Vector3d& centre) {
  MultiviewPairTerms t;
  const Eigen::Vector3d d = xa - xb;
  switch (method) {
    case IcpMethod::kPointToPlane:  // r = n_b·(x_a − x_b)
      t.rows = 1;
      t.e(0) = nb.dot(d);
      t.ja.row(0) << (xa - centre).cross(nb).transpose(), nb.transpose();
      t.jb.row(0) << (nb.cross(d) - (xb - centre).cross(nb)).transpose(), -nb.transpose();
      break;
    case IcpMethod::kSymmetric: {  // r = (n_a + n_b)·(x_a − x_b), both normals turning
      const Eigen::Vector3d n = na + nb;
      t.rows = 1;
      t.e(0) = n.dot(d);
      t.ja.row(0) << ((xa - centre).cross(n) + na.cross(d)).transpose(), n.transpose();
      t.jb.row(0) << (nb.cross(d) - (xb - centre).cross(n)).transpose(), -n.transpose();
      break;
    }
    case IcpMethod::kPointToPoint:
    case IcpMethod::kGicp:  // e = x_a − x_b weighed by M (I, or GICP's, held over the step)
      t.rows = 3;
      t.e = d;
      t.ja << -skew(xa - centre), Eigen::Matrix3d::Identity();
      t.jb << skew(xb - centre), -Eigen::Matrix3d::Identity();
      t.M = method == IcpMethod::kGicp ? GicpFactor::weight(na, nb) : Eigen::Matrix3d::Identity();
      break;
  }
  return t;
}

namespace {

// x ← exp(ω)·(x − c) + c + v.
Eigen::Isometry3d update_about(const Vector6d& xi, const Eigen::Vector3d& c) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3_exp(xi.head<3>());
  T.translation() = c + xi.tail<3>() - T.linear() * c;
  return T;
}

Eigen::Vector3d common_centre(const std::vector<MultiviewScan>& scans,
                              const std::vector<Eigen::Isometry3d>& poses) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double count = 0;
  for (std::size_t k = 0; k < scans.size(); ++k)
    for (std::uint32_t i : scans[k].sample) sum += poses[k] * scans[k].cloud->positions[i], ++count;
  return count > 0 ? Eigen::Vector3d(sum / count) : Eigen::Vector3d::Zero();
}

// Whether a scan that moved by `steps` in the iterations so far holds the others back no more:
// its last step is below the tolerance, or it slides (kRestlessIterations).
bool settled(const std::vector<double>& steps, double tolerance) {
  const std::size_t m = steps.size();
  if (steps.back() < tolerance) return true;
  if (m < static_cast<std::size_t>(kRestlessIterations)) return false;
  const bool restless = std::all_of(steps.end() - kRestlessIterations, steps.end(),
                                    [&](double x) { return x >= tolerance; });
  return restless && steps[m - 1] >= kSlowdown * steps[m - 1 - kSlowdownSpan];
}

}  // namespace

MultiviewResult multiview_icp(const std::vector<MultiviewScan>& scans,
                              const std::vector<std::pair<std::size_t, std::size_t>>& links,
                              std::vector<Eigen::Isometry3d> poses,
                              const MultiviewSettings& settings) {
  const std::size_t n = scans.size();
  MultiviewResult out;
  out.last_step.assign(n, 0);
  const Eigen::Vector3d centre = common_centre(scans, poses);
  std::vector<bool> linked(n, false);
  for (const auto& [a, b] : links) linked[a] = linked[b] = true;
  // How far a pose moved, in the tolerance's units (its turn times the length, plus how far it
  // moved the centre).
  auto moved = [&](const Eigen::Isometry3d& from, const Eigen::Isometry3d& to) {
    const Eigen::Isometry3d d = to * from.inverse();
    return Eigen::AngleAxisd(d.linear()).angle() * settings.length + (d * centre - centre).norm();
  };
  // Each directed link's sums and the poses they were taken at: a link whose two scans have moved
  // by less than the tolerance since keeps them (its pairs and terms would barely differ), so that
  // once most scans have settled, an iteration pairs only the links of those still moving.
  struct Cached {
    LinkSums sums;
    Eigen::Isometry3d pa, pb;
    bool valid = false;
  };
  // Directed link l: link l / 2 one way (even l) or the other.
  auto directed = [&](std::size_t l) {
    return l % 2 ? std::pair{links[l / 2].second, links[l / 2].first} : links[l / 2];
  };
  std::vector<Cached> cache(2 * links.size());
  std::vector<LinkMemory> memory(2 * links.size());
  std::vector<std::vector<double>> steps(n);  // of each scan, every iteration
  for (int it = 0; it < settings.max_iterations; ++it) {
    const Pass pass{scans, poses, centre, settings, false};
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6 * n, 6 * n);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(6 * n);
    std::vector<std::size_t> stale;
    for (std::size_t l = 0; l < 2 * links.size(); ++l) {
      const auto [a, b] = directed(l);
      const Cached& c = cache[l];
      if (!c.valid || moved(c.pa, poses[a]) >= settings.tolerance ||
          moved(c.pb, poses[b]) >= settings.tolerance)
        stale.push_back(l);
    }
    // The stale links' sums, a link a task (the loops inside a link then run on its thread, in
    // the same chunks: the same bits as one link after another on all threads). Measured
    // (2026-11-29, the bracket's ring, the same poses to the bit): the stage 2.0 × faster on 2
    // threads than on one, where parallel loops inside each link made 1.5 × (551 -> 385 ms).
    parallel_tasks(stale.size(), settings.threads, [&](std::size_t t) {
      const std::size_t l = stale[t];
      const auto [a, b] = directed(l);
      cache[l] = {pass.link(a, b, memory[l]), poses[a], poses[b], true};
    });
    for (std::size_t l = 0; l < 2 * links.size(); ++l) {
      const auto [a, b] = directed(l);
      const LinkSums& s = cache[l].sums;
      H.block<6, 6>(6 * a, 6 * a) += s.aa;
      H.block<6, 6>(6 * a, 6 * b) += s.ab;
      H.block<6, 6>(6 * b, 6 * a) += s.ab.transpose();
      H.block<6, 6>(6 * b, 6 * b) += s.bb;
      g.segment<6>(6 * a) += s.ga;
      g.segment<6>(6 * b) += s.gb;
    }
    // Node 0 and scans in no link stay: their rows and columns become the identity, with no
    // gradient. A tiny ridge keeps a direction no pair constrains (a plane's slide) at rest.
    const double ridge = 1e-12 * std::max(H.trace(), 1e-300);
    for (std::size_t k = 0; k < n; ++k) {
      if (k != 0 && linked[k]) {
        H.block<6, 6>(6 * k, 6 * k).diagonal().array() += ridge;
        continue;
      }
      H.middleRows(6 * k, 6).setZero(), H.middleCols(6 * k, 6).setZero();
      H.block<6, 6>(6 * k, 6 * k).setIdentity(), g.segment<6>(6 * k).setZero();
    }
    const Eigen::VectorXd xi = H.ldlt().solve(-g);
    for (std::size_t k = 0; k < n; ++k) {
      const Eigen::Isometry3d next = update_about(xi.segment<6>(6 * k), centre) * poses[k];
      out.last_step[k] = moved(poses[k], next);
      poses[k] = next;
    }
    out.iterations = it + 1;
    for (std::size_t k = 0; k < n; ++k) steps[k].push_back(out.last_step[k]);
    if (std::all_of(steps.begin(), steps.end(),
                    [&](const auto& h) { return settled(h, settings.tolerance); }))
      break;
  }
  out.residuals.assign(n, {});
  const Pass last{scans, poses, centre, settings, true};
  std::vector<LinkSums> final_sums(2 * links.size());
  parallel_tasks(final_sums.size(), settings.threads, [&](std::size_t l) {
    const auto [a, b] = directed(l);
    final_sums[l] = last.link(a, b, memory[l]);
  });
  for (std::size_t l = 0; l < final_sums.size(); ++l) {
    auto& d = out.residuals[directed(l).first].distances;
    d.insert(d.end(), final_sums[l].distances.begin(), final_sums[l].distances.end());
  }
  for (MultiviewPairs& r : out.residuals) r.count = r.distances.size();
  out.poses = std::move(poses);
  return out;
}

}  // namespace align3d
