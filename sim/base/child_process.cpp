#include "sim/base/child_process.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "sim/base/error.h"

namespace handson {

namespace {

constexpr std::uint64_t kMaxFrame = std::uint64_t{1} << 24;

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

bool writeAll(int fd, const void* data, std::size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= std::size_t(n);
  }
  return true;
}

/// Waits for the child; -1 when it cannot be reaped.
int reap(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return status;
}

/// Kills and reaps the child unless it was reaped (an exception from the parent's reader).
struct ChildGuard {
  pid_t pid;
  int fd;
  ~ChildGuard() {
    if (fd >= 0) ::close(fd);
    if (pid > 0) {
      ::kill(pid, SIGKILL);
      reap(pid);
    }
  }
};

}  // namespace

bool ChildWriter::frame(std::uint8_t kind, const std::string& payload) {
  const std::uint64_t n = payload.size();
  return n <= kMaxFrame && writeAll(fd_, &kind, 1) && writeAll(fd_, &n, sizeof n) && writeAll(fd_, payload.data(), payload.size());
}

bool ChildWriter::raw(const void* data, std::size_t n) { return writeAll(fd_, data, n); }

ChildReader::ChildReader(int fd, double timeoutS)
    : fd_(fd), deadline_(timeoutS > 0.0 && std::isfinite(timeoutS) ? now() + timeoutS : std::numeric_limits<double>::infinity()) {}

bool ChildReader::read(void* data, std::size_t size) {
  char* p = static_cast<char*>(data);
  while (size > 0) {
    if (std::isfinite(deadline_)) {
      const double left = deadline_ - now();
      if (left <= 0.0) return !(timedOut_ = true);
      pollfd pf{fd_, POLLIN, 0};
      const int ready = ::poll(&pf, 1, int(std::min(left * 1000.0 + 1.0, 60000.0)));
      if (ready < 0 && errno == EINTR) continue;
      if (ready == 0) continue;
      if (ready < 0) return false;
    }
    const ssize_t n = ::read(fd_, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= std::size_t(n);
  }
  return true;
}

bool ChildReader::frame(std::uint8_t& kind, std::string& payload) {
  std::uint64_t n = 0;
  if (!read(&kind, 1) || !read(&n, sizeof n) || n > kMaxFrame) return false;
  payload.assign(std::size_t(n), '\0');
  return read(payload.data(), payload.size());
}

bool ChildReader::raw(void* data, std::size_t n) { return read(data, n); }

ChildEnd runInChild(const std::function<int(ChildWriter&)>& child, const std::function<void(ChildReader&)>& parent, double timeoutS,
                    const std::string& what) {
  int fds[2];
  if (::pipe(fds) != 0) throw Error(what + ": no pipe for the child process (" + std::strerror(errno) + ")");
  std::fflush(nullptr);  // nothing buffered twice
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(what + ": cannot start the child process (" + std::strerror(err) + ")");
  }
  if (pid == 0) {
    ::close(fds[0]);
    int code = 4;
    try {
      ChildWriter w(fds[1]);
      code = child(w);
    } catch (...) {
      code = 4;
    }
    ::close(fds[1]);
    std::_Exit(code);
  }
  ::close(fds[1]);
  ChildGuard guard{pid, fds[0]};
  ChildReader reader(fds[0], timeoutS);
  parent(reader);
  ::close(guard.fd);
  guard.fd = -1;
  ChildEnd end;
  end.timedOut = reader.timedOut();
  if (end.timedOut) ::kill(pid, SIGKILL);
  const int status = reap(pid);
  guard.pid = -1;
  if (status == -1) return end;
  if (WIFSIGNALED(status)) end.signal = end.timedOut ? 0 : WTERMSIG(status);
  else if (WIFEXITED(status)) end.exitCode = WEXITSTATUS(status);
  return end;
}

std::string signalName(int sig) {
  switch (sig) {
    case SIGABRT: return "SIGABRT, an assertion or abort";
    case SIGSEGV: return "SIGSEGV, an invalid memory access";
    case SIGBUS: return "SIGBUS";
    case SIGFPE: return "SIGFPE";
    case SIGKILL: return "SIGKILL, killed from outside, possibly for lack of memory";
    default: return "signal " + std::to_string(sig);
  }
}

}  // namespace handson
