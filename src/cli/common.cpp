#include "common.hpp"

#include <optional>
#include <string_view>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "detail/number.hpp"

namespace align3d::cli {

PointCloud load_cloud(const std::filesystem::path& path, std::ostream& err, io::ReadInfo* info) {
  io::ReadInfo read;
  PointCloud cloud = io::read_point_cloud(path, &read);
  if (read.dropped_non_finite > 0)
    err << "align3d: warning: " << path.string() << ": dropped " << read.dropped_non_finite
        << " points with NaN or Inf coordinates\n";
  if (info != nullptr) *info = read;
  return cloud;
}

nlohmann::json to_json(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c) row.push_back(T.matrix()(r, c));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json to_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

void write_json(const std::string& path, const nlohmann::json& report, std::ostream& out) {
  const std::string text = report.dump(2) + "\n";
  if (path == "-") {
    out << text;
    out.flush();
  } else {
    io::write_text_atomically(path, text);
  }
}

Eigen::Vector3d parse_vector(const std::string& text, const std::string& flag) {
  Eigen::Vector3d v;
  std::string_view rest = text;
  for (int i = 0; i < 3; ++i) {
    const std::size_t comma = rest.find(',');
    // Exactly three parts: a fourth ("1,2,3,4") or a trailing comma leaves a comma after the third.
    const bool last = i == 2;
    const std::optional<double> x = (last == (comma == std::string_view::npos))
                                        ? detail::parse_finite(rest.substr(0, comma))
                                        : std::nullopt;
    if (!x) throw UsageError(flag + ": expected X,Y,Z (three finite numbers), got '" + text + "'");
    v[i] = *x;
    if (!last) rest.remove_prefix(comma + 1);
  }
  return v;
}

const CLI::Validator& finite_non_negative() {
  static const CLI::Validator validator(
      [](const std::string& text) -> std::string {
        const std::optional<double> v = detail::parse_finite(text);
        if (v && *v >= 0) return {};
        return "expected a finite non-negative number, got '" + text + "'";
      },
      "finite >= 0");
  return validator;
}

}  // namespace align3d::cli
