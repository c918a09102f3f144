#include "align3d/io/ply_attributes.hpp"

#include <cctype>
#include <set>
#include <stdexcept>

#include "align3d/io/atomic_file.hpp"
#include "io_detail.hpp"

namespace align3d::io {
namespace {

template <class T>
void check_property(const std::string& name, const std::vector<T>& values, std::size_t points,
                    std::set<std::string>& names) {
  const bool identifier =
      !name.empty() && std::all_of(name.begin(), name.end(),
                                   [](unsigned char c) { return std::isalnum(c) || c == '_'; });
  if (!identifier || !names.insert(name).second)
    throw std::invalid_argument("write_ply: bad or repeated property name '" + name + "'");
  if (values.size() != points)
    throw std::invalid_argument("write_ply: property '" + name + "' has " +
                                std::to_string(values.size()) + " values for " +
                                std::to_string(points) + " points");
}

void check(const std::vector<Eigen::Vector3d>& positions, const PlyAttributes& a) {
  std::set<std::string> names = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue"};
  if (!a.normals.empty() && a.normals.size() != positions.size())
    throw std::invalid_argument("write_ply: " + std::to_string(a.normals.size()) + " normals for " +
                                std::to_string(positions.size()) + " points");
  for (const auto& [name, values] : a.scalars)
    check_property(name, values, positions.size(), names);
  for (const auto& [name, values] : a.ints) check_property(name, values, positions.size(), names);
  for (const auto& [name, values] : a.bytes) check_property(name, values, positions.size(), names);
  if (!a.colors.empty() && a.colors.size() != positions.size())
    throw std::invalid_argument("write_ply: " + std::to_string(a.colors.size()) + " colours for " +
                                std::to_string(positions.size()) + " points");
}

}  // namespace

void write_ply(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& positions,
               const PlyAttributes& a) {
  check(positions, a);
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by align3d\n";
  header += "element vertex " + std::to_string(positions.size()) +
            "\nproperty float x\nproperty float y\nproperty float z\n";
  if (!a.normals.empty()) header += "property float nx\nproperty float ny\nproperty float nz\n";
  for (const auto& scalar : a.scalars) header += "property float " + scalar.first + "\n";
  for (const auto& integer : a.ints) header += "property int " + integer.first + "\n";
  for (const auto& byte : a.bytes) header += "property uchar " + byte.first + "\n";
  if (!a.colors.empty())
    header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header += "end_header\n";
  const bool swap = detail::kHostIsBigEndian;
  write_atomically(path, [&](std::ostream& out) {
    detail::ChunkedOutput output(out);
    std::string& buffer = output.buffer();
    buffer += header;
    for (std::size_t i = 0; i < positions.size(); ++i) {
      for (int k = 0; k < 3; ++k)
        detail::append_bytes(buffer, detail::to_float(positions[i][k]), swap);
      if (!a.normals.empty())
        for (int k = 0; k < 3; ++k)
          detail::append_bytes(buffer, detail::to_float(a.normals[i][k]), swap);
      for (const auto& scalar : a.scalars) detail::append_bytes(buffer, scalar.second[i], swap);
      for (const auto& integer : a.ints) detail::append_bytes(buffer, integer.second[i], swap);
      for (const auto& byte : a.bytes) buffer += static_cast<char>(byte.second[i]);
      if (!a.colors.empty())
        for (std::uint8_t c : a.colors[i]) buffer += static_cast<char>(c);
      output.maybe_flush();
    }
    output.flush();
  });
}

}  // namespace align3d::io
