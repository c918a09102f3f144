// The choice of the hierarchy behind MeshIndex, measured: align3d's own (a BVH with SAH and a
// near-surface candidate grid, double precision, warm starts) against Embree 3's point query
// (rtcPointQuery with a closest-point-on-triangle callback in float, the engine of Open3D's
// RaycastingScene) and CGAL's AABB tree (Simple_cartesian<double>,
// closest_point_and_primitive, with and without the previous answer as its hint), on the same
// mesh and the same queries: exact closest point and triangle per query.
//
// Meshes: the machined part (synth::PartModel), subdivided to 51 968 and 207 872 triangles.
// Queries: the part points of its as-built scan (synth::make_as_built_scan with its defaults:
// 235 030 points, noise σ = 0.01 mm along the ray, two dents, two bumps, a warp), moved into the
// CAD frame, in spatial (Morton) order or shuffled.
// Build and query are timed apart, with 1 and 2 threads: MeshIndex builds and queries with its own
// pool; Embree builds with its device's threads ("threads=N") and is queried, like CGAL, from N
// threads taking runs of 256 queries in turn (the runs MeshIndex::closest_points uses); CGAL's
// build is sequential (1 thread only).
//
// Built only when Embree and CGAL are found (bench/CMakeLists.txt; scripts/setup-peers.sh).
// Before the benchmarks run, every system's distances are checked against ours (stderr).
// Run (one line): build/bench/align3d_mesh_bench --benchmark_enable_random_interleaving=true
//   --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "align3d/kdtree.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/synth/part.hpp"

namespace align3d {
namespace {

constexpr std::size_t kRun = 256;  // queries a thread takes at a time (as closest_points)

struct Data {
  TriangleMesh mesh;
  std::vector<Eigen::Vector3d> spatial, shuffled;  // the same points in two orders
};

// The part points of the default as-built scan, in the CAD frame.
const std::vector<Eigen::Vector3d>& scan_points() {
  static const std::vector<Eigen::Vector3d> points = [] {
    const synth::AsBuiltSettings settings;  // named: GCC 12 warns falsely on the default temporary
    const synth::AsBuiltScan scan = synth::make_as_built_scan(settings);
    std::vector<Eigen::Vector3d> p;
    for (std::size_t i = 0; i < scan.scan.size(); ++i)
      if (scan.label[i] == synth::ScanLabel::kPart)
        p.push_back(scan.T_cad_scan * scan.scan.positions[i]);
    return p;
  }();
  return points;
}

const Data& data(std::int64_t triangles) {
  static std::map<std::int64_t, Data> cache;
  auto it = cache.find(triangles);
  if (it == cache.end()) {
    Data d;
    d.mesh = synth::PartModel().mesh(static_cast<std::size_t>(triangles));
    const auto& points = scan_points();
    for (std::uint32_t i : spatial_order(points)) d.spatial.push_back(points[i]);
    d.shuffled = d.spatial;
    std::shuffle(d.shuffled.begin(), d.shuffled.end(), std::mt19937_64(1));
    it = cache.emplace(triangles, std::move(d)).first;
  }
  return it->second;
}

const std::vector<Eigen::Vector3d>& queries(const Data& d, std::int64_t shuffled) {
  return shuffled ? d.shuffled : d.spatial;
}

// Runs f(begin, end) over [0, n) in runs of kRun, on `threads` threads taking runs in turn.
template <class F>
void parallel_runs(std::size_t n, int threads, F&& f) {
  std::atomic<std::size_t> next{0};
  auto work = [&] {
    for (;;) {
      const std::size_t begin = kRun * next.fetch_add(1);
      if (begin >= n) return;
      f(begin, std::min(n, begin + kRun));
    }
  };
  std::vector<std::thread> helpers;
  for (int t = 1; t < threads; ++t) helpers.emplace_back(work);
  work();
  for (std::thread& t : helpers) t.join();
}

// ---- align3d ---------------------------------------------------------------------------------

struct Align3d {
  std::unique_ptr<MeshIndex> index;
  Align3d(const TriangleMesh& mesh, int threads)
      : index(std::make_unique<MeshIndex>(mesh, threads)) {}
  void query(const std::vector<Eigen::Vector3d>& q, int threads, std::vector<double>& sq_distance,
             std::vector<std::uint32_t>& triangle) const {
    std::vector<SurfacePoint> out;
    index->closest_points(q, Eigen::Isometry3d::Identity(), std::numeric_limits<double>::infinity(),
                          threads, out);
    for (std::size_t i = 0; i < q.size(); ++i) {
      sq_distance[i] = out[i].sq_distance;
      triangle[i] = out[i].triangle;
    }
  }
};

// ---- Embree 3 --------------------------------------------------------------------------------

struct Vec3f {
  float x, y, z;
  Vec3f operator-(const Vec3f& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3f operator+(const Vec3f& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3f operator*(float s) const { return {x * s, y * s, z * s}; }
  float dot(const Vec3f& o) const { return x * o.x + y * o.y + z * o.z; }
};

// Ericson's closest point on triangle abc (Real-Time Collision Detection 5.1.5) in float, as
// Embree's closest_point tutorial and Open3D's RaycastingScene compute it.
Vec3f closest_on_triangle(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const Vec3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const float denom = 1.0f / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

struct EmbreeQuery {
  const Vec3f* vertices;
  const std::uint32_t* indices;
  std::uint32_t triangle = kNoTriangle;
};

// Called by rtcPointQuery for each triangle whose box the query sphere reaches; shrinking the
// radius prunes the rest of the traversal.
bool embree_closest(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<EmbreeQuery*>(args->userPtr);
  const std::uint32_t* f = q->indices + 3 * args->primID;
  const Vec3f p{args->query->x, args->query->y, args->query->z};
  const Vec3f c = closest_on_triangle(p, q->vertices[f[0]], q->vertices[f[1]], q->vertices[f[2]]);
  const float d = std::sqrt((p - c).dot(p - c));
  if (d >= args->query->radius) return false;
  args->query->radius = d;
  q->triangle = args->primID;
  return true;
}

struct Embree {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  const Vec3f* vertices = nullptr;
  const std::uint32_t* indices = nullptr;

  Embree(const TriangleMesh& mesh, int threads) {
    const std::string config = "threads=" + std::to_string(threads);
    device = rtcNewDevice(config.c_str());
    scene = rtcNewScene(device);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<Vec3f*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, sizeof(Vec3f), mesh.vertices.size()));
    auto* t = static_cast<std::uint32_t*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(std::uint32_t), mesh.triangles.size()));
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
      v[i] = {static_cast<float>(mesh.vertices[i].x()), static_cast<float>(mesh.vertices[i].y()),
              static_cast<float>(mesh.vertices[i].z())};
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
      for (int k = 0; k < 3; ++k) t[3 * i + k] = mesh.triangles[i][k];
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    vertices = v;
    indices = t;
  }
  ~Embree() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
  Embree(const Embree&) = delete;
  Embree& operator=(const Embree&) = delete;

