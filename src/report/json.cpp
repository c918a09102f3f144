#include "align3d/report/json.hpp"

#include <stdexcept>

#include "align3d/io/atomic_file.hpp"
#include "align3d/se3.hpp"

namespace align3d::report {
namespace {

nlohmann::json refine_json(const RefineResult& r) {
  nlohmann::json history = nlohmann::json::array();
  for (const auto& h : r.history)
    history.push_back({{"rms", h.rms}, {"kept", h.kept}, {"threshold", h.threshold}});
  nlohmann::json stages = nlohmann::json::array();
  for (const auto& s : r.stages)
    stages.push_back({{"metric", s.metric},
                      {"max_distance", s.max_distance},
                      {"first_iteration", s.first_iteration},
                      {"iterations", s.iterations},
                      {"hop", s.hop},
                      {"resolution", s.resolution}});
  nlohmann::json weak = nlohmann::json::array();
  for (const auto& w : r.icp.degenerate_directions)
    weak.push_back({{"rotation", to_json(w.rotation)},
                    {"translation", to_json(w.translation)},
                    {"strength", w.strength}});
  return {{"iterations", r.total_iterations},
          {"converged", r.icp.converged},
          {"stop_reason", to_string(r.icp.stop_reason)},
          {"rms", r.icp.rms},
          {"fitness", r.icp.fitness},
          {"correspondences", r.icp.correspondences},
          {"degenerate_directions", weak},
          {"normals", {{"estimated", r.estimated_normals}, {"undefined", r.undefined_normals}}},
          {"history", history},
          {"stages", stages},
          {"hops", r.hops},
          {"hopped", r.hopped},
          {"unconfirmed", r.unconfirmed},
          {"fit", to_json(r.fit)}};
}

nlohmann::json init_json(const AlignResult& r, const AlignSettings& s) {
  nlohmann::json candidates = nlohmann::json::array();
  for (const AlignCandidate& c : r.candidates)
    candidates.push_back({{"path", c.path},
                          {"transformation", to_json(c.transformation)},
                          {"overlap", c.support.overlap},
                          {"rms", c.rms},
                          {"fit_ratio", c.fit.ratio},
                          {"weak", c.weak}});
  return {{"policy", to_string(s.init)},
          {"path", r.path},
          {"reason", r.reason},
          {"candidates", candidates}};
}

nlohmann::json stitch_pose_json(const StitchScan& s, const InputInfo& in) {
  return {{"file", in.path},
          {"transformation", to_json(s.transformation)},
          {"connected", s.connected},
          {"points", s.points},
          {"edges", s.edges},
          {"sensor", {{"position", to_json(s.viewpoint)}, {"source", to_string(s.sensor)}}},
          {"residual", {{"pairs", s.pairs}, {"rms", s.rms}, {"median", s.median}, {"p95", s.p95}}},
          {"warnings", s.warnings}};
}

nlohmann::json stitch_edge_json(const StitchEdge& e, const std::vector<InputInfo>& scans) {
  const auto file = [&](std::size_t k) { return k < scans.size() ? scans[k].path : ""; };
  return {{"source", e.source},
          {"target", e.target},
          {"source_file", file(e.source)},
          {"target_file", file(e.target)},
          {"transformation", to_json(e.transformation)},
          {"overlap", e.overlap},
          {"rms", e.rms},
          {"pairs", e.pairs},
          {"free_space", e.free_space},
          {"kept", e.kept},
          {"status", e.status},
          {"rotation_residual_deg", e.rotation_residual_deg},
          {"translation_residual", e.translation_residual},
          {"information", matrix6_json(e.information)},
          {"warnings", to_json(e.warnings)}};
}

// The ICP cost a command was given (refine.hpp, CostSettings).
nlohmann::json cost_json(const CostSettings& c) {
  return {{"method", to_string(c.method)},
          {"kernel", kernel_name(c)},
          {"kernel_scale", c.kernel_scale}};
}

nlohmann::json stitch_settings_json(const StitchSettings& s) {
  nlohmann::json viewpoints = nlohmann::json::array();
  for (const std::optional<Eigen::Vector3d>& v : s.viewpoints)
    viewpoints.push_back(v ? to_json(*v) : nlohmann::json());
  return {{"min_overlap", s.min_overlap},
          {"prune_rotation_deg", s.prune_rotation_deg},
          {"prune_translation", s.prune_translation},
          {"multiview_iterations", s.multiview_iterations},
          {"voxel", s.voxel},
          {"viewpoints", viewpoints},
          {"threads", s.threads},
          {"icp", cost_json(s.cost)}};
}

// A mesh's points are its vertices; its triangles are listed too.
nlohmann::json input_json(const InputInfo& in) {
  nlohmann::json j = {{"path", in.path}, {"points", in.points}};
  if (in.triangles > 0) j["triangles"] = in.triangles;
  return j;
}

// An organized scene's depth noise (RangeImage::noise_depth): [depth, σ of the depth] per depth
// bin, data units; empty when it was not measured.
nlohmann::json depth_noise_json(const RangeImage& im) {
  nlohmann::json out = nlohmann::json::array();
  for (double z : im.noise_depth) out.push_back({z, im.depth_sigma(z)});
  return out;
}

}  // namespace

nlohmann::json to_json(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c) row.push_back(T.matrix()(r, c));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json to_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::json matrix6_json(const Matrix6d& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 6; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 6; ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json to_json(const std::vector<Warning>& warnings) {
  nlohmann::json out = nlohmann::json::array();
  for (const Warning& w : warnings) out.push_back({{"code", w.code}, {"message", w.message}});
  return out;
}

nlohmann::json to_json(const GlobalResult& g) {
  nlohmann::json j = {{"method", to_string(g.method)},
                      {"success", g.success},
                      {"object", to_string(g.object)},
                      {"voxel", g.voxel},
                      {"score", g.score},
                      {"votes", g.votes},
                      {"overlap", g.overlap},
                      {"candidates", g.candidates},
                      {"transformation", to_json(g.T_target_source)},
                      {"ambiguous", g.ambiguous},
                      {"message", g.message},
                      {"time_ms", g.time_ms}};
  if (g.ambiguous) {
    j["second_transformation"] = to_json(g.second_T_target_source);
    j["second_score"] = g.second_score;
  }
  return j;
}

nlohmann::json to_json(const Support& s) {
  return {{"overlap", s.overlap}, {"object", to_string(s.object)}, {"noise", s.noise},
          {"spacing", s.spacing}, {"structured", s.structured},    {"reach", s.reach},
          {"band", s.band}};
}

nlohmann::json to_json(const FitEvidence& f) {
  return {{"ratio", f.ratio},
          {"rms", f.rms},
          {"expected", f.expected},
          {"structured", f.structured},
          {"pairs", f.pairs}};
}

nlohmann::json registration_report(const AlignResult& r, const AlignSettings& s,
                                   const InputInfo& source, const InputInfo& target,
                                   const std::optional<Eigen::Isometry3d>& truth) {
  const Eigen::Isometry3d& T = r.transformation;
  nlohmann::json j = {{"success", r.success},
                      {"source", input_json(source)},
                      {"target", input_json(target)},
                      {"method", to_string(s.refine.method)},
                      {"rejection", to_string(s.refine.rejection)},
                      {"kernel", kernel_name(s.refine)},
                      {"icp_direction", r.reversed ? "target onto source" : "source onto target"},
                      {"init", init_json(r, s)},
                      {"transformation", to_json(T)},
                      {"covariance", matrix6_json(r.covariance)},
                      {"pending_sigmas", r.refine.icp.pending_sigmas},
                      {"rotation_deg", rad_to_deg(rotation_angle(T.linear()))},
                      {"translation", to_json(T.translation())},
                      {"support", to_json(r.support)},
                      {"warnings", to_json(r.warnings)},
                      {"timing_ms",
                       {{"total", r.timings.total_ms},
                        {"prepare", r.timings.prepare_ms},
                        {"global", r.timings.global_ms},
                        {"refine", r.timings.refine_ms},
                        {"support", r.timings.support_ms}}}};
  if (!r.success) j["failure"] = r.failure;
  j.update(refine_json(r.refine));
  if (r.global) j["global"] = to_json(*r.global);
  if (truth) {
    const PoseError e = pose_error(T, *truth);
    j["rotation_error_deg"] = e.rotation_deg;
    j["translation_error"] = e.translation;
  }
  return j;
}

nlohmann::json inspection_report(const InspectResult& r, const InspectSettings& s,
                                 const InputInfo& scan, const InputInfo& cad) {
  nlohmann::json j = registration_report(r.registration, s.align, scan, cad);
  const DeviationStats& d = r.stats;
  j["deviation"] = {{"count", d.count}, {"mean", d.mean}, {"std", d.std}, {"rms", d.rms},
                    {"min", d.min},     {"max", d.max},   {"p01", d.p01}, {"p05", d.p05},
                    {"p50", d.p50},     {"p95", d.p95},   {"p99", d.p99}};
  j["gauss_fit"] = {{"mean", r.gauss.mean}, {"sigma", r.gauss.sigma}};
  j["tolerance"] = {{"lower", r.tolerance.lower}, {"upper", r.tolerance.upper}};
  j["within_tolerance"] = r.within_tolerance;
  j["counts"] = {{"below", r.below}, {"within", r.within}, {"above", r.above}};
  j["outliers"] = r.map.outliers;
  j["max_distance"] = r.map.max_distance;
  j["pass_fraction"] = s.pass_fraction;
  j["verdict"] = r.pass ? "pass" : "fail";
  j["histogram"] = {{"lo", r.histogram.lo},
                    {"hi", r.histogram.hi},
                    {"counts", r.histogram.counts},
                    {"below", r.histogram.below},
                    {"above", r.histogram.above}};
  j["mesh"] = {{"triangles", r.mesh.triangles},
               {"vertices", r.mesh.vertices},
               {"closed", r.mesh.closed()},
               {"boundary_edges", r.mesh.boundary_edges},
               {"non_manifold_edges", r.mesh.non_manifold_edges},
               {"components", r.mesh.components},
               {"welded_vertices", r.repair.welded_vertices},
               {"dropped_triangles", r.repair.dropped_triangles},
               {"inconsistent_edges", r.repair.inconsistent_edges},
               {"rewound_triangles", r.repair.flipped_triangles},
               {"inverted_components", r.repair.inverted_components}};
  j["warnings"] = to_json(r.warnings);
  j["timing_ms"]["align"] = r.align_ms;
  j["timing_ms"]["deviation"] = r.deviation_ms;
  j["timing_ms"]["inspect"] = r.total_ms;
  return j;
}

nlohmann::json find_report(const FindResult& r, const FindSettings& s, const InputInfo& model,
                           const InputInfo& scene) {
  nlohmann::json instances = nlohmann::json::array();
  for (std::size_t k = 0; k < r.instances.size(); ++k) {
    const FoundInstance& f = r.instances[k];
    instances.push_back({{"rank", k + 1},
                         {"transformation", to_json(f.T_scene_model)},
                         {"score", f.score},
                         {"visible_fraction", f.visible_fraction},
                         {"rms", f.rms},
                         {"points", f.explained},
                         {"symmetry", r.symmetry.name()}});
  }
  const RangeImage& im = r.image;
  return {{"instances", instances},
          {"model",
           {{"path", model.path},
            {"points", model.points},
            {"triangles", model.triangles},
            {"diameter", r.model_diameter},
            {"voxel", r.voxel},
            {"feature_points", r.model_points},
            {"symmetry", r.symmetry.name()},
            {"partial", r.model_side.partial},
            {"seen_from", to_json(r.model_side.seen_from)},
            {"hidden_share", r.model_side.hidden_share}}},
          {"scene",
           {{"path", scene.path},
            {"points", scene.points},
            {"organized", im.organized},
            {"width", im.width},
            {"height", im.height},
            {"camera", {{"fx", im.fx}, {"fy", im.fy}, {"cx", im.cx}, {"cy", im.cy}}},
            {"camera_pose", to_json(im.T_cloud_camera)},
            {"orientation_from_rays", im.orientation_from_rays},
            {"given_orientation_error_deg", im.given_orientation_error_deg},
            {"depth_noise", depth_noise_json(im)},
            {"depth_dropped", r.depth_dropped},
            {"plane_points", r.plane_points},
            {"voting_points", r.voting_points}}},
          {"hypotheses", r.hypotheses},
          {"settings",
           {{"max_instances", s.max_instances},
            {"min_score", s.min_score},
            {"symmetry", s.detect_symmetry ? "auto" : s.symmetry.name()},
            {"remove_plane", s.remove_plane},
            {"min_depth", s.min_depth},
            {"max_depth", s.max_depth},
            {"seed", s.seed},
            {"icp", cost_json(s.cost)}}},
          {"warnings", to_json(r.warnings)},
          {"timing_ms",
           {{"prepare", r.prepare_ms},
            {"vote", r.vote_ms},
            {"refine", r.refine_ms},
            {"verify", r.verify_ms},
            {"total", r.total_ms}}}};
}

nlohmann::json stitch_report(const StitchResult& r, const StitchSettings& s,
                             const std::vector<InputInfo>& scans, const std::string& merged_file,
                             bool scan_index) {
  if (scans.size() != r.scans.size())
    throw std::invalid_argument("stitch_report: " + std::to_string(scans.size()) +
                                " inputs named for " + std::to_string(r.scans.size()) + " scans");
  nlohmann::json poses = nlohmann::json::array();
  for (std::size_t k = 0; k < r.scans.size(); ++k)
    poses.push_back(stitch_pose_json(r.scans[k], scans[k]));
  nlohmann::json edges = nlohmann::json::array();
  for (const StitchEdge& e : r.edges) edges.push_back(stitch_edge_json(e, scans));
  const StitchTimings& t = r.timings;
  return {{"poses", poses},
          {"edges", edges},
          {"merged",
           {{"file", merged_file},
            {"points", r.merged.size()},
            {"voxel", r.voxel},
            {"scan_index", scan_index}}},
          {"diameter", r.diameter},
          {"multiview_iterations", r.multiview_iterations},
          {"settings", stitch_settings_json(s)},
          {"warnings", to_json(r.warnings)},
          {"timings",
           {{"pairs_ms", t.pairs_ms},
            {"edges_ms", t.edges_ms},
            {"graph_ms", t.graph_ms},
            {"multiview_ms", t.multiview_ms},
            {"merge_ms", t.merge_ms},
            {"total_ms", t.total_ms}}}};
}

nlohmann::json rectify_report(const RectifyResult& r, const RectifySettings& s,
                              const InputInfo& cloud) {
  return {{"cloud", {{"path", cloud.path}, {"points", cloud.points}}},
          {"fit", s.robust ? "robust" : "lsq"},
          {"normal", to_json(r.normal)},
          {"tilt_before_deg", r.tilt_before_deg},
          {"tilt_after_deg", r.tilt_after_deg},
          {"inliers", r.inliers},
          {"flatness", r.flatness},
          {"rms", r.rms},
          {"noise", r.noise},
          {"transformation", to_json(r.T_level_cloud)},
          {"warnings", to_json(r.warnings)}};
}

void write_json(const std::string& path, const nlohmann::json& report, std::ostream& out) {
  const std::string text = report.dump(2) + "\n";
  if (path == "-") {
    out << text;
    out.flush();
  } else {
    io::write_text_atomically(path, text);
  }
}

}  // namespace align3d::report
