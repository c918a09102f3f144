// Pose errors and instance matching as the BOP benchmark scores 6D object detection (Hodaň et al.
// 2016, "On evaluation of 6D object pose estimation"; Hodaň et al. 2018, BOP): what `align3d find`
// is measured with (bench/, tests) against a generator's ground truth.
//
// ADD-S (the average distance for objects with indistinguishable views): the mean, over the model
// points x, of the distance from T_a·x to the nearest point of the model posed by T_b,
//   ADD-S(T_a, T_b) = mean_x min_y ‖T_a·x − T_b·y‖ = mean_x min_y ‖T_b⁻¹·T_a·x − y‖,
// so a symmetric part turned about its axis of symmetry has no error. Units: those of the points.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <memory>
#include <vector>

namespace align3d {

class KdTree;

class AddS {
 public:
  // The model's points (its surface sampled evenly, or its vertices, as BOP uses); at least one,
  // all finite, else std::invalid_argument.
  explicit AddS(std::vector<Eigen::Vector3d> model_points, int threads = 1);
  ~AddS();
  AddS(const AddS&) = delete;
  AddS& operator=(const AddS&) = delete;

  double operator()(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b) const;

 private:
  std::vector<Eigen::Vector3d> points_;
  std::unique_ptr<KdTree> tree_;
};

struct TrueInstance {
  Eigen::Isometry3d T_scene_model = Eigen::Isometry3d::Identity();
  double visible_fraction = 1;  // BOP's visib_fract
};

// BOP's matching, per scene: the found poses in descending score (the order given), each matched
// to the not yet matched true instance of lowest ADD-S, if that is below `max_error`. A true
// instance less visible than `min_visible` does not count for recall, and a found pose matched to
// it is neither a true nor a false positive (it found something real that the criterion excuses).
struct InstanceMatch {
  std::size_t counted = 0;          // true instances at least min_visible visible
  std::size_t true_positives = 0;   // found poses matched to a counted instance
  std::size_t false_positives = 0;  // found poses matched to none
  std::size_t excused = 0;          // found poses matched to a less visible instance
  std::vector<int> match;           // per found pose: the true instance's index, or −1
  std::vector<double> error;        // per found pose: ADD-S to its match (or the nearest), or ∞
  double recall() const;            // true_positives / counted (1 when nothing counts)
  double precision() const;         // true_positives / (true + false positives) (1 when none)
};

InstanceMatch match_instances(const AddS& add_s, const std::vector<Eigen::Isometry3d>& found,
                              const std::vector<TrueInstance>& truth, double max_error,
                              double min_visible = 0.5);

}  // namespace align3d
