// libFuzzer target: the STL reader (src/io/stl.cpp), binary and ASCII, on arbitrary bytes.
#include "mesh_fuzz_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return align3d::fuzz::run_mesh_reader(&align3d::io::detail::read_stl, "fuzz.stl", data, size);
}
