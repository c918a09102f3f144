#include "align3d/coarse/target_cache.hpp"

namespace align3d {
namespace {

constexpr std::size_t kKeptVoxels = 4;  // entries per kind (target_cache.hpp)

// The entry for `voxel`, built by `build` when missing; the oldest entry goes beyond kKeptVoxels.
// Built under the lock: concurrent callers for one target wait rather than build twice.
template <class Entries, class Build>
auto lookup(Entries& entries, double voxel, Build&& build) {
  for (const auto& e : entries)
    if (e.voxel == voxel) return e.value;
  auto value = build();
  if (entries.size() == kKeptVoxels) entries.erase(entries.begin());
  entries.push_back({voxel, value});
  return value;
}

}  // namespace

std::shared_ptr<const FpfhCloud> GlobalTargetCache::fpfh(double voxel, int threads) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return lookup(fpfh_, voxel, [&] { return prepare_fpfh(target_, voxel, "target", threads); });
}

std::shared_ptr<const PpfModel> GlobalTargetCache::ppf_model(double voxel, int threads) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return lookup(ppf_, voxel, [&] {
    return std::make_shared<const PpfModel>(build_ppf_model(target_, voxel, threads));
  });
}

}  // namespace align3d
