// Pieces shared by the subcommands (private to the tool).
#pragma once

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "align3d/align.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/progress.hpp"
#include "align3d/report/json.hpp"
#include "align3d/warning.hpp"

namespace align3d::cli {

struct Streams {
  std::ostream& out;
  std::ostream& err;
};

// Reads a cloud, warning on `err` about dropped non-finite points; `info` receives what the reader
// reports.
PointCloud load_cloud(const std::filesystem::path& path, std::ostream& err,
                      io::ReadInfo* info = nullptr);

// Reads a mesh (io/mesh_io.hpp), warning on `err` about dropped faces.
TriangleMesh load_mesh(const std::filesystem::path& path, std::ostream& err,
                       const io::MeshReadSettings& settings = {}, io::MeshReadInfo* info = nullptr);

// A registration target as given on the command line: a mesh when the file is one
// (io::is_mesh_file: .stl .obj .off .step .iges, or a .ply with faces; registration then uses its
// exact surface), else a point cloud.
struct TargetInput {
  std::optional<TriangleMesh> mesh;
  PointCloud cloud;  // when not a mesh
  report::InputInfo info(const std::string& path) const;
};
TargetInput load_target(const std::filesystem::path& path, std::ostream& err,
                        const io::MeshReadSettings& settings = {});

using report::to_json;     // 4 arrays of 4 numbers, row-major; vectors as 3 numbers
using report::write_json;  // to a file atomically, or to `out` with "-"

// --init: auto, identity, global, or a file with a 4x4 matrix (read here: ICP starts there).
void apply_init(const std::string& init, AlignSettings& settings);
// Declare --init for apply_init (its help ends with `matrix_file`, the command's words for the
// matrix file) and --seed of the global stage (AlignSettings::seed).
void add_init(CLI::App* sub, std::string& init, const std::string& matrix_file);
void add_seed(CLI::App* sub, std::uint64_t& seed);

// --method, --kernel and --kernel-scale of the ICP refinement (CostSettings, refine.hpp), shared
// by the commands that refine; apply_refine_options sets them (CLI11 has checked the names).
struct RefineOptions {
  std::string method = to_string(CostSettings{}.method);
  std::string kernel = kernel_name(CostSettings{});
  double kernel_scale = 0;
};
// The command's words in the help: which ICP runs the method refines, what `--kernel auto` is.
struct RefineHelp {
  std::string method_applies_to;
  std::string auto_kernel;
};
// register and inspect: refine()'s schedule.
RefineHelp schedule_refine_help();
void add_refine_options(CLI::App* sub, RefineOptions& o, const RefineHelp& help);
void apply_refine_options(const RefineOptions& o, CostSettings& s);

// Parses "X,Y,Z": exactly three finite numbers (throws UsageError naming `flag`).
Eigen::Vector3d parse_vector(const std::string& text, const std::string& flag);

// Prints each warning as "align3d: warning: …" on `err`. Returns the exit code the command ends
// with: 0, or ExitCode::kWarnings when `strict` and there are warnings.
int report_warnings(const std::vector<Warning>& warnings, bool strict, std::ostream& err);

// Progress on stderr, redrawn in place at most 5 times a second ("label: task 12/40, 3.1/s,
// ETA 0:08"), shown only when `err` is the process's stderr and that is a terminal, and never
// with --quiet; the line is cleared when the work ends.
class ProgressLine {
 public:
  ProgressLine(std::ostream& err, bool quiet, std::string label);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  ProgressCallback callback();  // empty when nothing is shown
  void update(const Progress& p);
  void set_label(std::string label) { label_ = std::move(label); }

 private:
  using Clock = std::chrono::steady_clock;
  std::ostream& err_;
  bool shown_;
  std::string label_, task_;
  Clock::time_point start_, task_start_, last_draw_;
  std::size_t last_done_ = 0;
  bool drawn_ = false;
};

// Adds --quiet and --threads, shared by the commands that run long work.
void add_quiet(CLI::App* sub, bool& quiet);
void add_threads(CLI::App* sub, int& threads);
// Adds --strict: exit code 7 when the result comes with warnings, every output written first (each
// command writes its outputs before report_warnings gives the code).
void add_strict(CLI::App* sub, bool& strict);
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
Command add_batch(CLI::App& app, Streams io);
Command add_inspect(CLI::App& app, Streams io);
Command add_find(CLI::App& app, Streams io);
Command add_stitch(CLI::App& app, Streams io);

}  // namespace align3d::cli
