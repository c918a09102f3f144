// align3d rectify CLOUD: plane correction (chapter 39.5, plane/rectify.hpp).
#include "align3d/error.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/plane/rectify.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct RectifyOptions {
  std::string cloud, output, report, up;
  std::string fit = RectifySettings{}.robust ? "robust" : "lsq";
  bool robust = false, strict = false, quiet = false, up_given = false;
  std::uint64_t seed = RectifySettings{}.ransac.seed;
};

int run_rectify(const RectifyOptions& o, Streams io) {
  RectifySettings s;
  s.robust = o.robust || o.fit == "robust";
  s.ransac.seed = o.seed;
  if (o.up_given) {
    s.up = parse_vector(o.up, "--up");
    if (s.up->isZero(0.0))
      throw UsageError("--up: the zero vector gives no direction, got '" + o.up + "'");
  }
  const PointCloud cloud = load_cloud(o.cloud, io.err);
  RectifyResult r;
  try {
    r = rectify(cloud, s);
  } catch (const DataError& e) {
    throw DataError(o.cloud + ": " + e.what());  // which file has no plane
  }
  if (!o.output.empty()) io::write_point_cloud(o.output, transformed(cloud, r.T_level_cloud));
  if (!o.report.empty())
    write_json(o.report, report::rectify_report(r, s, {o.cloud, cloud.size()}), io.out);
  if (o.report != "-" && !o.quiet)
    io.out << "rectified " << o.cloud << " (" << (s.robust ? "robust" : "least-squares")
           << " fit): tilt " << r.tilt_before_deg << " deg -> " << r.tilt_after_deg << " deg, "
           << r.inliers << " of " << cloud.size() << " points on the plane, RMS " << r.rms
           << " (surface noise " << r.noise << "), flatness " << r.flatness << "\n";
  return report_warnings(r.warnings, o.strict, io.err);
}

}  // namespace

Command add_rectify(CLI::App& app, Streams io) {
  auto o = std::make_shared<RectifyOptions>();
  CLI::App* sub = app.add_subcommand(
      "rectify",
      "Level CLOUD: fit its plane, rotate the normal onto +Z and shift the plane to z = 0.\n"
      "The plane is the dominant one (RANSAC, then least squares on its inliers) unless --fit "
      "lsq.\n"
      "Up side: --up if given, else the side a part on the plane stands on, else +Z.\n"
      "Warns when the fitted points do not lie on one plane (RMS far above the surface noise).");
  sub->add_option("CLOUD", o->cloud, "Cloud of a plate or a part on a reference plane")->required();
  sub->add_option("--output", o->output, "Write the levelled cloud");
  sub->add_option("--report", o->report,
                  "Write a JSON report to FILE, or to stdout with - (keys: docs/report.md)");
  sub->add_option("--fit", o->fit,
                  "robust: the dominant plane (RANSAC + least squares on its inliers; right with "
                  "parts, walls, clutter); lsq: least squares on every point (the chapter's fit, "
                  "for a cloud of the plate alone)")
      ->check(CLI::IsMember({"robust", "lsq"}))
      ->capture_default_str();
  sub->add_flag("--robust", o->robust, "The same as --fit robust (the default)");
  CLI::Option* up =
      sub->add_option("--up", o->up, "X,Y,Z: the direction that counts as up (the normal's sign)");
  sub->add_option("--seed", o->seed, "RANSAC seed (robust fit)")
      ->check(CLI::NonNegativeNumber)  // CLI11 would wrap -1 to 2^64 - 1
      ->capture_default_str();
  add_strict(sub, o->strict);
  add_quiet(sub, o->quiet);
  return {sub, [o, io, up] {
            o->up_given = up->count() > 0;
            return run_rectify(*o, io);
          }};
}

}  // namespace align3d::cli
