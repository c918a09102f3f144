// The hostile-file set (tests/data/hostile, listed in manifest.tsv) run through the `align3d`
// executable as a separate process, as a user would: each file must give the documented exit code
// (README, "Exit codes"), exactly one line on stderr naming the file and the problem, nothing on
// stdout, and no output file (not even a temporary). A crash, a hang (ctest's timeout) or an
// uncaught exception (exit 1) fails. Inputs too large to commit (a 10 MB line) are made here. Mesh
// files run through `align3d convert FILE OUT.ply` ("convert-mesh" in the manifest).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "align3d/io/mesh_io.hpp"
#include "test_util.hpp"

extern char** environ;

namespace align3d {
namespace {

namespace fs = std::filesystem;

const fs::path kHostileDir = fs::path(ALIGN3D_TEST_DATA_DIR) / "hostile";

using test::read_text;
using test::write_text;

struct Process {
  bool exited = false;  // false: killed by a signal (a crash)
  int code = -1;
  std::string out, err;
};

// Runs the align3d executable with `args`, its stdout and stderr going to files in `logs`; with a
// `wrapper` (a program and its arguments, e.g. prlimit), runs that with the executable appended.
Process run_cli(const std::vector<std::string>& args, const fs::path& logs,
                const std::vector<std::string>& wrapper = {}) {
  const fs::path out = logs / "stdout", err = logs / "stderr";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> argv_text = wrapper;
  argv_text.push_back(ALIGN3D_CLI_PATH);
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  Process p;
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return p;
  int status = 0;
  waitpid(pid, &status, 0);
  p.exited = WIFEXITED(status);
  p.code = p.exited ? WEXITSTATUS(status) : -WTERMSIG(status);
  p.out = read_text(out);
  p.err = read_text(err);
  return p;
}

// Two clouds any file can be paired with: the faces of a box around one corner, 300 points.
class Hostile : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir("hostile");
    std::string text;
    for (int i = 0; i < 100; ++i) {
      const double u = (i % 10) * 3.0, v = (i / 10) * 2.0;
      text += std::to_string(u) + " " + std::to_string(v) + " 0\n";
      text += std::to_string(u) + " 0 " + std::to_string(v) + "\n";
      text += "0 " + std::to_string(u) + " " + std::to_string(v) + "\n";
    }
    write_text(*dir_ / "good.xyz", text);
    write_text(*dir_ / "identity.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  }
  static void TearDownTestSuite() { delete dir_; }
  static std::string good() { return (*dir_ / "good.xyz").string(); }

  // Runs `command` (as in manifest.tsv) on `file` and checks the error contract.
  static void expect_rejected(const std::string& file, const std::string& command, int expected,
                              const std::string& phrase) {
    test::TempDir out("hostile_out");
    test::TempDir logs("hostile_logs");
    const std::string aligned = (out / "aligned.ply").string();
    const std::string report = (out / "report.json").string();
    std::vector<std::string> args;
    if (command == "register") {
      args = {"register", file, good()};
    } else if (command == "target") {
      args = {"register", good(), file};
    } else if (command == "init" || command == "ground-truth") {
      args = {"register", good(), good(), "--" + command, file};
    } else if (command == "rectify") {
      args = {"rectify", file};
    } else if (command != "convert-mesh") {
      FAIL() << "unknown command '" << command << "' for " << file;
    }
    if (command == "convert-mesh") {
      args = {"convert", file, (out / "mesh.ply").string()};
    } else {
      args.insert(args.end(), {"--output", aligned, "--report", report});
    }
    const Process p = run_cli(args, logs.path());
    ASSERT_TRUE(p.exited) << file << ": killed by signal " << -p.code << "\n" << p.err;
    EXPECT_EQ(p.code, expected) << p.err;
    EXPECT_EQ(std::count(p.err.begin(), p.err.end(), '\n'), 1) << p.err;
    EXPECT_EQ(p.err.rfind("align3d: ", 0), 0u) << p.err;
    EXPECT_NE(p.err.find(file), std::string::npos)
        << "the message does not name the file: " << p.err;
    EXPECT_NE(p.err.find(phrase), std::string::npos) << "expected '" << phrase << "' in " << p.err;
    EXPECT_EQ(p.out, "");
    EXPECT_TRUE(fs::is_empty(out.path())) << "an output file was written";
  }

  static test::TempDir* dir_;
};
test::TempDir* Hostile::dir_ = nullptr;

struct ManifestRow {
  std::string file, command;
  int exit_code = 0;
  std::string phrase;
};

void PrintTo(const ManifestRow& row, std::ostream* os) { *os << row.file << " " << row.command; }

std::vector<ManifestRow> manifest() {
  std::vector<ManifestRow> rows;
  std::ifstream in(kHostileDir / "manifest.tsv");
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string cell; std::getline(s, cell, '\t');) cells.push_back(cell);
    if (cells.size() != 4) {
      ADD_FAILURE() << "manifest.tsv: expected 4 tab-separated columns: " << line;
      continue;
    }
    rows.push_back({cells[0], cells[1], std::stoi(cells[2]), cells[3]});
  }
  return rows;
}

