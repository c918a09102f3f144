// align3d convert IN OUT: between PLY, PCD and XYZ/TXT/CSV (io/point_cloud_io.hpp).
#include <optional>
#include <stdexcept>

#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct ConvertOptions {
  std::string input, output, encoding;
};

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
          throw OutputError(o->output,
                            "cannot write: unknown point cloud format (expected .ply, .pcd, "
                            ".xyz, .txt or .csv)");
        }
        io::WriteSettings settings;
        try {
          settings = io::write_settings(*format, o->encoding);
        } catch (const std::invalid_argument& e) {
          throw UsageError(std::string("--encoding: ") + e.what());
        }
        io::ReadInfo info;
        const PointCloud cloud = load_cloud(o->input, io.err, &info);
        settings.pcd_layout.viewpoint = info.viewpoint;
        if (cloud.has_normals() && *format == io::CloudFormat::kXyz) {
          io.err << "align3d: warning: " << o->output << ": text holds no normals; the "
                 << cloud.size() << " normals of " << o->input << " are not written\n";
        }
        io::write_point_cloud(o->output, cloud, settings);
        io.out << "converted " << o->input << " to " << o->output << " ("
               << io::encoding_name(*format, settings) << "): " << cloud.size() << " points"
               << (cloud.has_normals() && *format != io::CloudFormat::kXyz ? " with normals" : "")
               << "\n";
        return 0;
      }};
}

}  // namespace align3d::cli
