// The command-line contract shared by the side-by-side runners (bench/run_align3d.cpp,
// bench/peers/run_open3d.cpp, bench/peers/run_pcl.cpp), driven by bench/compare.py:
//
//   RUNNER TASK SOURCE TARGET --init FILE --max-distance D --max-iterations N --k K --threads T
//          [--voxel V]
//
//   TASK  normals    KNN (k = K) normal estimation of TARGET
//         icp-point  point-to-point ICP of SOURCE onto TARGET from the init, to convergence
//         icp-plane  normal estimation of TARGET (k = K) + point-to-plane ICP to convergence
//         global     the coarse stage (voxel V, FPFH, RANSAC); the init is not used
//
// Each runner reads the files with its own library's reader, then times only the work, and prints
// ONE JSON line on stdout (report() below). Transform convention: target ≈ T·source; the init file
// is a 4×4 text matrix (4 rows of 4 numbers; '#' comments and commas allowed, as align3d's
// io::read_matrix). Header-only and library-free, so the peer project needs nothing from align3d.
#pragma once

#include <sys/resource.h>
#include <time.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace bench {

using Matrix4 = std::array<std::array<double, 4>, 4>;

inline Matrix4 identity4() {
  Matrix4 m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1.0;
  return m;
}

struct RunnerArgs {
  std::string task, source, target;
  std::string init;  // path; empty: identity
  double max_distance = 0;
  int max_iterations = 60;
  int k = 20;
  int threads = 1;
  double voxel = 0;             // 0: target bounding-box diagonal / 50
  std::set<std::string> flags;  // runner-specific switches (e.g. align3d's --auto)
};

// Parses the contract; `extra_flags` are switches without a value this runner accepts. Throws
// std::invalid_argument naming the bad argument.
inline RunnerArgs parse_args(int argc, char** argv, const std::set<std::string>& extra_flags = {}) {
  RunnerArgs a;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (extra_flags.count(arg)) {
      a.flags.insert(arg);
      continue;
    }
    if (arg.rfind("--", 0) != 0) {
      positional.push_back(arg);
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
    const std::string value = argv[++i];
    try {
      if (arg == "--init") {
        a.init = value == "identity" ? "" : value;
      } else if (arg == "--max-distance") {
        a.max_distance = std::stod(value);
      } else if (arg == "--max-iterations") {
        a.max_iterations = std::stoi(value);
      } else if (arg == "--k") {
        a.k = std::stoi(value);
      } else if (arg == "--threads") {
        a.threads = std::stoi(value);
      } else if (arg == "--voxel") {
        a.voxel = std::stod(value);
      } else {
        throw std::invalid_argument("unknown option " + arg);
      }
    } catch (const std::logic_error& e) {
      throw std::invalid_argument(arg + " " + value + ": " + e.what());
    }
  }
  if (positional.size() != 3)
    throw std::invalid_argument("expected TASK SOURCE TARGET, got " +
                                std::to_string(positional.size()) + " positional arguments");
  a.task = positional[0];
  a.source = positional[1];
  a.target = positional[2];
  static const std::set<std::string> kTasks = {"normals", "icp-point", "icp-plane", "global"};
  if (!kTasks.count(a.task)) throw std::invalid_argument("unknown task " + a.task);
  if ((a.task == "icp-point" || a.task == "icp-plane") && !(a.max_distance > 0))
    throw std::invalid_argument(a.task + " needs --max-distance > 0");
  if (a.k < 3 || a.max_iterations < 1 || a.threads < 1)
    throw std::invalid_argument("--k >= 3, --max-iterations >= 1 and --threads >= 1 required");
  return a;
}

// The init file for runners without align3d's reader: 4 rows of 4 numbers.
inline Matrix4 read_matrix4(const std::string& path) {
  if (path.empty()) return identity4();
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<double> v;
  std::string line;
  while (std::getline(in, line)) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream row(line);
    double x;
    while (row >> x) v.push_back(x);
  }
  if (v.size() != 16) throw std::runtime_error(path + ": expected 16 numbers");
  Matrix4 m;
  for (int i = 0; i < 16; ++i) m[i / 4][i % 4] = v[i];
  return m;
}

