// The one call between the core's STEP and IGES reader (cad_exchange.cpp) and the module that holds
// OpenCASCADE (src/io/occt/read_cad.cpp, built as libalign3d_occt.so): private to src/io.
//
// Why a module: OCCT's eight toolkits and what they pull in cost every process that links them
// about 50 ms of dynamic relocation before main() (measured on Debian 12, OCCT 7.6.3: an empty
// program linked to them starts in 47 ms, 1.6 ms without; `align3d --version` took 80 ms). Loaded
// with dlopen on the first STEP or IGES file, only the reads of such files pay it: every other
// command, `import align3d`, and each test process start without.
#pragma once

#include <string>

namespace align3d::io::detail {

// What a read returns. kMesh: `text` is the mesh as the module serialised it (the chord
// tolerance as a double, the vertex and triangle counts as two uint64, then the vertices as
// x, y, z doubles and the triangles as three uint32 each, in this machine's byte order: the reader
// is the same build). kIoError: `text` is the problem with the file (the caller prefixes the path).
// kOutOfMemory: `text` names what did not fit.
struct OcctAnswer {
  enum class Outcome { kMesh, kIoError, kOutOfMemory };
  Outcome outcome = Outcome::kIoError;
  std::string text;
};

// The module's entry, named kOcctEntry: reads `path` as STEP (step true) or IGES with the chord
// tolerance `chord` (0: the default of mesh_io.hpp; the caller checked it) and fills `answer`.
// Never throws.
using OcctRead = void (*)(const char* path, bool step, double chord, OcctAnswer& answer);
inline constexpr const char* kOcctEntry = "align3d_occt_read";
inline constexpr const char* kOcctModuleName = "libalign3d_occt.so";

}  // namespace align3d::io::detail
