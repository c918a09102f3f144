// Inspection of a measured part against its CAD model (README, "Inspect a part"): the scan is
// placed in the CAD frame by registering it onto the mesh's exact surface (align(), with the mesh
// as the target: a best fit that local defects do not pull, refine.hpp), then every scan point's
// signed deviation from the surface is measured (deviation.hpp: + outside the material) and judged
// against a tolerance band. Points farther than a maximum distance from every surface (fixtures,
// clamps, background) are outliers: counted, never mixed into the statistics.
//
// The verdict is "pass" when at least `pass_fraction` of the inliers lie within the band
// [lower, upper] (default: every one), the registration succeeded and at least one point was
// measured. Every default follows the data: the outlier distance scales with the tolerance and the
// part (not the scene), so the same part in mm or m gives the same verdict.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "align3d/align.hpp"
#include "align3d/deviation.hpp"
#include "align3d/mesh_index.hpp"
#include "align3d/point_cloud.hpp"
#include "align3d/prepared_target.hpp"
#include "align3d/warning.hpp"

namespace align3d {

// Deviations from lower to upper (data units) are within tolerance; lower < upper, and the band
// holds 0 (lower <= 0 <= upper).
struct Tolerance {
  double lower = 0, upper = 0;
};

// The default outlier distance: the larger of kOutlierTolerances × the band's larger half and
// kOutlierDiagonal × the CAD model's bounding-box diagonal (a defect many times the tolerance is
// still measured; a clamp a few millimetres from a 150 mm part is not).
inline constexpr double kOutlierTolerances = 5;
inline constexpr double kOutlierDiagonal = 0.01;
// Warnings: more than this share of the scan are outliers; the Gauss fit's sigma is more than this
// share of the band's width (the band is then within a few σ of noise).
inline constexpr double kManyOutliers = 0.5;
inline constexpr double kNoisyBand = 1.0 / 6.0;
inline constexpr int kHistogramBins = 80;

struct InspectSettings {
  AlignSettings align;         // the registration (init auto by default; align.hpp)
  Tolerance tolerance;         // required
  double max_distance = 0;     // outlier distance (data units); 0: the default above
  double pass_fraction = 1.0;  // in (0, 1]
  int threads = 0;             // 0: all cores; replaces align.threads; results do not depend on it
};

struct InspectResult {
  // The registration, scan → CAD: CAD ≈ registration.transformation · scan. When it failed
  // (success false) nothing was measured.
  AlignResult registration;
  DeviationMap map;  // per scan point, in the scan's order, of the registered scan
  DeviationStats stats;
  GaussFit gauss;
  Histogram histogram;  // kHistogramBins bins over the band widened by half and the 0.5-99.5 %
                        // of the deviations, at most ±max_distance
  Tolerance tolerance;
  std::size_t within = 0, below = 0, above = 0;  // inliers inside, under and over the band
  double within_tolerance = 0;                   // within / inliers (0 when none)
  bool pass = false;
  MeshTopology mesh;  // of the cleaned CAD mesh
  MeshRepair repair;  // what cleaning it changed
  // The CAD model as measured: the cleaned mesh (surface->mesh(), the numbering of map.triangle)
  // and its index.
  std::shared_ptr<const MeshIndex> surface;
  std::vector<Warning> warnings;  // the registration's, then the inspection's
  double align_ms = 0, deviation_ms = 0, total_ms = 0;
};

// Throws std::invalid_argument for settings no run can use (a band without 0 or empty, a
// pass_fraction outside (0, 1], a negative or non-finite max_distance) and DataError("source" or
// "target", …) for a scan or mesh that cannot be measured (align.hpp, mesh_index.hpp).
InspectResult inspect(const PointCloud& scan, const TriangleMesh& cad,
                      const InspectSettings& settings);
// The same against a CAD model prepared once for many scans (PreparedTarget of a mesh; a cloud
// target is std::invalid_argument): the same result, to the bit.
InspectResult inspect(const PointCloud& scan, const PreparedTarget& cad,
                      const InspectSettings& settings);

// The outlier distance `settings` give for a CAD model of this diagonal.
double outlier_distance(const InspectSettings& settings, double cad_diagonal);

}  // namespace align3d
