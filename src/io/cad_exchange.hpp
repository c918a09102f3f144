// STEP and IGES through OpenCASCADE (mesh_io.hpp): private to src/io. Built with ALIGN3D_OCCT the
// reader tessellates the file's shapes; without it, it throws an IoError saying so.
#pragma once

#include <filesystem>

#include "align3d/io/mesh_io.hpp"

namespace align3d::io::detail {

// Whether this build reads STEP and IGES.
bool occt_available();

// Reads a STEP (format kStep) or IGES (kIges) file and tessellates every face (mesh_io.hpp).
TriangleMesh read_cad_exchange(const std::filesystem::path& path, MeshFormat format,
                               const MeshReadSettings& settings, MeshReadInfo& info);

}  // namespace align3d::io::detail
