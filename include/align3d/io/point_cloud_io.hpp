// Reading and writing point clouds. The format is chosen by the file extension (case-insensitive):
//   .ply            ascii, binary_little_endian, binary_big_endian; vertex x y z (float or double,
//                   any other scalar type too), nx ny nz when present; other properties and
//                   elements (faces, ...) are skipped.
//   .pcd            ascii, binary, binary_compressed (LZF); fields x y z, normal_x/y/z when
//                   present.
//   .xyz .txt .csv  one point per row: three numbers (separated by spaces, tabs, commas or
//                   semicolons), further columns ignored; blank lines and lines starting with '#'
//                   skipped.
// Any other extension is an IoError.
//
// Contract for every reader: a missing, unreadable, malformed or truncated file throws IoError
// whose message starts with the file name and names the problem and, for parse errors, the line
// (text) or byte offset (binary). Counts announced by a header are checked against the file's real
// size before anything is allocated; a text line longer than a bound (64 KiB for a .xyz row, 1 MiB
// for a PLY/PCD ascii record or header) is an IoError too. Points with a NaN or Inf coordinate are
// dropped and counted in ReadInfo::dropped_non_finite; normals that are non-finite or zero make the
// cloud's normals absent. Other normals are normalised. A file that yields no point (none
// announced, or all dropped) is an IoError "contains no points" (ReadInfo is filled in first). Text
// numbers are read independently of the locale; in .xyz/.txt/.csv a run of separators counts as
// one, and a first row that does not start with a number (a CSV header such as "x,y,z") is skipped.
// Text lines end with '\n', "\r\n" or '\r' alone (classic Mac OS), whichever ends the first line.
// A float32 property (PLY float, PCD F 4) is rounded to float32 even when written as text, so a
// cloud reads the same from every encoding.
//
// Files are streamed through a 4 MiB buffer, so reading costs the cloud (24 bytes a point, 48 with
// normals) plus a constant, whatever the file's size; a .xyz/.txt/.csv file is read twice, first to
// count its rows. Running out of memory while reading is a DataError (not an IoError: the file is
// fine) whose message names the file and what was being allocated.
//
// Every writer is atomic: it writes a temporary file in the destination's folder and renames it, so
// the destination holds either the complete new file or whatever it held before (OutputError on
// failure).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "align3d/point_cloud.hpp"

namespace align3d::io {

// The pose a PCD file records for the sensor (VIEWPOINT tx ty tz qw qx qy qz): its position and
// orientation in the cloud's frame. Neither align3d nor PCL applies it to the points.
struct Viewpoint {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // unit
};

struct ReadInfo {
  std::size_t dropped_non_finite = 0;  // points dropped because a coordinate was NaN or Inf
  // The file's points as width x height, the dropped ones included: a PCD's WIDTH and HEIGHT (an
  // organized cloud, HEIGHT > 1, lists its rows one after another); other formats: the count, 1.
  std::size_t width = 0;
  std::size_t height = 0;
  Viewpoint viewpoint;  // a PCD's VIEWPOINT; other formats: the identity
  // An organized PCD (HEIGHT > 1): the index in the file (row-major, v·WIDTH + u: the pixel) of
  // each point read; otherwise empty.
  std::vector<std::uint32_t> indices;
};

PointCloud read_point_cloud(const std::filesystem::path& path, ReadInfo* info = nullptr);

// Where a file says its sensor was, in the cloud's frame: a PCD's VIEWPOINT away from the origin,
// or the origin of an organized cloud (a depth camera's image, in that camera's frame); nothing
// otherwise (most PLY, XYZ and OBJ exports; a VIEWPOINT at the origin is what writers put when
// they know none).
std::optional<Eigen::Vector3d> sensor_position(const ReadInfo& info);

enum class CloudFormat { kPly, kPcd, kXyz };
// The format that `path`'s extension names (.ply; .pcd; .xyz, .txt, .csv; in any case), or nullopt.
std::optional<CloudFormat> cloud_format(const std::filesystem::path& path);

enum class PlyEncoding { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

// Writes float32 x y z (and nx ny nz when the cloud has normals) as a single vertex element.
// Coordinates in float32 keep ~7 significant digits: 0.1 µm at 1 m, ample for scanner data.
void write_ply(const std::filesystem::path& path, const PointCloud& cloud,
               PlyEncoding encoding = PlyEncoding::kBinaryLittleEndian);

// How write_pcd lays the points out, and the sensor pose it records.
struct PcdLayout {
  // 0 x 0: unorganized, WIDTH = the points written, HEIGHT 1; a point with a NaN or Inf coordinate
  // is left out. Otherwise an organized cloud (a depth camera's image): width * height must be the
  // cloud's size (else std::invalid_argument), row after row, every point written in its place,
  // NaN ones included (pixels without a return; readers drop and count them).
  std::size_t width = 0;
  std::size_t height = 0;
  Viewpoint viewpoint;  // VIEWPOINT, written exactly (17 digits)
};

// Writes float32 x y z (and normal_x/y/z when the cloud has normals). binary_compressed stores its
// sizes as uint32, so it holds at most 4 GiB of data (~178 million points with normals); larger
// clouds are an OutputError there.
void write_pcd(const std::filesystem::path& path, const PointCloud& cloud,
               PcdEncoding encoding = PcdEncoding::kBinary, const PcdLayout& layout = {});
void write_xyz(const std::filesystem::path& path,
               const PointCloud& cloud);  // %.9g, one point a row

// The choices write_point_cloud leaves to the caller, each for its format.
struct WriteSettings {
  PlyEncoding ply = PlyEncoding::kBinaryLittleEndian;  // for .ply
  PcdEncoding pcd = PcdEncoding::kBinary;              // for .pcd
  PcdLayout pcd_layout;                                // for .pcd
};

// The settings that write `format` in the encoding named `encoding`: PLY ascii, binary (or
// binary_little_endian; the default) or binary_big_endian; PCD ascii, binary (the default) or
// binary_compressed; empty: the defaults. std::invalid_argument for a name the format lacks, and
// for any name with .xyz/.txt/.csv (text has no encoding). `align3d convert --encoding` and the
// Python binding name encodings this way.
WriteSettings write_settings(CloudFormat format, const std::string& encoding);
// How `settings` encode `format`, for people: "ascii", "binary little-endian", ..., "text".
std::string_view encoding_name(CloudFormat format, const WriteSettings& settings);

// Writes by extension: .ply, .pcd as `settings` say, .xyz/.txt/.csv text (separated by spaces, also
// for .csv). Any other extension is an OutputError, and nothing is written.
void write_point_cloud(const std::filesystem::path& path, const PointCloud& cloud,
                       const WriteSettings& settings = {});

}  // namespace align3d::io
