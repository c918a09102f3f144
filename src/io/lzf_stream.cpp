#include "lzf_stream.hpp"

#include <algorithm>
#include <cstring>
#include <vector>

#include "io_detail.hpp"

namespace align3d::io::detail {
namespace {

constexpr std::size_t kWindow = 8192;     // the farthest back-reference: (31 << 8) + 255 + 1
constexpr std::size_t kLongestRun = 264;  // the longest back-reference: 7 + 255 + 2 (a literal: 32)
constexpr std::size_t kLongestOp = 33;    // the most input one step reads: a literal's 1 + 32 bytes
constexpr std::size_t kOutputBytes = std::size_t{256} << 10;  // handed to the sink at a time

}  // namespace

LzfResult lzf_decompress_stream(BlockReader& in, std::uint64_t compressed,
                                std::uint64_t uncompressed, const LzfSink& sink) {
  // A short output fits whole (then the buffer is never shifted: no run is written past
  // `uncompressed`).
  std::vector<char> out;
  try {
    out.resize(static_cast<std::size_t>(
        std::min<std::uint64_t>(kWindow + kOutputBytes, uncompressed + kLongestRun)));
  } catch (const std::bad_alloc&) {
    fail_out_of_memory(in.path(), "an LZF window");
  }
  std::size_t op = 0;      // out[op] is the next output byte
  std::size_t handed = 0;  // out[0, handed) has gone to the sink
  std::uint64_t base = 0;  // output offset of out[0]
  std::uint64_t left = compressed;
  const auto hand = [&] { handed += sink(out.data() + handed, op - handed, base + handed); };
  while (left > 0) {
    const auto want = static_cast<std::size_t>(std::min<std::uint64_t>(left, kLongestOp));
    std::string_view input = in.peek(want);
    if (input.size() < want) return {false, base + op};  // the file ended early (it shrank)
    if (input.size() > left) input = input.substr(0, static_cast<std::size_t>(left));
    const bool last = input.size() == left;  // the rest of the stream, so running short is an error
    const auto* ip = reinterpret_cast<const unsigned char*>(input.data());
    const auto* const end = ip + input.size();
    while (ip < end && (last || static_cast<std::size_t>(end - ip) >= kLongestOp)) {
      if (out.size() - op < kLongestRun) {
        // Make room, keeping the window (and any partial value the sink left).
        hand();
        const std::size_t keep_from = std::min(op - kWindow, handed);
        std::memmove(out.data(), out.data() + keep_from, op - keep_from);
        base += keep_from;
        op -= keep_from;
        handed -= keep_from;
      }
      const unsigned control = *ip++;
      if (control < 32) {
        const std::size_t run = control + 1;
        if (static_cast<std::size_t>(end - ip) < run || base + op + run > uncompressed) {
          return {false, base + op};
        }
        std::memcpy(out.data() + op, ip, run);
        ip += run;
        op += run;
        continue;
      }
      std::size_t run = control >> 5;
      if (ip == end) return {false, base + op};
      if (run == 7) {
        run += *ip++;
        if (ip == end) return {false, base + op};
      }
      const std::size_t distance = ((control & 31u) << 8) + *ip++ + 1;
      run += 2;
      // The window kept above holds every distance once base > 0.
      if (distance > base + op || base + op + run > uncompressed) return {false, base + op};
      for (std::size_t i = 0; i < run; ++i, ++op) out[op] = out[op - distance];  // may overlap
    }
    const auto used = static_cast<std::size_t>(reinterpret_cast<const char*>(ip) - input.data());
    in.consume(used);
    left -= used;
  }
  hand();
  return {base + op == uncompressed && handed == op, base + op};
}

}  // namespace align3d::io::detail
