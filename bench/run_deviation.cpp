// align3d_run_deviation: align3d's runner for the deviation step's side-by-side comparison
// (bench/compare_inspect.py, against CloudCompare's C2M and Open3D's RaycastingScene). Uses only
// the public API.
//
//   align3d_run_deviation SCAN MESH [--matrix T.txt] [--threads N] [--out DEV.f64]
//                         [--oracle-out INSIDE.u8]
//
// Reads the scan (io::read_point_cloud) and the mesh (io::read_mesh), then times, on the wall
// clock and after reading:
//   build  the MeshIndex of the mesh as read (cleaning, pseudo-normals, hierarchy, candidate grid)
//   query  measure_deviations(scan, index, T, max_distance = ∞): every point's exact signed
//          distance (the scan's own order when coherent, else spatial order; warm starts;
//          pseudo-normal signs) in double precision
// and prints one JSON line on stdout: the times (wall and CPU of the whole process) and the minor
// page faults of each step (fresh pages the kernel zeroes: a cost the CPU time includes), the
// sizes, the index's own bytes, the deviation map's bytes, and memory: rss_before_scan_kb (the
// process's resident set once the library is loaded and the mesh read, before the scan is read) and
// peak_rss_kb (getrusage's high-water mark at the end), so that (peak − before) ÷ points is what
// the scan costs: its points (24 bytes each, double), the index, the query's temporaries and the
// map.
//   --matrix    T (4×4, CAD ≈ T·scan) applied to the scan inside measure_deviations (default: I)
//   --out       the signed distances, float64 little-endian, one per scan point in scan order
//               (NaN for none: never with an infinite max_distance)
//   --oracle-out  one byte per point, untimed: 1 when T·point lies strictly inside the material of
//               the default machined part (synth::PartModel{}.contains, the analytic solid that
//               `align3d synth --scene part` meshes), 0 otherwise: the sign's ground truth for
//               scans and probe points of that part.
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "align3d/deviation.hpp"
#include "align3d/io/matrix_io.hpp"
#include "align3d/io/mesh_io.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/synth/part.hpp"

namespace {

struct Args {
  std::string scan, mesh, matrix, out, oracle_out;
  int threads = 0;
};

Args parse(int argc, char** argv) {
  Args a;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--", 0) != 0) {
      positional.push_back(arg);
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
    const std::string value = argv[++i];
    if (arg == "--matrix") {
      a.matrix = value;
    } else if (arg == "--threads") {
      a.threads = std::stoi(value);
    } else if (arg == "--out") {
      a.out = value;
    } else if (arg == "--oracle-out") {
      a.oracle_out = value;
    } else {
      throw std::invalid_argument("unknown option " + arg);
    }
  }
  if (positional.size() != 2)
    throw std::invalid_argument("expected SCAN MESH, got " + std::to_string(positional.size()) +
                                " positional arguments");
  if (a.threads < 0) throw std::invalid_argument("--threads >= 0 (0: all cores)");
  a.scan = positional[0];
  a.mesh = positional[1];
  return a;
}

// The resident set now (Linux /proc/self/statm, in pages), in kilobytes.
long current_rss_kb() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

long peak_rss_kb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;  // Linux: kilobytes
}

double cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

struct Stopwatch {
  std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
  double cpu = cpu_ms();
  long faults = minor_faults();
  long faults_elapsed() const { return minor_faults() - faults; }
  double wall_ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall)
        .count();
  }
  double cpu_elapsed_ms() const { return cpu_ms() - cpu; }
};

void write_bytes(const std::string& path, const char* data, std::size_t size) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(data, static_cast<std::streamsize>(size));
  if (!f) throw std::runtime_error(path + ": cannot write");
}

std::string number(double x) {
  if (!std::isfinite(x)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

int run(const Args& a) {
  static_assert(std::endian::native == std::endian::little, "--out writes native doubles");
  const Eigen::Isometry3d T =
      a.matrix.empty() ? Eigen::Isometry3d::Identity() : align3d::io::read_matrix(a.matrix);
  const Stopwatch read_mesh;
  const align3d::TriangleMesh mesh = align3d::io::read_mesh(a.mesh);
  const double read_mesh_ms = read_mesh.wall_ms();
  const long rss_before_scan_kb = current_rss_kb();
  const Stopwatch read_scan;
  const align3d::PointCloud scan = align3d::io::read_point_cloud(a.scan);
  const double read_scan_ms = read_scan.wall_ms();

  const Stopwatch build;
  const align3d::MeshIndex index(mesh, a.threads, a.mesh);
  const double build_ms = build.wall_ms(), build_cpu_ms = build.cpu_elapsed_ms();
  const long build_faults = build.faults_elapsed();

  const Stopwatch query;
  const align3d::DeviationMap map = align3d::measure_deviations(
      scan.positions, index, T, std::numeric_limits<double>::infinity(), a.threads);
  const double query_ms = query.wall_ms(), query_cpu_ms = query.cpu_elapsed_ms();
  const long query_faults = query.faults_elapsed();
  const long peak_kb = peak_rss_kb();  // before the untimed extras below allocate anything

  if (!a.out.empty())
    write_bytes(a.out, reinterpret_cast<const char*>(map.deviation.data()),
                map.deviation.size() * sizeof(double));
  if (!a.oracle_out.empty()) {
    const align3d::synth::PartModel part;
    std::vector<char> inside(scan.size());
    for (std::size_t i = 0; i < scan.size(); ++i)
      inside[i] = part.contains(T * scan.positions[i]) ? 1 : 0;
    write_bytes(a.oracle_out, inside.data(), inside.size());
  }

  const std::size_t map_bytes = map.deviation.capacity() * sizeof(double) +
                                map.closest.capacity() * sizeof(Eigen::Vector3d) +
                                map.triangle.capacity() * sizeof(std::uint32_t);
  std::size_t negative = 0;
  for (double d : map.deviation) negative += d < 0 ? 1 : 0;
  std::string s = "{\"system\":\"align3d\",\"points\":";
  s += std::to_string(scan.size());
  s += ",\"triangles\":" + std::to_string(mesh.triangles.size());
  s += ",\"triangles_indexed\":" + std::to_string(index.mesh().triangles.size());
  s += ",\"threads\":" + std::to_string(a.threads);
  s += ",\"read_mesh_ms\":" + number(read_mesh_ms);
  s += ",\"read_scan_ms\":" + number(read_scan_ms);
  s += ",\"build_ms\":" + number(build_ms);
  s += ",\"build_cpu_ms\":" + number(build_cpu_ms);
  s += ",\"query_ms\":" + number(query_ms);
  s += ",\"query_cpu_ms\":" + number(query_cpu_ms);
  s += ",\"build_page_faults\":" + std::to_string(build_faults);
  s += ",\"query_page_faults\":" + std::to_string(query_faults);
  s += ",\"index_bytes\":" + std::to_string(index.memory_bytes());
  s += ",\"map_bytes\":" + std::to_string(map_bytes);
  s += ",\"outliers\":" + std::to_string(map.outliers);
  s += ",\"negative\":" + std::to_string(negative);
  s += ",\"rss_before_scan_kb\":" + std::to_string(rss_before_scan_kb);
  s += ",\"peak_rss_kb\":" + std::to_string(peak_kb);
  s += "}\n";
  std::fputs(s.c_str(), stdout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "align3d_run_deviation: %s\n", e.what());
    return 2;
  }
}
