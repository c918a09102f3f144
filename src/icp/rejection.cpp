#include "align3d/icp/rejection.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "align3d/icp/correspondences.hpp"
#include "detail/number.hpp"

namespace align3d {

double rejection_threshold(const RejectionRule& rule, std::vector<double>& distances) {
  switch (rule.kind) {
    case RejectionRule::Kind::kDistance:
      return rule.distance;
    case RejectionRule::Kind::kNone:
      return std::numeric_limits<double>::infinity();
    case RejectionRule::Kind::kAuto:
      throw std::invalid_argument(
          "rejection 'auto' is a schedule (icp/refine.hpp), not a threshold");
    case RejectionRule::Kind::kMedian: {
      if (distances.empty()) return rule.floor;
      // The chapter's sorted[size / 2]: the upper median.
      auto mid = distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2);
      std::nth_element(distances.begin(), mid, distances.end());
      return std::max(rule.factor * *mid, rule.floor);
    }
  }
  return 0.0;
}

double rejection_threshold(const RejectionRule& rule, const Correspondences& pairs) {
  thread_local std::vector<double> found;
  found.clear();
  if (rule.kind == RejectionRule::Kind::kMedian)
    for (double d : pairs.distance)
      if (std::isfinite(d)) found.push_back(d);
  return rejection_threshold(rule, found);
}

namespace {

double parse_positive(const std::string& text, const std::string& what, bool allow_zero) {
  const std::optional<double> v = detail::parse_finite(text);
  if (!v || *v < 0 || (!allow_zero && *v == 0))
    throw std::invalid_argument(what + " must be a " + (allow_zero ? "non-negative" : "positive") +
                                " number, got '" + text + "'");
  return *v;
}

}  // namespace

RejectionRule parse_rejection_rule(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string part; std::getline(ss, part, ':');) parts.push_back(part);
  if (parts.empty()) throw std::invalid_argument("empty rejection rule");
  const std::string& kind = parts[0];
  if (kind == "auto" && parts.size() == 1) return RejectionRule::automatic();
  if (kind == "none" && parts.size() == 1) return RejectionRule::none();
  if (kind == "distance" && parts.size() == 2)
    return RejectionRule::max_distance(parse_positive(parts[1], "distance D", false));
  if (kind == "median" && parts.size() <= 3) {
    const double factor = parts.size() > 1 ? parse_positive(parts[1], "median FACTOR", false) : 2.5;
    const double floor = parts.size() > 2 ? parse_positive(parts[2], "median FLOOR", true) : 0.0;
    return RejectionRule::median(factor, floor);
  }
  throw std::invalid_argument("unknown rejection rule '" + text +
                              "' (expected auto, median[:FACTOR[:FLOOR]], distance:D or none)");
}

std::string to_string(const RejectionRule& rule) {
  std::ostringstream out;
  switch (rule.kind) {
    case RejectionRule::Kind::kMedian:
      out << "median:" << rule.factor;
      if (rule.floor > 0) out << ":" << rule.floor;
      break;
    case RejectionRule::Kind::kDistance:
      out << "distance:" << rule.distance;
      break;
    case RejectionRule::Kind::kNone:
      out << "none";
      break;
    case RejectionRule::Kind::kAuto:
      out << "auto";
      break;
  }
  return out.str();
}

}  // namespace align3d
