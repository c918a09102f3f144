#include "align3d/io/atomic_file.hpp"

#include <fstream>
#include <random>
#include <system_error>

#include "align3d/error.hpp"

namespace align3d::io {
namespace {

std::filesystem::path temporary_name(const std::filesystem::path& path) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  auto tmp = path;
  tmp += ".tmp-" + std::to_string(rng() % 1000000000ULL);
  return tmp;
}

}  // namespace

void write_via_temporary(const std::filesystem::path& path,
                         const std::function<void(const std::filesystem::path& tmp)>& write) {
  std::error_code ec;
  // A device, a FIFO or a socket (/dev/null, /dev/stdout, a pipe) is written in place: renaming a
  // file over it would replace it (as root, /dev/null itself).
  const auto status = std::filesystem::status(path, ec);
  if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status) &&
      !std::filesystem::is_directory(status)) {
    write(path);
    return;
  }
  const auto tmp = temporary_name(path);
  try {
    write(tmp);
  } catch (...) {
    std::filesystem::remove(tmp, ec);
    throw;
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw OutputError(path, "cannot write: " + ec.message());
  }
}

void write_atomically(const std::filesystem::path& path,
                      const std::function<void(std::ostream&)>& write) {
  write_via_temporary(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw OutputError(path, "cannot write: cannot create file");
    write(out);
    out.flush();
    if (!out) throw OutputError(path, "cannot write: write failed (disk full?)");
  });
}

void write_text_atomically(const std::filesystem::path& path, std::string_view text) {
  write_atomically(path, [&](std::ostream& out) { out.write(text.data(), std::ssize(text)); });
}

}  // namespace align3d::io
