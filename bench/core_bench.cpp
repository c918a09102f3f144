// Micro-benchmarks of the ICP roles, in points per second, on conveyor scenes of growing size.
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

// The chapter's scene scaled to n model points (same geometry, denser sampling).
const synth::Scene& scene(int n) {
  static std::map<int, synth::Scene> cache;
  auto it = cache.find(n);
  if (it == cache.end()) {
    synth::ConveyorSettings s;
    s.model_points = n;
    s.scan_model_points = n * 4310 / 5678;
    s.wall_points = n * 2187 / 5678;
    it = cache.emplace(n, synth::make_conveyor_scene(s)).first;
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

void IcpIteration(benchmark::State& state) {
  const auto& s = scene(static_cast<int>(state.range(0)));
  PointCloud target = s.model;
  const KdTree tree(target.positions);
  estimate_normals(target, tree);
  IcpSettings settings;
  settings.method = state.range(1) ? IcpMethod::kPointToPlane : IcpMethod::kPointToPoint;
  settings.termination.max_iterations = 1;
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

BENCHMARK(KdTreeBuild)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(KdTreeNearest)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(Normals)->Arg(10000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(IcpIteration)
    ->ArgsProduct({{10000, 100000, 1000000}, {0, 1}})
    ->ArgNames({"n", "plane"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(Registration)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace align3d
