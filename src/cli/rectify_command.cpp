// align3d rectify CLOUD: plane correction (chapter 39.5, plane/rectify.hpp).
#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/plane/rectify.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct RectifyOptions {
  std::string cloud, output, report, up;
  bool robust = false;
  std::uint64_t seed = 1;
};

}  // namespace

nlohmann::json rectify_json(const RectifyResult& r) {
  return {{"normal", to_json(r.normal)},
          {"tilt_before_deg", r.tilt_before_deg},
          {"tilt_after_deg", r.tilt_after_deg},
          {"inliers", r.inliers},
          {"flatness", r.flatness},
          {"transformation", to_json(r.transformation)}};
}

Command add_rectify(CLI::App& app, Streams io) {
  auto o = std::make_shared<RectifyOptions>();
  CLI::App* sub = app.add_subcommand(
      "rectify",
      "Level CLOUD: fit its plane, rotate the normal onto +Z and shift the plane to z = 0.\n"
      "Up side: --up if given, else the side a part on the plane stands on, else +Z.");
  sub->add_option("CLOUD", o->cloud, "Cloud of a plate or a part on a reference plane")->required();
  sub->add_option("--output", o->output, "Write the levelled cloud");
  sub->add_option("--report", o->report, "Write a JSON report to FILE, or to stdout with -");
  sub->add_flag(
      "--robust", o->robust,
      "Find the dominant plane with RANSAC first, then refit on its inliers (clutter-proof)");
  CLI::Option* up =
      sub->add_option("--up", o->up, "X,Y,Z: the direction that counts as up (the normal's sign)");
  sub->add_option("--seed", o->seed, "RANSAC seed (with --robust)")
      ->check(CLI::NonNegativeNumber)  // CLI11 would wrap -1 to 2^64 - 1
      ->capture_default_str();
  return {sub, [o, io, up] {
            RectifySettings s;
            s.robust = o->robust;
            s.ransac.seed = o->seed;
            if (up->count() > 0) {
              s.up = parse_vector(o->up, "--up");
              if (s.up->isZero(0.0))
                throw UsageError("--up: the zero vector gives no direction, got '" + o->up + "'");
            }
            const PointCloud cloud = load_cloud(o->cloud, io.err);
            RectifyResult r;
            try {
              r = rectify(cloud, s);
            } catch (const DataError& e) {
              throw DataError(o->cloud + ": " + e.what());  // which file has no plane
            }
            if (!o->output.empty())
              io::write_point_cloud(o->output, transformed(cloud, r.transformation));
            nlohmann::json report = rectify_json(r);
            report["points"] = cloud.size();
            if (!o->report.empty()) write_json(o->report, report, io.out);
            if (o->report != "-")
              io.out << "rectified " << o->cloud << ": tilt " << r.tilt_before_deg << " deg -> "
                     << r.tilt_after_deg << " deg, " << r.inliers << " of " << cloud.size()
                     << " points on the plane, flatness " << r.flatness << "\n";
            return 0;
          }};
}

}  // namespace align3d::cli
