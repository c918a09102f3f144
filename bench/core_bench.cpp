// Micro-benchmarks of the ICP roles, in points per second, on work-cell scenes of growing size.
// Run: cmake -DALIGN3D_BUILD_BENCH=ON ... && build/bench/align3d_bench
// These measure align3d alone; speed claims against peers need the side-by-side comparison.
#include <benchmark/benchmark.h>

#include <map>

#include "align3d/kdtree.hpp"
#include "align3d/normals.hpp"
#include "align3d/registration.hpp"
#include "align3d/synth/scenes.hpp"

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

void KdTreeBuild(benchmark::State& state) {
  const auto& cloud = scene(static_cast<int>(state.range(0))).model;
  for (auto _ : state) {
    KdTree tree(cloud.positions);
    benchmark::DoNotOptimize(tree.size());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cloud.size()));
}

void KdTreeNearest(benchmark::State& state) {
  const auto& s = scene(static_cast<int>(state.range(0)));
  const KdTree tree(s.model.positions);
  for (auto _ : state) {
    Neighbor nb;
    double sum = 0;
    for (const auto& p : s.scan.positions)
      if (tree.nearest(p, nb)) sum += nb.sq_distance;
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(s.scan.size()));
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
  for (auto _ : state)
    benchmark::DoNotOptimize(register_clouds(s.scan, s.model, Eigen::Isometry3d::Identity()));
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(s.scan.size()));
}

// 10 million points where it fits: each cloud is ~0.5 GB with normals.
BENCHMARK(KdTreeBuild)->RangeMultiplier(10)->Range(10000, 10000000)->Unit(benchmark::kMillisecond);
BENCHMARK(KdTreeNearest)
    ->RangeMultiplier(10)
    ->Range(10000, 10000000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(Normals)->RangeMultiplier(10)->Range(10000, 10000000)->Unit(benchmark::kMillisecond);
BENCHMARK(IcpIteration)
    ->ArgsProduct({{10000, 100000, 1000000, 10000000}, {0, 1}, {1, 2}})
    ->ArgNames({"n", "plane", "threads"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(Registration)->RangeMultiplier(10)->Range(10000, 1000000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace align3d
