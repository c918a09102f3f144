// The global stage's products that depend on the target alone, kept across calls by a caller that
// registers many sources against one target (PreparedTarget, prepared_target.hpp): the FPFH
// descriptors and the PPF model at a voxel. The voxel follows the object (global.hpp), which may be
// the source, so entries are kept per voxel, the most recent few.
//
// Lifetime: keeps a reference to the target, which must outlive it. Thread-safety: any number of
// calls at once; a missing entry is built once (other callers for it wait).
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "align3d/coarse/ppf.hpp"
#include "align3d/coarse/ransac.hpp"

namespace align3d {

class GlobalTargetCache {
 public:
  explicit GlobalTargetCache(const PointCloud& target) : target_(target) {}

  // Throw what prepare_fpfh and build_ppf_model throw (DataError("target", …)).
  std::shared_ptr<const FpfhCloud> fpfh(double voxel, int threads);
  std::shared_ptr<const PpfModel> ppf_model(double voxel, int threads);

 private:
  template <class T>
  struct Entry {
    double voxel;
    std::shared_ptr<const T> value;
  };
  const PointCloud& target_;
  std::mutex mutex_;
  std::vector<Entry<FpfhCloud>> fpfh_;
  std::vector<Entry<PpfModel>> ppf_;
};

}  // namespace align3d
