// libFuzzer target: the PLY reader (src/io/ply.cpp) on arbitrary bytes.
#include "fuzz_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return align3d::fuzz::run_reader(&align3d::io::detail::read_ply, "fuzz.ply", data, size);
}