class HostileFile : public Hostile, public ::testing::WithParamInterface<ManifestRow> {};

TEST_P(HostileFile, IsRejectedWithTheDocumentedCodeAndOneLine) {
  const ManifestRow& row = GetParam();
  ASSERT_TRUE(fs::is_regular_file(kHostileDir / row.file)) << row.file;
  // Without OpenCASCADE every STEP and IGES file gives the same error, not the row's.
  const std::optional<io::MeshFormat> format = io::mesh_format(row.file);
  if ((format == io::MeshFormat::kStep || format == io::MeshFormat::kIges) &&
      !io::has_cad_exchange()) {
    GTEST_SKIP() << "built without OpenCASCADE (ALIGN3D_OCCT)";
  }
  expect_rejected((kHostileDir / row.file).string(), row.command, row.exit_code, row.phrase);
}

INSTANTIATE_TEST_SUITE_P(Manifest, HostileFile, ::testing::ValuesIn(manifest()),
                         [](const auto& info) {
                           std::string name = info.param.file + "_" + info.param.command;
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });

TEST_F(Hostile, EveryFileIsInTheManifest) {
  std::vector<std::string> listed;
  for (const auto& row : manifest()) listed.push_back(row.file);
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(kHostileDir)) {
    const std::string name = entry.path().filename().string();
    if (name == "manifest.tsv" || name == "make_hostile.py") continue;
    ++files;
    EXPECT_NE(std::find(listed.begin(), listed.end(), name), listed.end()) << name;
  }
  EXPECT_GE(files, 30u);
}

// ---- made here rather than committed ----

const std::string kTenMegabytes(10u << 20, '7');

TEST_F(Hostile, TenMegabyteLineInAnXyzFile) {
  test::TempDir d("long");
  write_text(d / "long.xyz", "1 2 3\n" + kTenMegabytes + "\n4 5 6\n");
  expect_rejected((d / "long.xyz").string(), "register", 3, "line 2 is longer than 65536 bytes");
}

TEST_F(Hostile, TenMegabyteLineInAnAsciiPly) {
  test::TempDir d("long");
  write_text(d / "long.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n" +
                 kTenMegabytes + " 1 2\n");
  expect_rejected((d / "long.ply").string(), "rectify", 3, "line 8 is longer than 1048576 bytes");
}

TEST_F(Hostile, TenMegabyteLineInAPlyHeader) {
  test::TempDir d("long");
  write_text(d / "long.ply", "ply\nformat ascii 1.0\ncomment " + kTenMegabytes + "\nend_header\n");
  expect_rejected((d / "long.ply").string(), "register", 3, "header longer than 1 MiB");
}

TEST_F(Hostile, TenMegabyteLineInAnAsciiPcd) {
  test::TempDir d("long");
  write_text(d / "long.pcd",
             "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 " + kTenMegabytes);
  expect_rejected((d / "long.pcd").string(), "target", 3, "line 6 is longer than 1048576 bytes");
}

TEST_F(Hostile, TenMegabyteMatrix) {
  test::TempDir d("long");
  write_text(d / "long.txt", kTenMegabytes);
  expect_rejected((d / "long.txt").string(), "init", 3, "file is too large");
}

TEST_F(Hostile, ADirectoryInsteadOfAFile) {
  test::TempDir d("folder");
  fs::create_directory(d / "cloud.ply");
  expect_rejected((d / "cloud.ply").string(), "register", 3, "not a regular file");
  expect_rejected((d / "cloud.ply").string(), "rectify", 3, "not a regular file");
  fs::create_directory(d / "matrix.txt");
  expect_rejected((d / "matrix.txt").string(), "init", 3, "not a regular file");
}

