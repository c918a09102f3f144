#include "isolated_call.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <new>
#include <stdexcept>

#include "align3d/error.hpp"
#include "io_detail.hpp"

namespace align3d::io::detail {
namespace {

// The child's answer: one byte of kind, then the payload (the result, or the error's message).
constexpr char kResult = 'R', kIoError = 'I', kDataError = 'D', kInvalid = 'A', kOther = 'X';

bool write_all(int fd, const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

std::string read_all(int fd) {
  std::string bytes;
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return bytes;
    bytes.append(buffer, static_cast<std::size_t>(n));
  }
}

[[noreturn]] void run_child(int fd, const std::function<std::string()>& work) {
  std::string answer;
  try {
    answer = std::string(1, kResult) + work();
  } catch (const DataError& e) {
    answer = std::string(1, kDataError) + std::string(e.what());
  } catch (const Error& e) {
    answer = std::string(1, kIoError) + std::string(e.what());
  } catch (const std::invalid_argument& e) {
    answer = std::string(1, kInvalid) + std::string(e.what());
  } catch (const std::bad_alloc&) {
    answer = std::string(1, kDataError) + std::string("not enough memory");
  } catch (const std::exception& e) {
    answer = std::string(1, kOther) + std::string(e.what());
  }
  _exit(write_all(fd, answer) ? 0 : 1);
}

int wait_for(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return status;
}

}  // namespace

std::string isolated_call(const std::filesystem::path& path, const std::string& what,
                          const std::function<std::string()>& work) {
  int fds[2];
  if (::pipe(fds) != 0)
    fail(path, "cannot make a pipe to read it apart: " + std::string(std::strerror(errno)));
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    fail(path, "cannot start a process to read it apart: " + std::string(std::strerror(errno)));
  }
  if (pid == 0) {
    ::close(fds[0]);
    run_child(fds[1], work);
  }
  ::close(fds[1]);
  std::string answer = read_all(fds[0]);  // until the child closes its end: no pipe deadlock
  ::close(fds[0]);
  const int status = wait_for(pid);
  if (status >= 0 && WIFSIGNALED(status))
    fail(path, what + " crashed on the file (signal " + std::to_string(WTERMSIG(status)) +
                   "): it is corrupt or uses what " + what + " cannot read");
  if (answer.empty() || status < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    fail(path, what + " stopped without an answer (exit status " + std::to_string(status) + ")");
  const std::string message = answer.substr(1);
  switch (answer[0]) {
    case kResult:
      answer.erase(0, 1);
      return answer;
    case kDataError:
      throw DataError(message);
    case kIoError: {  // "<path>: <problem>", as IoError writes it
      const std::string prefix = path.string() + ": ";
      throw IoError(path, message.rfind(prefix, 0) == 0 ? message.substr(prefix.size()) : message);
    }
    case kInvalid:
      throw std::invalid_argument(message);
    default:
      throw std::runtime_error(message);
  }
}

}  // namespace align3d::io::detail