  void query(const std::vector<Eigen::Vector3d>& q, int threads, std::vector<double>& sq_distance,
             std::vector<std::uint32_t>& triangle) const {
    parallel_runs(q.size(), threads, [&](std::size_t begin, std::size_t end) {
      RTCPointQueryContext context;
      for (std::size_t i = begin; i < end; ++i) {
        RTCPointQuery pq;
        pq.x = static_cast<float>(q[i].x());
        pq.y = static_cast<float>(q[i].y());
        pq.z = static_cast<float>(q[i].z());
        pq.time = 0;
        pq.radius = std::numeric_limits<float>::infinity();
        rtcInitPointQueryContext(&context);
        EmbreeQuery result{vertices, indices};
        rtcPointQuery(scene, &pq, &context, embree_closest, &result);
        sq_distance[i] = static_cast<double>(pq.radius) * static_cast<double>(pq.radius);
        triangle[i] = result.triangle;
      }
    });
  }
};

// ---- CGAL ------------------------------------------------------------------------------------

using K = CGAL::Simple_cartesian<double>;
using CgalTriangles = std::vector<K::Triangle_3>;
using CgalPrimitive = CGAL::AABB_triangle_primitive<K, CgalTriangles::const_iterator>;
using CgalTree = CGAL::AABB_tree<CGAL::AABB_traits<K, CgalPrimitive>>;

template <bool kHint>
struct Cgal {
  CgalTriangles triangles;
  std::unique_ptr<CgalTree> tree;

  Cgal(const TriangleMesh& mesh, int /*threads: CGAL builds sequentially*/) {
    triangles.reserve(mesh.triangles.size());
    auto point = [&](std::uint32_t v) {
      return K::Point_3(mesh.vertices[v].x(), mesh.vertices[v].y(), mesh.vertices[v].z());
    };
    for (const auto& f : mesh.triangles)
      triangles.emplace_back(point(f[0]), point(f[1]), point(f[2]));
    tree = std::make_unique<CgalTree>(triangles.cbegin(), triangles.cend());
    tree->build();
    tree->accelerate_distance_queries();  // the kd-tree of reference points that seeds each query
  }

