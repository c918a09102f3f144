// STEP and IGES through OpenCASCADE (mesh_io.hpp): private to src/io. Built with ALIGN3D_OCCT the
// reader tessellates the file's shapes, in a child process, with the module libalign3d_occt.so
// (occt_module.hpp); without it, it throws an IoError saying so.
//
// OCCT keeps process-wide state (its default messenger, the Interface_Static parameters, IGES's C
// parser), so the module serialises reads by a mutex. While a read runs, the default messenger's
// printers are set aside (OCCT would print to stdout) and the session's length unit is
// millimetres; both are restored afterwards.
#pragma once

#include <filesystem>

#include "align3d/io/mesh_io.hpp"

namespace align3d::io::detail {

// Whether this build reads STEP and IGES: built with OpenCASCADE and its module found
// (cad_exchange.cpp: where it is looked for).
bool occt_available();

// Reads a STEP (format kStep) or IGES (kIges) file and tessellates every face (mesh_io.hpp):
// vertices in millimetres (OCCT converts from the unit the file declares), each face's own
// vertices (faces meet at identical coordinates; clean_mesh welds them), triangles wound outward.
// Fills info.format and info.chord_tolerance. Throws IoError "<path>: <problem>" for a file that
// is missing, empty, larger than 1 GiB, not of its extension's format, broken (OCCT's load checks
// fail), without a face, or that OCCT cannot tessellate; DataError when memory runs out;
// std::invalid_argument for a negative or non-finite chord tolerance.
TriangleMesh read_cad_exchange(const std::filesystem::path& path, MeshFormat format,
                               const MeshReadSettings& settings, MeshReadInfo& info);

}  // namespace align3d::io::detail
