// align3d convert IN OUT: between PLY, PCD and XYZ/TXT/CSV (io/point_cloud_io.hpp).
#include <optional>
#include <string_view>
#include <utility>

#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct ConvertOptions {
  std::string input, output, encoding;
};

// Sets `out` to the encoding named `name` in `table`; false if the table has no such name.
template <typename E, std::size_t kSize>
bool set_encoding(const std::pair<std::string_view, E> (&table)[kSize], std::string_view name,
                  E& out) {
  for (const auto& [key, value] : table) {
    if (key == name) {
      out = value;
      return true;
    }
  }
  return false;
}

// The WriteSettings for OUT's format with --encoding applied (throws UsageError for an encoding
// the format lacks, or any encoding for .xyz/.txt/.csv).
io::WriteSettings write_settings(io::CloudFormat format, const std::string& encoding) {
  using io::PcdEncoding;
  using io::PlyEncoding;
  static constexpr std::pair<std::string_view, PlyEncoding> kPly[] = {
      {"ascii", PlyEncoding::kAscii},
      {"binary", PlyEncoding::kBinaryLittleEndian},
      {"binary_little_endian", PlyEncoding::kBinaryLittleEndian},
      {"binary_big_endian", PlyEncoding::kBinaryBigEndian}};
  static constexpr std::pair<std::string_view, PcdEncoding> kPcd[] = {
      {"ascii", PcdEncoding::kAscii},
      {"binary", PcdEncoding::kBinary},
      {"binary_compressed", PcdEncoding::kBinaryCompressed}};
  io::WriteSettings settings;
  if (encoding.empty()) return settings;
  if (format == io::CloudFormat::kPly && !set_encoding(kPly, encoding, settings.ply)) {
    throw UsageError("--encoding: PLY has no encoding '" + encoding +
                     "' (ascii, binary, binary_big_endian)");
  }
  if (format == io::CloudFormat::kPcd && !set_encoding(kPcd, encoding, settings.pcd)) {
    throw UsageError("--encoding: PCD has no encoding '" + encoding +
                     "' (ascii, binary, binary_compressed)");
  }
  if (format == io::CloudFormat::kXyz) {
    throw UsageError("--encoding: .xyz, .txt and .csv files are text and have no encoding");
  }
  return settings;
}

std::string_view encoding_name(io::CloudFormat format, const io::WriteSettings& s) {
  switch (format) {
    case io::CloudFormat::kPly:
      return s.ply == io::PlyEncoding::kAscii                ? "ascii"
             : s.ply == io::PlyEncoding::kBinaryLittleEndian ? "binary little-endian"
                                                             : "binary big-endian";
    case io::CloudFormat::kPcd:
      return s.pcd == io::PcdEncoding::kAscii    ? "ascii"
             : s.pcd == io::PcdEncoding::kBinary ? "binary"
                                                 : "binary_compressed";
    case io::CloudFormat::kXyz:
      break;
  }
  return "text";
}

}  // namespace

Command add_convert(CLI::App& app, Streams io) {
  auto o = std::make_shared<ConvertOptions>();
  CLI::App* sub = app.add_subcommand(
      "convert",
      "Convert IN to OUT; each file's format is its extension: .ply, .pcd, or .xyz/.txt/.csv\n"
      "(text, one point a row). Normals are kept when OUT's format holds them (PLY, PCD).\n"
      "Points with a NaN or Inf coordinate are dropped, with a warning: an organized PCD\n"
      "becomes unorganized. A PCD's VIEWPOINT is kept when OUT is a PCD. Coordinates are\n"
      "stored as float32 in PLY and PCD, %.9g in text. OUT is written atomically.");
  sub->add_option("IN", o->input, "Input cloud (.ply .pcd .xyz .txt .csv)")->required();
  sub->add_option("OUT", o->output, "Output cloud (.ply .pcd .xyz .txt .csv)")->required();
  sub->add_option("--encoding", o->encoding,
                  "Encoding of OUT. PLY: ascii, binary (little-endian; the default) or "
                  "binary_big_endian. PCD: ascii, binary (the default) or binary_compressed "
                  "(LZF). Text formats have none");
  return {
      sub, [o, io] {
        const std::optional<io::CloudFormat> format = io::cloud_format(o->output);
        if (!format) {
          throw OutputError(o->output +
                            ": cannot write: unknown point cloud format (expected .ply, .pcd, "
                            ".xyz, .txt or .csv)");
        }
        io::WriteSettings settings = write_settings(*format, o->encoding);
        io::ReadInfo info;
        const PointCloud cloud = load_cloud(o->input, io.err, &info);
        settings.pcd_layout.viewpoint = info.viewpoint;
        if (cloud.has_normals() && *format == io::CloudFormat::kXyz) {
          io.err << "align3d: warning: " << o->output << ": text holds no normals; the "
                 << cloud.size() << " normals of " << o->input << " are not written\n";
        }
        io::write_point_cloud(o->output, cloud, settings);
        io.out << "converted " << o->input << " to " << o->output << " ("
               << encoding_name(*format, settings) << "): " << cloud.size() << " points"
               << (cloud.has_normals() && *format != io::CloudFormat::kXyz ? " with normals" : "")
               << "\n";
        return 0;
      }};
}

}  // namespace align3d::cli
