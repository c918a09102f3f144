// Atomic file output: everything align3d writes goes through here. The content is written to a
// temporary file next to the destination, flushed, and renamed over it; on any failure the
// temporary is removed and an OutputError naming the destination is thrown. So a destination holds
// either the complete new content or whatever it held before. A destination that exists and is
// neither a regular file nor a directory (a device such as /dev/null or /dev/stdout, a FIFO) is
// written in place instead: it has no content to keep, and a rename would replace it.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <string_view>

namespace align3d::io {

// Calls write(stream) on a binary stream to the temporary file, then renames it onto `path`.
void write_atomically(const std::filesystem::path& path,
                      const std::function<void(std::ostream&)>& write);

void write_text_atomically(const std::filesystem::path& path, std::string_view text);

// For writers that need a file name (cairo): write(tmp_path) must create tmp_path.
void write_via_temporary(const std::filesystem::path& path,
                         const std::function<void(const std::filesystem::path& tmp)>& write);

}  // namespace align3d::io
