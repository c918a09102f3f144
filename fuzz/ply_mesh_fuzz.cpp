// libFuzzer target: the PLY mesh reader (src/io/ply.cpp: vertices and faces) on arbitrary bytes.
#include "mesh_fuzz_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return align3d::fuzz::run_mesh_reader(&align3d::io::detail::read_ply_mesh, "fuzz.ply", data,
                                        size);
}
