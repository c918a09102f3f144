#include "block_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>

#include "io_detail.hpp"

namespace align3d::io::detail {
namespace {

class FileSource : public ByteSource {
 public:
  FileSource(const std::filesystem::path& path, std::FILE* file, std::uint64_t size)
      : path_(path), file_(file), size_(size) {}
  ~FileSource() override { std::fclose(file_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;

  std::uint64_t size() const override { return size_; }
  std::size_t read(char* out, std::size_t n) override {
    const std::size_t got = std::fread(out, 1, n, file_);
    if (got == 0 && std::ferror(file_))
      fail(path_, std::string("read error: ") + std::strerror(errno));
    return got;
  }
  void rewind() override { std::rewind(file_); }

 private:
  std::filesystem::path path_;
  std::FILE* file_;
  std::uint64_t size_;
};

}  // namespace

std::unique_ptr<ByteSource> open_file(const std::filesystem::path& path, std::uint64_t max_bytes) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) fail(path, "file not found");
  if (ec) fail(path, "cannot access: " + ec.message());
  if (!std::filesystem::is_regular_file(status)) fail(path, "not a regular file");
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) fail(path, "cannot determine the file size: " + ec.message());
  if (size == 0) fail(path, "file is empty");
  if (size > max_bytes) {
    fail(path, "file is too large (" + std::to_string(size) + " bytes, limit " +
                   std::to_string(max_bytes) + ")");
  }
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) fail(path, std::string("cannot open: ") + std::strerror(errno));
  // Unbuffered: every read asks for megabytes, which stdio would only copy once more.
  std::setvbuf(file, nullptr, _IONBF, 0);
  return std::make_unique<FileSource>(path, file, size);
}

std::size_t MemorySource::read(char* out, std::size_t n) {
  const std::size_t got = std::min({n, max_read_, data_.size() - pos_});
  std::memcpy(out, data_.data() + pos_, got);
  pos_ += got;
  return got;
}

BlockReader::BlockReader(const std::filesystem::path& path, ByteSource& source,
                         std::size_t capacity)
    : path_(path),
      source_(source),
      capacity_(static_cast<std::size_t>(std::min<std::uint64_t>(capacity, source.size() + 1))) {
  try {
    // Not zeroed: every byte is read into before it is looked at.
    buffer_ = std::make_unique_for_overwrite<char[]>(capacity_);
  } catch (const std::bad_alloc&) {
    fail_out_of_memory(path, "a read buffer of " + std::to_string(capacity_) + " bytes");
  }
}

void BlockReader::fill(std::size_t n) {
  if (begin_ > 0) {
    std::memmove(buffer_.get(), buffer_.get() + begin_, end_ - begin_);
    base_ += begin_;
    end_ -= begin_;
    begin_ = 0;
  }
  n = std::min(n, capacity_);
  while (end_ < n && !at_end_) {
    const std::size_t got = source_.read(buffer_.get() + end_, capacity_ - end_);
    if (got == 0) at_end_ = true;
    end_ += got;
  }
}

bool BlockReader::read_more() {
  const std::size_t had = end_ - begin_;
  fill(had + 1);
  return end_ - begin_ > had;
}

std::uint64_t BlockReader::skip(std::uint64_t n) {
  std::uint64_t skipped = 0;
  while (skipped < n) {
    if (begin_ == end_) fill(1);
    if (begin_ == end_) break;  // the end of the file
    const auto step = static_cast<std::size_t>(std::min<std::uint64_t>(n - skipped, end_ - begin_));
    begin_ += step;
    skipped += step;
  }
  return skipped;
}

void BlockReader::rewind() {
  source_.rewind();
  begin_ = end_ = 0;
  base_ = 0;
  at_end_ = false;
}

std::size_t LineReader::find_end(std::string_view data, std::size_t from, std::size_t to) const {
  if (from >= to) return std::string_view::npos;
  if (terminator_ != 0) {
    const void* hit = std::memchr(data.data() + from, terminator_, to - from);
    return hit == nullptr ? std::string_view::npos
                          : static_cast<std::size_t>(static_cast<const char*>(hit) - data.data());
  }
  const auto hit = data.substr(from, to - from).find_first_of("\n\r");
  return hit == std::string_view::npos ? hit : from + hit;
}

bool LineReader::next(std::string_view& line, std::size_t limit) {
  limit = std::min(limit, in_.capacity() - 1);  // what the buffer can hold with a terminator
  if (newline_after_) {
    newline_after_ = false;
    const std::string_view head = in_.peek(1);
    if (!head.empty() && head[0] == '\n') in_.consume(1);
  }
  std::size_t scanned = 0;
  for (;;) {
    std::string_view data = in_.buffered();
    const std::size_t window = std::min(data.size(), limit + 1);
    std::size_t stop = find_end(data, scanned, window);
    if (stop != std::string_view::npos && terminator_ == 0) {
      // The first line end decides the file's: "\r\n" counts as '\n'. Deciding needs the byte after
      // a '\r', which may not be buffered yet.
      if (data[stop] == '\r' && stop + 1 == data.size() && in_.read_more()) {
        data = in_.buffered();
      }
      terminator_ =
          data[stop] == '\n' || (stop + 1 < data.size() && data[stop + 1] == '\n') ? '\n' : '\r';
      if (terminator_ == '\n' && data[stop] == '\r') ++stop;
    }
    if (stop != std::string_view::npos) {
      line = data.substr(0, stop);
      in_.consume(stop + 1);
      newline_after_ = terminator_ == '\r';
    } else if (data.size() > limit) {
      line = data.substr(0, limit + 1);  // too long: the caller rejects it
      in_.consume(limit + 1);
    } else {
      scanned = window;
      if (in_.read_more()) continue;
      if (data.empty()) return false;
      line = data;  // the last line, without a terminator
      in_.consume(data.size());
    }
    if (terminator_ != '\r' && !line.empty() && line.back() == '\r') line.remove_suffix(1);
    ++number_;
    return true;
  }
}

const std::vector<std::string_view>& HeaderLines::next() {
  if (!lines_.next(line_, kMaxHeaderBytes))
    fail(lines_.input().path(), "header ends without " + std::string(end_marker_));
  if (lines_.input().offset() > kMaxHeaderBytes) {
    fail(lines_.input().path(), "header longer than 1 MiB without " + std::string(end_marker_));
  }
  words_.clear();
  std::size_t pos = 0;
  for (auto word = next_token(line_, pos, kSpace); !word.empty();
       word = next_token(line_, pos, kSpace)) {
    words_.push_back(word);
  }
  return words_;
}

}  // namespace align3d::io::detail
