// align3d convert IN OUT: point clouds between PLY, PCD and XYZ/TXT/CSV (io/point_cloud_io.hpp);
// triangle meshes between STL, OBJ, OFF and PLY, STEP and IGES read through OpenCASCADE
// (io/mesh_io.hpp); a mesh's surface sampled into a point cloud (--sample).
#include <optional>
#include <stdexcept>

#include "align3d/error.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/mesh.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct ConvertOptions {
  std::string input, output, encoding;
  std::size_t sample = 0;  // points; 0: not given
  double chord_tolerance = 0;
  bool chord_given = false;
};

const char* const kUnknownCloudOutput =
    "cannot write: unknown point cloud format (expected .ply, .pcd, .xyz, .txt or .csv)";

io::WriteSettings cloud_settings(io::CloudFormat format, const std::string& encoding) {
  try {
    return io::write_settings(format, encoding);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--encoding: ") + e.what());
  }
}

bool is_cad(const std::string& path) {
  const std::optional<io::MeshFormat> format = io::mesh_format(path);
  return format == io::MeshFormat::kStep || format == io::MeshFormat::kIges;
}

// IN is a point cloud: every format into every other.
int convert_cloud(const ConvertOptions& o, Streams io) {
  const std::optional<io::CloudFormat> format = io::cloud_format(o.output);
  if (!format) {
    // A mesh format (.stl, .obj, .off) as OUT: say why it cannot be one here.
    throw OutputError(
        o.output, std::string(kUnknownCloudOutput) +
                      (io::mesh_format(o.output)
                           ? "; a mesh format needs a mesh as IN, and " + o.input + " has no faces"
                           : ""));
  }
  io::WriteSettings settings = cloud_settings(*format, o.encoding);
  io::ReadInfo info;
  const PointCloud cloud = load_cloud(o.input, io.err, &info);
  settings.pcd_layout.viewpoint = info.viewpoint;
  if (cloud.has_normals() && *format == io::CloudFormat::kXyz) {
    io.err << "align3d: warning: " << o.output << ": text holds no normals; the " << cloud.size()
           << " normals of " << o.input << " are not written\n";
  }
  io::write_point_cloud(o.output, cloud, settings);
  io.out << "converted " << o.input << " to " << o.output << " ("
         << io::encoding_name(*format, settings) << "): " << cloud.size() << " points"
         << (cloud.has_normals() && *format != io::CloudFormat::kXyz ? " with normals" : "")
         << "\n";
  return 0;
}

const char* mesh_encoding(io::MeshFormat format) {
  switch (format) {
    case io::MeshFormat::kStl:
      return "binary STL";
    case io::MeshFormat::kPly:
      return "binary little-endian";
    default:
      return "text";
  }
}

// IN is a mesh: into a mesh format, or sampled into a point cloud (--sample). The command line is
// checked before IN is read, which may take long (STEP).
int convert_mesh(const ConvertOptions& o, Streams io) {
  const std::optional<io::MeshFormat> mesh_out = io::mesh_format(o.output);
  const std::optional<io::CloudFormat> cloud_out = io::cloud_format(o.output);
  io::WriteSettings settings;
  if (o.sample > 0) {
    if (!cloud_out) throw OutputError(o.output, kUnknownCloudOutput + std::string(" for --sample"));
    settings = cloud_settings(*cloud_out, o.encoding);
  } else if (cloud_out && !mesh_out) {
    throw UsageError(o.input + " is a triangle mesh and " + o.output +
                     " a point cloud format: choose how many points to sample from its surface "
                     "with --sample N");
  } else if (!mesh_out || is_cad(o.output)) {
    throw OutputError(o.output,
                      "cannot write: unknown mesh format (expected .stl, .obj, .ply or "
                      ".off; STEP and IGES are read only)");
  } else if (!o.encoding.empty()) {
    throw UsageError(
        "--encoding: a mesh is written in its format's one encoding (STL and PLY "
        "binary, OBJ and OFF text); it applies with --sample");
  }
  if (o.chord_given && !is_cad(o.input)) {
    throw UsageError("--chord-tolerance: applies to STEP and IGES input only, not " + o.input);
  }
  io::MeshReadSettings read_settings;
  read_settings.chord_tolerance = o.chord_tolerance;
  io::MeshReadInfo info;
  const TriangleMesh mesh = io::read_mesh(o.input, read_settings, &info);
  if (info.dropped_faces > 0) {
    io.err << "align3d: warning: " << o.input << ": dropped " << info.dropped_faces
           << " faces with fewer than 3 corners or a repeated corner\n";
  }
  io.out << "converted " << o.input;
  if (info.chord_tolerance > 0) io.out << " (chord tolerance " << info.chord_tolerance << ")";
  if (o.sample == 0) {
    io::write_mesh(o.output, mesh);
    io.out << " to " << o.output << " (" << mesh_encoding(*mesh_out)
           << "): " << mesh.triangles.size() << " triangles, " << mesh.vertices.size()
           << " vertices\n";
    return 0;
  }
  // Cleaned first, so that each normal points out of a closed part (mesh.hpp: files mix windings).
  const PointCloud cloud = sample_surface(clean_mesh(mesh), o.sample);
  if (cloud.empty()) throw DataError(o.input, "the mesh has no area to sample points from");
  io::write_point_cloud(o.output, cloud, settings);
  io.out << " to " << o.output << " (" << io::encoding_name(*cloud_out, settings)
         << "): " << cloud.size() << " points"
         << (*cloud_out != io::CloudFormat::kXyz ? " with normals" : "") << " sampled from "
         << mesh.triangles.size() << " triangles\n";
  return 0;
}

}  // namespace

