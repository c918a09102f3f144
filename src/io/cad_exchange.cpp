// Placeholder until the OpenCASCADE reader lands: this build reads no STEP or IGES.
#include "cad_exchange.hpp"

#include "io_detail.hpp"

namespace align3d::io::detail {

bool occt_available() { return false; }

TriangleMesh read_cad_exchange(const std::filesystem::path& path, MeshFormat, const MeshReadSettings&,
                               MeshReadInfo&) {
  fail(path, "STEP and IGES need align3d built with OpenCASCADE (cmake -DALIGN3D_OCCT=ON)");
}

}  // namespace align3d::io::detail