inline long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;  // Linux: kilobytes
}

struct Report {
  std::string system, task;
  double time_ms = 0;   // wall clock of the work (set by timed())
  double cpu_ms = 0;    // CPU time of the whole process meanwhile, all threads (spin-waits of
                        // idle threads included), a check on wall times taken on a busy machine
  int iterations = -1;  // < 0: not applicable / not reported (null)
  // Measured the same way by every runner, outside the timed region, at the final pose: each
  // source point paired with its nearest target point when closer than --max-distance; rms =
  // Euclidean RMS of those pairs, fitness = pairs ÷ source points. NaN: not applicable (null).
  double rms = NAN, fitness = NAN;
  Matrix4 transformation = identity4();
  std::size_t points_source = 0, points_target = 0;
  std::map<std::string, std::string> extra;  // further fields, values already JSON
};

// Runs f() and sets r.time_ms and r.cpu_ms.
template <class F>
void timed(Report& r, F&& f) {
  timespec cpu0{}, cpu1{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu0);
  const auto start = std::chrono::steady_clock::now();
  f();
  r.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &cpu1);
  r.cpu_ms = 1e3 * static_cast<double>(cpu1.tv_sec - cpu0.tv_sec) +
             1e-6 * static_cast<double>(cpu1.tv_nsec - cpu0.tv_nsec);
}

inline std::string json_number(double x) {
  if (!std::isfinite(x)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

inline std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

// Prints the report as one JSON line on stdout (peak_rss_kb is taken now, for the whole process).
inline void print_report(const Report& r) {
  // Built with += only: GCC 12 warns falsely (-Wrestrict) on "literal" + std::string&&.
  std::string s = "{\"system\":";
  s += json_string(r.system);
  s += ",\"task\":";
  s += json_string(r.task);
  s += ",\"time_ms\":";
  s += json_number(r.time_ms);
  s += ",\"cpu_ms\":";
  s += json_number(r.cpu_ms);
  s += ",\"iterations\":";
  s += r.iterations < 0 ? std::string("null") : std::to_string(r.iterations);
  s += ",\"rms\":";
  s += json_number(r.rms);
  s += ",\"fitness\":";
  s += json_number(r.fitness);
  s += ",\"transformation\":[";
  for (int i = 0; i < 4; ++i) {
    s += i ? ",[" : "[";
    for (int j = 0; j < 4; ++j) {
      if (j) s += ',';
      s += json_number(r.transformation[i][j]);
    }
    s += ']';
  }
  s += "],\"peak_rss_kb\":";
  s += std::to_string(peak_rss_kb());
  s += ",\"points_source\":";
  s += std::to_string(r.points_source);
  s += ",\"points_target\":";
  s += std::to_string(r.points_target);
  for (const auto& [key, value] : r.extra) {
    s += ',';
    s += json_string(key);
    s += ':';
    s += value;
  }
  std::printf("%s}\n", s.c_str());
  std::fflush(stdout);
}

// main() of every runner: parse, run, print; errors go to stderr with exit code 1 (2 for usage).
template <class Run>
int runner_main(int argc, char** argv, const char* system, Run&& run,
                const std::set<std::string>& extra_flags = {}) {
  RunnerArgs args;
  try {
    args = parse_args(argc, argv, extra_flags);
  } catch (const std::exception& e) {
    std::fprintf(stderr,
                 "%s: %s\nusage: %s TASK SOURCE TARGET --init FILE --max-distance D "
                 "--max-iterations N --k K --threads T [--voxel V]\n",
                 system, e.what(), argv[0]);
    return 2;
  }
  try {
    print_report(run(args));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", system, e.what());
    return 1;
  }
}

}  // namespace bench
