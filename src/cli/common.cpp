#include "common.hpp"

#include <cmath>
#include <sstream>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/io/point_cloud_io.hpp"

namespace align3d::cli {

PointCloud load_cloud(const std::filesystem::path& path, std::ostream& err) {
  io::ReadInfo info;
  PointCloud cloud = io::read_point_cloud(path, &info);
  if (info.dropped_non_finite > 0)
    err << "align3d: warning: " << path.string() << ": dropped " << info.dropped_non_finite
        << " points with NaN or Inf coordinates\n";
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
  std::stringstream ss(text);
  std::string part;
  int i = 0;
  for (; std::getline(ss, part, ',') && i < 4; ++i) {
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != part.size() || !std::isfinite(x) || i == 3)
      throw UsageError(flag + ": expected X,Y,Z (three finite numbers), got '" + text + "'");
    v[i] = x;
  }
  if (i != 3)
    throw UsageError(flag + ": expected X,Y,Z (three finite numbers), got '" + text + "'");
  return v;
}

}  // namespace align3d::cli
