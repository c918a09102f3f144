// A call run in a child process (src/io/isolated_call.hpp): its result comes back through the pipe
// whole, its errors come back as the same errors, and its crash is an error naming the file
// instead of the caller's end.
#include "io/isolated_call.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <stdexcept>

#include "align3d/error.hpp"

namespace align3d {
namespace {

TEST(IsolatedCall, ReturnsTheChildsBytesWhole) {
  std::string big(5'000'000, 'x');  // far more than a pipe holds: no deadlock
  big[123] = '\0';
  const std::string back = io::detail::isolated_call("f.step", "Lib", [&] { return big; });
  EXPECT_EQ(back, big);
  EXPECT_EQ(io::detail::isolated_call("f.step", "Lib", [] { return std::string(); }), "");
}

TEST(IsolatedCall, ErrorsComeBackAsTheSameErrors) {
  try {
    io::detail::isolated_call("part.step", "Lib", []() -> std::string {
      throw IoError("part.step", "line 3: bad entity");
    });
    FAIL();
  } catch (const IoError& e) {
    EXPECT_STREQ(e.what(), "part.step: line 3: bad entity");
    EXPECT_EQ(e.path(), "part.step");
  }
  EXPECT_THROW(io::detail::isolated_call(
                   "p", "Lib",
                   []() -> std::string { throw DataError("p: not enough memory for the model"); }),
               DataError);
  EXPECT_THROW(io::detail::isolated_call(
                   "p", "Lib", []() -> std::string { throw std::invalid_argument("chord"); }),
               std::invalid_argument);
}

TEST(IsolatedCall, ACrashInTheChildIsAnErrorNamingTheFile) {
  try {
    io::detail::isolated_call("broken.igs", "OpenCASCADE", []() -> std::string {
      ::kill(::getpid(), SIGKILL);  // what no sanitizer intercepts: the child dies of a signal
      return "never";
    });
    FAIL();
  } catch (const IoError& e) {
    EXPECT_EQ(e.path(), "broken.igs");
    EXPECT_NE(std::string(e.what()).find("OpenCASCADE crashed on the file (signal 9)"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace align3d
