// Streaming LZF decompression for PCD's binary_compressed (not installed). liblzf's lzf_decompress
// needs the whole input and the whole output in memory; this decoder reads the input through a
// BlockReader and keeps only LZF's 8 KiB window of output, so memory does not grow with the file.
#pragma once

#include <cstdint>
#include <functional>

#include "block_reader.hpp"

namespace align3d::io::detail {

// Receives the output in order: `size` bytes at `data`, the first of them at `offset` in the
// whole output. Returns how many leading bytes it used, at least size - 7: it may leave a partial
// value for the next call, which then starts with those bytes again.
using LzfSink =
    std::function<std::size_t(const char* data, std::size_t size, std::uint64_t offset)>;

struct LzfResult {
  bool ok = false;             // the stream was valid and expanded to exactly `uncompressed` bytes
  std::uint64_t produced = 0;  // bytes expanded before an error was found (or all of them)
};

// Decodes the `compressed` bytes at in.offset(), liblzf's format (lzf_d.c): a control byte c < 32
// starts a literal run of c + 1 bytes; otherwise it is a back-reference of length (c >> 5) + 2
// (c >> 5 == 7: plus the next byte) to distance ((c & 31) << 8) + next byte + 1 behind. A
// reference before the start of the output, a run past the input's end or output beyond
// `uncompressed` makes the stream corrupt, as for lzf_decompress. The input is consumed up to the
// error, or entirely; the sink sees only valid output.
LzfResult lzf_decompress_stream(BlockReader& in, std::uint64_t compressed,
                                std::uint64_t uncompressed, const LzfSink& sink);

}  // namespace align3d::io::detail
