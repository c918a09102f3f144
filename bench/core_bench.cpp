// Micro-benchmarks of the ICP roles, in points per second, on work-cell scenes of growing size.
// Run: cmake -DALIGN3D_BUILD_BENCH=ON ... && build/bench/align3d_bench
// These measure align3d alone (the kd-tree rows also its nanoflann baseline); speed claims against
// Open3D and PCL need the side-by-side comparison (bench/compare.py).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <limits>
#include <map>
#include <vector>

#include "align3d/align.hpp"
#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "nanoflann_baseline.hpp"

namespace align3d {
namespace {

// The benchmark work cell (synth::make_parts_scene) with n points in each cloud.
const synth::Scene& scene(int n) {
  static std::map<int, synth::Scene> cache;
  auto it = cache.find(n);
  if (it == cache.end()) {
    synth::PartsSettings s;
    s.points = n;
    it = cache.emplace(n, synth::make_parts_scene(s)).first;
  }
  return it->second;
}

// The kd-tree against the nanoflann baseline it replaced (nanoflann_baseline.hpp), on the same
// points and queries, one thread (the build also with 2: ours builds large subtrees in parallel).
// Queries come in spatial order, as ICP and the normals issue them.
template <class Tree>
void KdTreeBuild(benchmark::State& state) {
  const auto& cloud = scene(static_cast<int>(state.range(0))).model;
  for (auto _ : state) {
    Tree tree(cloud.positions, static_cast<int>(state.range(1)));
    benchmark::DoNotOptimize(&tree);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}

// The scan at its true pose against the model, as ICP's last iterations search it; argument 1 is
// the search bound in mm (0: none; ICP bounds every search by its rejection distance or the
// previous partner, so unbounded queries from outliers and non-overlapping parts are the worst
// case, not the usual one).
template <class Tree>
void KdTreeNearest(benchmark::State& state) {
  const auto& s = scene(static_cast<int>(state.range(0)));
  const double bound = static_cast<double>(state.range(1));
  const double sq_bound = bound > 0 ? bound * bound : std::numeric_limits<double>::infinity();
  const Tree tree(s.model.positions);
  std::vector<Eigen::Vector3d> queries;
  for (std::uint32_t i : spatial_order(s.scan.positions))
    queries.push_back(s.T_model_scan * s.scan.positions[i]);
  for (auto _ : state) {
    Neighbor nb;
    double sum = 0;
    for (const auto& p : queries)
      if (tree.nearest(p, nb, sq_bound)) sum += nb.sq_distance;
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(queries.size()));
}

// Every model point's 20 nearest: the normals' search (knn_unsorted) or sorted (knn).
template <class Tree, bool kSorted = true>
void KdTreeKnn(benchmark::State& state) {
  const auto& cloud = scene(static_cast<int>(state.range(0))).model;
  const Tree tree(cloud.positions);
  const std::vector<std::uint32_t> order = spatial_order(cloud.positions);
  std::vector<Neighbor> nb;
  for (auto _ : state) {
    double sum = 0;
    for (std::uint32_t i : order) {
      if constexpr (kSorted) {
        tree.knn(cloud.positions[i], 20, nb);
      } else {
        tree.knn_unsorted(cloud.positions[i], 20, nb);
      }
      sum += nb.back().sq_distance;
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}

void Normals(benchmark::State& state) {
  PointCloud cloud = scene(static_cast<int>(state.range(0))).model;
  const KdTree tree(cloud.positions);
  for (auto _ : state) estimate_normals(cloud, tree);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}

// One iteration (correspondences + reduction + solve) from the ground-truth pose, with a maximum
// correspondence distance of 5 mm; arguments: points, metric (0 point-to-point, 1 point-to-plane),
// threads.
void IcpIteration(benchmark::State& state) {
  const auto& s = scene(static_cast<int>(state.range(0)));
  PointCloud target = s.model;
  const KdTree tree(target.positions);
  estimate_normals(target, tree);
  IcpSettings settings;
  settings.method = state.range(1) ? IcpMethod::kPointToPlane : IcpMethod::kPointToPoint;
  settings.rejection = RejectionRule::max_distance(5.0);
  settings.termination.max_iterations = 1;
  settings.threads = static_cast<int>(state.range(2));
  for (auto _ : state)
    benchmark::DoNotOptimize(icp(s.scan, target, tree, s.T_model_scan, settings));
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(s.scan.size()));
}

void Registration(benchmark::State& state) {
  const auto& s = scene(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(align(s.scan, s.model));
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(s.scan.size()));
}

// One scan after another against one model (a line's job): argument 0 prepares the model once
// (PreparedTarget) or not, argument 1 is the init policy (0 auto, 1 global fpfh). The scans are
// partial views of 40 000 points turned 30 deg further each time, so auto runs the global stage on
// some of them.
void ScanAgainstModel(benchmark::State& state) {
  static const synth::Scene base = [] {
    synth::ObjectSettings os;
    os.shape = "bracket";
    os.points = 40000;
    return synth::make_object_scene(os);
  }();
  std::vector<PointCloud> scans;
  for (int k = 0; k < 6; ++k)
    scans.push_back(transformed(base.scan, rigid_transform(30.0 * k, {1, 2, -0.5}, {3, -1, 2})));
  AlignSettings settings;
  settings.init = state.range(1) ? InitPolicy::kGlobal : InitPolicy::kAuto;
  const bool prepare = state.range(0) != 0;
  const PreparedTarget model(base.model);
  std::size_t k = 0;
  for (auto _ : state) {
    const PointCloud& scan = scans[k++ % scans.size()];
    benchmark::DoNotOptimize(prepare ? align(scan, model, settings)
                                     : align(scan, base.model, settings));
  }
  state.SetItemsProcessed(state.iterations());
}

// 10 million points where it fits: each cloud is ~0.5 GB with normals.
BENCHMARK_TEMPLATE(KdTreeBuild, KdTree)
    ->ArgsProduct({{10000, 100000, 1000000, 10000000}, {1, 2}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(KdTreeBuild, bench::NanoflannTree)
    ->ArgsProduct({{10000, 100000, 1000000, 10000000}, {1}})
    ->ArgNames({"n", "threads"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(KdTreeNearest, KdTree)
    ->ArgsProduct({{10000, 100000, 1000000, 10000000}, {0, 5}})
    ->ArgNames({"n", "bound"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(KdTreeNearest, bench::NanoflannTree)
    ->ArgsProduct({{10000, 100000, 1000000, 10000000}, {0, 5}})
    ->ArgNames({"n", "bound"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(KdTreeKnn, KdTree)
    ->RangeMultiplier(10)
    ->Range(10000, 10000000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(KdTreeKnn, KdTree, false)
    ->RangeMultiplier(10)
    ->Range(10000, 10000000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_TEMPLATE(KdTreeKnn, bench::NanoflannTree)
    ->RangeMultiplier(10)
    ->Range(10000, 10000000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(Normals)->RangeMultiplier(10)->Range(10000, 10000000)->Unit(benchmark::kMillisecond);
BENCHMARK(IcpIteration)
    ->ArgsProduct({{10000, 100000, 1000000, 10000000}, {0, 1}, {1, 2}})
    ->ArgNames({"n", "plane", "threads"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(ScanAgainstModel)
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->ArgNames({"prepared", "global"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(Registration)->RangeMultiplier(10)->Range(10000, 1000000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace align3d
