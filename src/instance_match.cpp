#include "align3d/instance_match.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "align3d/kdtree.hpp"

namespace align3d {

AddS::AddS(std::vector<Eigen::Vector3d> model_points, int threads)
    : points_(std::move(model_points)) {
  if (points_.empty()) throw std::invalid_argument("AddS: no model points");
  for (const Eigen::Vector3d& p : points_)
    if (!p.allFinite()) throw std::invalid_argument("AddS: a model point is not finite");
  tree_ = std::make_unique<KdTree>(points_, threads);
}

AddS::~AddS() = default;

double AddS::operator()(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b) const {
  const Eigen::Isometry3d D = T_b.inverse() * T_a;
  double sum = 0;
  Neighbor nearest;
  for (const Eigen::Vector3d& x : points_) {
    tree_->nearest(D * x, nearest);
    sum += std::sqrt(nearest.sq_distance);
  }
  return sum / static_cast<double>(points_.size());
}

double InstanceMatch::recall() const {
  return counted == 0 ? 1.0 : static_cast<double>(true_positives) / static_cast<double>(counted);
}

double InstanceMatch::precision() const {
  const std::size_t claimed = true_positives + false_positives;
  return claimed == 0 ? 1.0 : static_cast<double>(true_positives) / static_cast<double>(claimed);
}

InstanceMatch match_instances(const AddS& add_s, const std::vector<Eigen::Isometry3d>& found,
                              const std::vector<TrueInstance>& truth, double max_error,
                              double min_visible) {
  InstanceMatch m;
  for (const TrueInstance& t : truth) m.counted += t.visible_fraction >= min_visible ? 1 : 0;
  std::vector<bool> taken(truth.size(), false);
  for (const Eigen::Isometry3d& T : found) {
    int best = -1;
    double best_error = std::numeric_limits<double>::infinity(), nearest = best_error;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      const double e = add_s(T, truth[k].T_scene_model);
      nearest = std::min(nearest, e);
      if (!taken[k] && e < max_error && e < best_error) {
        best = static_cast<int>(k);
        best_error = e;
      }
    }
    m.match.push_back(best);
    m.error.push_back(best >= 0 ? best_error : nearest);
    if (best < 0) {
      ++m.false_positives;
      continue;
    }
    taken[static_cast<std::size_t>(best)] = true;
    if (truth[static_cast<std::size_t>(best)].visible_fraction >= min_visible)
      ++m.true_positives;
    else
      ++m.excused;
  }
  return m;
}

}  // namespace align3d
