// Correspondence rejection (chapter 39.1 step 2): a pair is kept when its nearest-neighbour
// distance is <= the iteration's threshold. Distances are true (not squared) Euclidean distances.
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace align3d {

struct RejectionRule {
  enum class Kind {
    kMedian,    // threshold = max(factor · median distance, floor)   (the chapter's rule)
    kDistance,  // threshold = distance
    kNone,      // keep every pair
    kAuto,      // not one rule but the coarse-to-fine schedule of icp/refine.hpp, which runs ICP
                // with distance rules derived from the data; icp() alone rejects it
  };
  Kind kind = Kind::kMedian;
  double factor = 2.5;
  double floor = 0.0;     // data units; the chapter uses 0.5 mm
  double distance = 0.0;  // data units, for kDistance

  static RejectionRule median(double factor = 2.5, double floor = 0.0) {
    return {Kind::kMedian, factor, floor, 0.0};
  }
  static RejectionRule max_distance(double d) { return {Kind::kDistance, 0.0, 0.0, d}; }
  static RejectionRule none() { return {Kind::kNone, 0.0, 0.0, 0.0}; }
  static RejectionRule automatic() { return {Kind::kAuto, 0.0, 0.0, 0.0}; }

  // An upper bound on the threshold known before the search (infinity for the median rule), used to
  // bound the nearest-neighbour search.
  double search_bound() const {
    return kind == Kind::kDistance ? distance : std::numeric_limits<double>::infinity();
  }
};

// The threshold for one iteration given the distances of all found pairs (reordered in place).
// std::invalid_argument for kAuto.
double rejection_threshold(const RejectionRule& rule, std::vector<double>& distances);

// The same for the pairs found by find_correspondences (pairs beyond the search bound excluded).
struct Correspondences;
double rejection_threshold(const RejectionRule& rule, const Correspondences& pairs);

// "auto", "median:2.5", "median:2.5:0.5" (factor, floor), "distance:1.2", "none"; "median" alone =
// factor 2.5. Throws std::invalid_argument with a message naming the bad part.
RejectionRule parse_rejection_rule(const std::string& text);
std::string to_string(const RejectionRule& rule);

}  // namespace align3d
