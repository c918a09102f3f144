// libFuzzer target: the XYZ reader (src/io/xyz.cpp) on arbitrary bytes.
#include "fuzz_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return align3d::fuzz::run_reader(&align3d::io::detail::read_xyz, "fuzz.xyz", data, size);
}
