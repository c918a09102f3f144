// align3d ppf-model MODEL OUT: build the PPF model description once, for many scans.
#include <sstream>
#include <stdexcept>

#include "align3d/coarse/ppf.hpp"
#include "align3d/error.hpp"
#include "align3d/find.hpp"
#include "align3d/icp/refine.hpp"
#include "common.hpp"

namespace align3d::cli {
namespace {

struct PpfModelOptions {
  std::string model, out;
  double voxel = GlobalSettings{}.voxel;
  bool find = false;
  double voxel_fraction = kFindVoxelFraction;
};

// The description `align3d find` uses (find.hpp: build_find_model, outward normals).
PpfModel find_description(const PpfModelOptions& o, std::ostream& err) {
  try {
    if (io::is_mesh_file(o.model))
      return build_find_model(load_mesh(o.model, err), o.voxel_fraction);
    return build_find_model(load_cloud(o.model, err), o.voxel_fraction);
  } catch (const DataError& e) {
    throw DataError(o.model, e.problem());
  }
}

}  // namespace

Command add_ppf_model(CLI::App& app, Streams io) {
  auto o = std::make_shared<PpfModelOptions>();
  CLI::App* sub = app.add_subcommand(
      "ppf-model",
      "Build the point-pair-feature description of MODEL and save it to OUT, for\n"
      "`align3d register SCAN MODEL --ppf-model OUT` on many scans (MODEL is their target); with\n"
      "--find, for `align3d find OUT SCENE` on many scenes (MODEL is the part).");
  sub->add_option("MODEL", o->model,
                  "Model: a cloud, or a mesh (sampled evenly by area, as registration samples a "
                  "mesh target); the target of later registrations")
      ->required();
  sub->add_option("OUT", o->out, "Output file for the model description")->required();
  sub->add_option("--voxel", o->voxel,
                  "Voxel size (data units); 0: the model's extent / 50 (its bulk: 0.5-99.5 "
                  "percentiles), as register's global stage uses")
      ->check(finite_non_negative())
      ->capture_default_str();
  sub->add_flag("--find", o->find,
                "Describe MODEL for `align3d find` instead: outward normals (a mesh's faces, or "
                "the cloud's own), sampled with --voxel-fraction of its diameter");
  sub->add_option("--voxel-fraction", o->voxel_fraction,
                  "With --find: the sampling step as a share of the model's diameter")
      ->check(CLI::Range(0.005, 0.25))
      ->capture_default_str();
  return {sub, [o, io] {
            if (o->find) {
              if (o->voxel != 0)
                throw UsageError(
                    "--voxel is for registration models; with --find the step is "
                    "--voxel-fraction of the model's diameter");
              const PpfModel description = find_description(*o, io.err);
              save_ppf_model(o->out, description);
              io.out << "wrote " << o->out << " (PPF model of " << o->model << " for find, voxel "
                     << description.voxel << ", " << description.points.size() << " points)\n";
              return 0;
            }
            // A mesh is described by the sample registration uses for its global stage.
            const PointCloud model =
                io::is_mesh_file(o->model)
                    ? mesh_target_sample(MeshIndex(load_mesh(o->model, io.err), 0, o->model))
                    : load_cloud(o->model, io.err);
            GlobalSettings gs;
            gs.voxel = o->voxel;
            PpfModel description;
            try {
              description = build_ppf_model(model, global_voxel(model, model, gs));
            } catch (const DataError& e) {
              throw DataError(o->model, e.problem());
            } catch (const std::invalid_argument& e) {
              // The one argument the user chose: a voxel so small that the grid overflows.
              std::ostringstream voxel;
              voxel << o->voxel;
              throw UsageError("--voxel " + voxel.str() + " is too small for " + o->model + " (" +
                               e.what() + ")");
            }
            save_ppf_model(o->out, description);
            io.out << "wrote " << o->out << " (PPF model of " << o->model << ", voxel "
                   << description.voxel << ", " << description.points.size() << " points)\n";
            return 0;
          }};
}

}  // namespace align3d::cli
