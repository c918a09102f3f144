// Streaming input for the readers in src/io (not installed): a file (or, for the fuzzers and tests,
// memory) read front to back through one buffer of fixed capacity, so that reading a cloud costs
// the cloud plus a constant, whatever the file's size. Offsets count from the file's first byte,
// for the byte offsets in error messages; the file's size, known when it is opened, bounds every
// count a header announces before anything is allocated.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace align3d::io::detail {

// Where the bytes come from.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;  // as known when opened
  // Reads up to n > 0 bytes into `out` and returns how many; 0 only at the end. Throws IoError on a
  // read error.
  virtual std::size_t read(char* out, std::size_t n) = 0;
  virtual void rewind() = 0;  // back to the first byte
};

// A regular file. IoError if it is missing, not a regular file, empty, larger than max_bytes or
// cannot be opened.
std::unique_ptr<ByteSource> open_file(const std::filesystem::path& path, std::uint64_t max_bytes);

// Bytes in memory (not copied), handed out at most max_read at a time: short reads put the block
// boundaries anywhere, which the fuzzers and tests use.
class MemorySource : public ByteSource {
 public:
  explicit MemorySource(std::string_view data, std::size_t max_read = SIZE_MAX)
      : data_(data), max_read_(max_read) {}
  std::uint64_t size() const override { return data_.size(); }
  std::size_t read(char* out, std::size_t n) override;
  void rewind() override { pos_ = 0; }

 private:
  std::string_view data_;
  std::size_t max_read_;
  std::size_t pos_ = 0;
};

// The buffer's capacity bounds what peek() and one line can span: above the 1 MiB bounds of
// io_detail.hpp, and large enough that reading costs one system call per 4 MiB.
inline constexpr std::size_t kBlockBytes = std::size_t{4} << 20;

class BlockReader {
 public:
  // The buffer holds `capacity` bytes, or the whole file (+ 1) if that is smaller: a file's lines
  // and records cannot be longer than the file.
  BlockReader(const std::filesystem::path& path, ByteSource& source,
              std::size_t capacity = kBlockBytes);

  const std::filesystem::path& path() const { return path_; }
  std::size_t capacity() const { return capacity_; }
  std::uint64_t offset() const { return base_ + begin_; }  // of the next unconsumed byte
  // What the file holds from offset() on, by the size it had when opened.
  std::uint64_t remaining() const {
    return offset() < source_.size() ? source_.size() - offset() : 0;
  }

  // The bytes read but not consumed; valid until the next call that reads.
  std::string_view buffered() const { return {buffer_.get() + begin_, end_ - begin_}; }
  // At least n <= capacity() bytes from offset() on (fewer only at the end of the file): the whole
  // buffer, reading more only if fewer than n are buffered.
  std::string_view peek(std::size_t n) {
    if (end_ - begin_ < n) fill(n);
    return buffered();
  }
  // Reads more after the buffered bytes (keeping them); false if nothing more could be read: at the
  // end of the file, or with the buffer full.
  bool read_more();
  void consume(std::size_t n) { begin_ += n; }  // n <= buffered().size()
  // Consumes n bytes, buffered or not; returns how many there were (fewer at the end of the file).
  std::uint64_t skip(std::uint64_t n);
  void rewind();

 private:
  void fill(std::size_t n);  // compacts, then reads until n bytes are buffered or the file ends

  std::filesystem::path path_;
  ByteSource& source_;
  std::size_t capacity_;
  std::unique_ptr<char[]> buffer_;
  std::size_t begin_ = 0, end_ = 0;  // buffered bytes: buffer_[begin_, end_)
  std::uint64_t base_ = 0;           // file offset of buffer_[0]
  bool at_end_ = false;
};

// The lines of a text file or header. A line ends at the file's line terminator, taken from the
// first line: '\n' (a '\r' before it is dropped: Windows' "\r\n"), or '\r' alone (classic Mac OS;
// a '\n' right after a '\r' then belongs to that line end). A binary PLY or PCD body starts right
// after its header's last terminator.
class LineReader {
 public:
  explicit LineReader(BlockReader& in) : in_(in) {}

  // False at the end of the file; otherwise `line` is the next line without its terminator, valid
  // until the next call that reads. A line longer than `limit` (at most the buffer's capacity - 1)
  // comes back cut to limit + 1 bytes, which the caller must reject (check_line_length): the reader
  // never holds more than that of a line.
  bool next(std::string_view& line, std::size_t limit);
  std::size_t number() const { return number_; }  // 1-based number of the line last returned
  BlockReader& input() { return in_; }

 private:
  // Position (in buffered()) of the first line end at or after `from` and before `to`, or npos.
  std::size_t find_end(std::string_view data, std::size_t from, std::size_t to) const;

  BlockReader& in_;
  std::size_t number_ = 0;
  char terminator_ = 0;         // '\n' or '\r' once the first line end has been seen
  bool newline_after_ = false;  // '\r' terminator: skip a '\n' that follows the last one
};

// A PLY or PCD text header, line by line: each line's words (split on spaces and tabs), the whole
// header within kMaxHeaderBytes. `end_marker` names what ends it, for the errors ("an end_header
// line", "a DATA line").
class HeaderLines {
 public:
  HeaderLines(LineReader& lines, std::string_view end_marker)
      : lines_(lines), end_marker_(end_marker) {}
  // The next line's words (none for a blank line), valid until the next call. IoError at the end of
  // the file or past kMaxHeaderBytes.
  const std::vector<std::string_view>& next();
  std::string_view line() const { return line_; }
  std::size_t number() const { return lines_.number(); }
  std::string where() const { return "line " + std::to_string(number()) + ": "; }

 private:
  LineReader& lines_;
  std::string_view end_marker_;
  std::string_view line_;
  std::vector<std::string_view> words_;
};

}  // namespace align3d::io::detail
