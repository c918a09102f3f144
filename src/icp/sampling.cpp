#include "align3d/icp/sampling.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstddef>
#include <numeric>
#include <stdexcept>

#include "align3d/se3.hpp"

namespace align3d {

namespace {

// H's pseudo-inverse: directions of eigenvalue below 1e-12 of the largest (a plane's free ones)
// count as held by no point.
Matrix6d pseudo_inverse(const Matrix6d& H) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(H);
  const Vector6d& values = eig.eigenvalues();
  Matrix6d out = Matrix6d::Zero();
  for (int i = 0; i < 6; ++i)
    if (values(i) > 1e-12 * values(5))
      out.noalias() +=
          eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose() / values(i);
  return out;
}

}  // namespace

std::vector<std::uint32_t> stable_sample(const PointCloud& cloud, double share, double top) {
  if (!(share >= 0 && share <= 1) || !(top >= 0 && top <= 1))
    throw std::invalid_argument("stable_sample: shares must lie in [0, 1]");
  const std::size_t n = cloud.size();
  if (n > 0 && !cloud.has_normals())
    throw std::invalid_argument("stable_sample: the cloud needs normals");
  std::vector<std::uint32_t> all(n);
  std::iota(all.begin(), all.end(), 0U);
  if (share >= 1 || n == 0) return all;
  const Eigen::Vector3d c = centroid(cloud);
  auto row = [&](std::size_t i) {
    Vector6d j;
    j << (cloud.positions[i] - c).cross(cloud.normals[i]), cloud.normals[i];
    return j;
  };
  Matrix6d H = Matrix6d::Zero();
  for (std::size_t i = 0; i < n; ++i) H.noalias() += row(i) * row(i).transpose();
  const Matrix6d Hp = pseudo_inverse(H);
  std::vector<double> leverage(n);
  for (std::size_t i = 0; i < n; ++i) leverage[i] = row(i).dot(Hp * row(i));
  std::vector<std::uint32_t> order = all;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return leverage[a] > leverage[b]; });
  const auto size = static_cast<double>(n);
  const auto n_top = static_cast<std::size_t>(top * size);
  const auto n_all = std::max(n_top, static_cast<std::size_t>(share * size));
  std::vector<char> in(n, 0);
  for (std::size_t k = 0; k < n_top; ++k) in[order[k]] = 1;
  // Every m-th of the others, m the least step that keeps at most the remaining count.
  const std::size_t others = n - n_top, wanted = n_all - n_top;
  if (wanted > 0) {
    const std::size_t step = (others + wanted - 1) / wanted;
    std::size_t seen = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (!in[i] && seen++ % step == 0) in[i] = 1;
  }
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < n; ++i)
    if (in[i]) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

}  // namespace align3d
