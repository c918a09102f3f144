// Progress of long work, reported to a callback the caller may give (library code never prints;
// the command-line tool draws it on a terminal).
#pragma once

#include <cstddef>
#include <functional>
#include <string>

namespace align3d {

struct Progress {
  std::string task;       // what is running, e.g. "icp stage 3", "global (fpfh)", "trials"
  std::size_t done = 0;   // units finished
  std::size_t total = 0;  // units in all; 0 when unknown
};

// Called from the thread that called the library function, between units of work; it must not
// throw. An empty function reports nothing.
using ProgressCallback = std::function<void(const Progress&)>;

}  // namespace align3d
