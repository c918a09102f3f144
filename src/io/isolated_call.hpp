// A call run in a child process, so that a library that crashes on hostile input (OpenCASCADE on
// some corrupted STEP and IGES files: cad_exchange.cpp) takes down the child and not the caller:
// the caller gets an error naming the file instead. Private to src/io.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace align3d::io::detail {

// Runs work() in a forked child and returns the bytes it returned. An Error (IoError, DataError)
// or std::invalid_argument thrown in the child is thrown again here with its message; a child
// killed by a signal (a crash) is IoError "<path>: <what> crashed on the file (signal N) ...".
// The child runs only work() and leaves through _exit (no atexit handler, no stdio flush, no
// Python), so it may be called from any thread of any program; it inherits the caller's memory
// copy-on-write. Throws IoError naming the file when no process or pipe can be made.
std::string isolated_call(const std::filesystem::path& path, const std::string& what,
                          const std::function<std::string()>& work);

}  // namespace align3d::io::detail
