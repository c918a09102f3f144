// libFuzzer target: the OBJ reader (src/io/obj.cpp) on arbitrary bytes.
#include "mesh_fuzz_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return align3d::fuzz::run_mesh_reader(&align3d::io::detail::read_obj, "fuzz.obj", data, size);
}