  void query(const std::vector<Eigen::Vector3d>& q, int threads, std::vector<double>& sq_distance,
             std::vector<std::uint32_t>& triangle) const {
    parallel_runs(q.size(), threads, [&](std::size_t begin, std::size_t end) {
      CgalTree::Point_and_primitive_id hint;
      for (std::size_t i = begin; i < end; ++i) {
        const K::Point_3 p(q[i].x(), q[i].y(), q[i].z());
        const auto answer = kHint && i > begin ? tree->closest_point_and_primitive(p, hint)
                                               : tree->closest_point_and_primitive(p);
        hint = answer;
        sq_distance[i] = CGAL::squared_distance(p, answer.first);
        triangle[i] = static_cast<std::uint32_t>(answer.second - triangles.cbegin());
      }
    });
  }
};

// ---- Benchmarks ------------------------------------------------------------------------------
// Arguments: triangles (51 968 or 207 872), shuffled (0: spatial order, 1: shuffled), threads.

template <class System>
void MeshBuild(benchmark::State& state) {
  const Data& d = data(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  for (auto _ : state) {
    System system(d.mesh, threads);
    benchmark::DoNotOptimize(&system);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(d.mesh.triangles.size()));
}

template <class System>
void MeshClosest(benchmark::State& state) {
  const Data& d = data(state.range(0));
  const auto& q = queries(d, state.range(1));
  const int threads = static_cast<int>(state.range(2));
  const System system(d.mesh, threads);
  std::vector<double> sq_distance(q.size());
  std::vector<std::uint32_t> triangle(q.size());
  for (auto _ : state) {
    system.query(q, threads, sq_distance, triangle);
    benchmark::DoNotOptimize(sq_distance.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(q.size()));
}

void build_args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"triangles", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
  for (std::int64_t t : {51968, 207872})
    for (std::int64_t threads : {1, 2}) b->Args({t, threads});
}
void build_args_sequential(benchmark::internal::Benchmark* b) {
  b->ArgNames({"triangles", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
  for (std::int64_t t : {51968, 207872}) b->Args({t, 1});
}
void query_args(benchmark::internal::Benchmark* b) {
  b->ArgNames({"triangles", "shuffled", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
  for (std::int64_t t : {51968, 207872})
    for (std::int64_t shuffled : {0, 1})
      for (std::int64_t threads : {1, 2}) b->Args({t, shuffled, threads});
}

BENCHMARK(MeshBuild<Align3d>)->Apply(build_args);
BENCHMARK(MeshBuild<Embree>)->Apply(build_args);
BENCHMARK(MeshBuild<Cgal<false>>)->Apply(build_args_sequential);
BENCHMARK(MeshClosest<Align3d>)->Apply(query_args);
BENCHMARK(MeshClosest<Embree>)->Apply(query_args);
BENCHMARK(MeshClosest<Cgal<false>>)->Apply(query_args);
BENCHMARK(MeshClosest<Cgal<true>>)->Apply(query_args);

// Every system against ours on the spatially ordered queries: the largest difference of the
// distances (triangles are not compared: on a shared edge or corner several are right).
template <class System>
void check(const char* name, const Data& d, const std::vector<double>& reference) {
  const System system(d.mesh, 2);
  std::vector<double> sq(d.spatial.size());
  std::vector<std::uint32_t> tri(d.spatial.size());
  system.query(d.spatial, 2, sq, tri);
  double worst = 0;
  for (std::size_t i = 0; i < sq.size(); ++i)
    worst = std::max(worst, std::abs(std::sqrt(sq[i]) - std::sqrt(reference[i])));
  std::fprintf(stderr, "  %-12s max |distance - align3d's| = %.3g mm\n", name, worst);
}

void check_all() {
  for (std::int64_t t : {51968, 207872}) {
    const Data& d = data(t);
    std::fprintf(stderr, "%zu triangles, %zu queries:\n", d.mesh.triangles.size(),
                 d.spatial.size());
    const Align3d ours(d.mesh, 2);
    std::vector<double> sq(d.spatial.size());
    std::vector<std::uint32_t> tri(d.spatial.size());
    ours.query(d.spatial, 2, sq, tri);
    check<Embree>("Embree", d, sq);
    check<Cgal<false>>("CGAL", d, sq);
    check<Cgal<true>>("CGAL (hint)", d, sq);
  }
}

}  // namespace
}  // namespace align3d

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  align3d::check_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