Command add_convert(CLI::App& app, Streams io) {
  auto o = std::make_shared<ConvertOptions>();
  CLI::App* sub = app.add_subcommand(
      "convert",
      "Convert IN to OUT; each file's format is its extension.\n"
      "Point clouds: .ply, .pcd, or .xyz/.txt/.csv (text, one point a row). Normals are kept\n"
      "when OUT's format holds them (PLY, PCD). Points with a NaN or Inf coordinate are\n"
      "dropped, with a warning: an organized PCD becomes unorganized. A PCD's VIEWPOINT is kept\n"
      "when OUT is a PCD. Coordinates are stored as float32 in PLY and PCD, %.9g in text.\n"
      "Triangle meshes: IN .stl (binary or ASCII), .obj, .off, .ply with a face element, or\n"
      ".step/.stp/.iges/.igs (builds with OpenCASCADE); OUT .stl (binary, float32), .ply\n"
      "(binary, float64), .obj or .off (%.17g). Polygons are split into triangles; faces with\n"
      "fewer than 3 corners or a repeated corner are dropped, with a warning. With --sample N,\n"
      "N points with normals spread evenly over the mesh's surface go to a point cloud OUT.\n"
      "OUT is written atomically.");
  sub->add_option("IN", o->input, "Input cloud or mesh (.ply .pcd .xyz .txt .csv .stl .obj .off)")
      ->required();
  sub->add_option("OUT", o->output, "Output cloud or mesh (same extensions)")->required();
  sub->add_option(
      "--encoding", o->encoding,
      "Encoding of a point cloud OUT. PLY: ascii, binary (little-endian; the default) or "
      "binary_big_endian. PCD: ascii, binary (the default) or binary_compressed "
      "(LZF). Text formats have none");
  sub->add_option("--sample", o->sample,
                  "IN a mesh, OUT a point cloud: write N points sampled evenly by area over the "
                  "surface, each with its triangle's outward normal")
      ->check(CLI::PositiveNumber);
  CLI::Option* chord =
      sub->add_option("--chord-tolerance", o->chord_tolerance,
                      "STEP/IGES IN: the largest distance between the triangles and the exact "
                      "surface, in the file's units (default: 1e-4 x the part's diagonal)")
          ->check(CLI::PositiveNumber & finite_non_negative());
  return {sub, [o, io, chord] {
            o->chord_given = chord->count() > 0;
            if (!io::cloud_format(o->input) && !io::mesh_format(o->input)) {
              const std::string ext = std::filesystem::path(o->input).extension().string();
              throw IoError(o->input, "unknown format " +
                                          (ext.empty() ? "(no extension)" : "'" + ext + "'") +
                                          " (point clouds: .ply .pcd .xyz .txt .csv; meshes: .stl "
                                          ".obj .off .ply .step .stp .iges .igs)");
            }
            const bool mesh_in = io::is_mesh_file(o->input) || is_cad(o->input);
            if (mesh_in) return convert_mesh(*o, io);
            if (o->sample > 0) {
              throw UsageError("--sample: applies to a mesh IN; " + o->input +
                               " is not one (a PLY needs a face element)");
            }
            if (o->chord_given) {
              throw UsageError("--chord-tolerance: applies to STEP and IGES input only, not " +
                               o->input);
            }
            return convert_cloud(*o, io);
          }};
}

}  // namespace align3d::cli