TEST_F(Hostile, AMissingFile) {
  test::TempDir d("missing");
  expect_rejected((d / "scan.pcd").string(), "target", 3, "file not found");
  expect_rejected((d / "truth.txt").string(), "ground-truth", 3, "file not found");
}

// ---- memory ----

// A binary PLY of `points` points at the origin.
void write_zero_ply(const fs::path& path, std::size_t points) {
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << points
      << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const std::string block(12 * 4096, '\0');
  for (std::size_t left = points; left > 0; left -= std::min<std::size_t>(left, 4096)) {
    out.write(block.data(), static_cast<std::streamsize>(12 * std::min<std::size_t>(left, 4096)));
  }
}

// The address space the `align3d` executable needs to start (its shared libraries: OpenCASCADE's
// alone take some 50 MiB when it is linked), to 4 MiB: the smallest limit `--version` runs under.
std::size_t startup_address_space(const fs::path& logs) {
  for (std::size_t mib = 8; mib <= 1024; mib += 4) {
    const Process p = run_cli({"--version"}, logs,
                              {"/usr/bin/prlimit", "--as=" + std::to_string(mib << 20), "--"});
    if (p.exited && p.code == 0) return mib << 20;
  }
  return std::size_t{1} << 30;
}

// 3 million points need 72 MB, more than 48 MiB above what the executable needs to start leave:
// the reader's allocation fails, and the error names the file and what it was for (README, "Exit
// codes": 4).
TEST_F(Hostile, RunningOutOfMemoryWhileReadingNamesTheFile) {
  if (test::kSanitized) GTEST_SKIP() << "an address-space limit does not apply under a sanitizer";
  if (!fs::exists("/usr/bin/prlimit")) GTEST_SKIP() << "no /usr/bin/prlimit (util-linux)";
  test::TempDir d("oom");
  write_zero_ply(d / "big.ply", 3000000);
  const std::size_t limit = startup_address_space(d.path()) + (48 << 20);
  const Process p =
      run_cli({"rectify", (d / "big.ply").string(), "--output", (d / "out.pcd").string()}, d.path(),
              {"/usr/bin/prlimit", "--as=" + std::to_string(limit), "--"});
  ASSERT_TRUE(p.exited) << p.err;
  EXPECT_EQ(p.code, 4) << p.err;
  EXPECT_EQ(p.err, "align3d: " + (d / "big.ply").string() +
                       ": not enough memory for 3000000 points (69 MiB)\n");
  EXPECT_FALSE(fs::exists(d / "out.pcd"));
}

// The same for a mesh: a binary STL of a million facets (50 MB) needs 3 million vertices (72 MB)
// before its triangles.
TEST_F(Hostile, RunningOutOfMemoryWhileReadingAMeshNamesTheFile) {
  if (test::kSanitized) GTEST_SKIP() << "an address-space limit does not apply under a sanitizer";
  if (!fs::exists("/usr/bin/prlimit")) GTEST_SKIP() << "no /usr/bin/prlimit (util-linux)";
  test::TempDir d("oom_mesh");
  constexpr std::uint32_t kFacets = 1000000;
  {
    std::ofstream out(d / "big.stl", std::ios::binary);
    out << std::string(80, ' ');
    out.write(reinterpret_cast<const char*>(&kFacets), 4);  // little-endian on every CI host
    const std::string block(50 * 4096, '\0');
    for (std::uint32_t left = kFacets; left > 0; left -= std::min<std::uint32_t>(left, 4096)) {
      out.write(block.data(),
                static_cast<std::streamsize>(50 * std::min<std::uint32_t>(left, 4096)));
    }
  }
  const std::size_t limit = startup_address_space(d.path()) + (48 << 20);
  const Process p = run_cli({"convert", (d / "big.stl").string(), (d / "out.ply").string()},
                            d.path(), {"/usr/bin/prlimit", "--as=" + std::to_string(limit), "--"});
  ASSERT_TRUE(p.exited) << p.err;
  EXPECT_EQ(p.code, 4) << p.err;
  EXPECT_EQ(p.err, "align3d: " + (d / "big.stl").string() +
                       ": not enough memory for 3000000 vertices and 1000000 triangles (81 MiB)\n");
  EXPECT_FALSE(fs::exists(d / "out.ply"));
}

}  // namespace
}  // namespace align3d
