#include "align3d/coarse/global.hpp"

#include <chrono>

#include "align3d/coarse/ppf.hpp"
#include "align3d/coarse/ransac.hpp"

namespace align3d {

GlobalResult global_register(const PointCloud& source, const PointCloud& target,
                             const GlobalSettings& settings, const GlobalContext& context) {
  const auto start = std::chrono::steady_clock::now();
  GlobalResult r = settings.method == GlobalMethod::kFpfh
                       ? fpfh_ransac_register(source, target, settings, context)
                       : ppf_register(source, target, settings, context);
  r.method = settings.method;
  r.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace align3d
