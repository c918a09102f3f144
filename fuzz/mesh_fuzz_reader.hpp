// Shared body of the libFuzzer targets for the triangle-mesh readers, as fuzz_reader.hpp is for
// the point-cloud readers (same in-memory input in short reads; an IoError is the expected outcome
// for bad input, anything else that escapes is a finding). A mesh that is returned must honour
// mesh_io.hpp's contract.
#pragma once

#include "fuzz_reader.hpp"
#include "mesh_readers.hpp"

namespace align3d::fuzz {

// Aborts (a libFuzzer crash) when a returned mesh breaks the reader contract: every index in range,
// every vertex finite (a non-finite one used by a triangle is an error, an unused one is removed),
// and no triangle with a repeated corner index (such faces are dropped, larger ones fanned from
// distinct corners).
inline void check_mesh(const TriangleMesh& mesh) {
  for (const auto& v : mesh.vertices) {
    if (!v.allFinite()) __builtin_trap();
  }
  for (const auto& t : mesh.triangles) {
    for (const std::uint32_t i : t) {
      if (i >= mesh.vertices.size()) __builtin_trap();
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) __builtin_trap();
  }
}

using MeshReader = TriangleMesh (*)(io::detail::BlockReader&, io::MeshReadInfo&);

inline int run_mesh_reader(MeshReader reader, const char* name, const std::uint8_t* data,
                           std::size_t size) {
  if (size == 0) return 0;  // open_file rejects empty files before any reader sees them
  FuzzInput input(name, data, size);
  try {
    io::MeshReadInfo info;
    const TriangleMesh mesh = reader(input.in, info);
    check_mesh(mesh);
    if (info.format.empty()) __builtin_trap();
  } catch (const IoError&) {
  }
  return 0;
}

}  // namespace align3d::fuzz
