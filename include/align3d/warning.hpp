// A result that may be wrong is never reported silently: the functions that can tell return
// warnings with their results (the command-line tool prints them on stderr and in its JSON
// reports; docs/report.md lists the codes).
#pragma once

#include <string>

namespace align3d {

struct Warning {
  std::string code;     // stable identifier, e.g. "weak_overlap"
  std::string message;  // one line for people
};

}  // namespace align3d
