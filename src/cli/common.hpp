// Pieces shared by the subcommands (private to the tool).
#pragma once

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

#include "align3d/io/point_cloud_io.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d::cli {

struct Streams {
  std::ostream& out;
  std::ostream& err;
};

// Reads a cloud, warning on `err` about dropped non-finite points; `info` receives what the reader
// reports.
PointCloud load_cloud(const std::filesystem::path& path, std::ostream& err,
                      io::ReadInfo* info = nullptr);

nlohmann::json to_json(const Eigen::Isometry3d& T);  // 4 arrays of 4 numbers, row-major
nlohmann::json to_json(const Eigen::Vector3d& v);

// Writes `report` to `path` ("-" = `out`), pretty-printed, atomically for files.
void write_json(const std::string& path, const nlohmann::json& report, std::ostream& out);

// Parses "X,Y,Z": exactly three finite numbers (throws UsageError naming `flag`).
Eigen::Vector3d parse_vector(const std::string& text, const std::string& flag);

// For numeric options: CLI11's NonNegativeNumber (and PositiveNumber) let "nan" through (every
// comparison with NaN is false) and accept "inf"; this requires a finite number >= 0.
const CLI::Validator& finite_non_negative();

// Subcommands: each adds itself to `app` and returns the runner to call once parsing chose it.
struct Command {
  CLI::App* app;
  std::function<int()> run;
};
Command add_register(CLI::App& app, Streams io);
Command add_synth(CLI::App& app, Streams io);
Command add_rectify(CLI::App& app, Streams io);
Command add_demo(CLI::App& app, Streams io);
Command add_ppf_model(CLI::App& app, Streams io);
Command add_evaluate(CLI::App& app, Streams io);
Command add_convert(CLI::App& app, Streams io);

}  // namespace align3d::cli
