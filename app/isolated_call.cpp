#include "isolated_call.h"

#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

#include "app/fd_io.h"

namespace handson {

namespace {

// The child writes one frame: [kind u8][length u64][bytes].
enum class Kind : std::uint8_t { Result = 1, Failure = 2 };
constexpr std::uint64_t kMaxPayload = std::uint64_t{1} << 24;

[[noreturn]] void runChild(int fd, const std::function<std::string()>& work, const std::string& what) {
  Kind kind = Kind::Failure;
  std::string payload;
  try {
    payload = work();
    kind = Kind::Result;
  } catch (const Error& e) {
    payload = e.what();
  } catch (const std::exception& e) {
    payload = what + " failed: " + e.what();
  } catch (...) {
    payload = what + " failed with an unknown exception";
  }
  const std::uint8_t k = std::uint8_t(kind);
  const std::uint64_t n = payload.size();
  const bool ok = writeAll(fd, &k, 1) && writeAll(fd, &n, sizeof n) && writeAll(fd, payload.data(), payload.size());
  ::close(fd);
  std::_Exit(ok ? 0 : 3);  // no atexit handlers, no destructors of the parent's static objects
}

// Everything the child writes until it closes the pipe, or false when the deadline passes first.
bool readUntilClosed(int fd, std::string& out, std::chrono::steady_clock::time_point deadline) {
  char buffer[1 << 14];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, int(std::min<long long>(left, 60000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) return true;  // treated as a closed pipe: the frame check reports it
    if (ready == 0) continue;
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return true;
    if (out.size() + std::size_t(n) > kMaxPayload + 9) return true;  // too much: the frame check refuses it
    out.append(buffer, std::size_t(n));
  }
}

int reap(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return status;
}

}  // namespace

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

std::string runIsolated(const std::function<std::string()>& work, double timeoutS, const std::string& what) {
  int fds[2];
  if (::pipe(fds) != 0) throw IsolatedCallFailed(what + ": no pipe for the child process (" + std::strerror(errno) + ")");
  std::fflush(nullptr);  // nothing buffered twice
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw IsolatedCallFailed(what + ": cannot start the child process (" + std::strerror(err) + ")");
  }
  if (pid == 0) {
    ::close(fds[0]);
    runChild(fds[1], work, what);
  }
  ::close(fds[1]);
  std::string frame;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long long>(timeoutS * 1000));
  const bool finished = readUntilClosed(fds[0], frame, deadline);
  ::close(fds[0]);
  if (!finished) {
    ::kill(pid, SIGKILL);
    reap(pid);
    throw IsolatedCallFailed(what + ": did not finish within " + std::to_string(int(timeoutS)) + " s (stopped)");
  }
  const int status = reap(pid);
  if (status != -1 && WIFSIGNALED(status))
    throw IsolatedCallFailed(what + ": stopped on the malformed input (" + signalName(WTERMSIG(status)) + ")");
  std::uint8_t kind = 0;
  std::uint64_t n = 0;
  if (frame.size() < 9 || status == -1 || WEXITSTATUS(status) != 0)
    throw IsolatedCallFailed(what + ": the child process ended without a result");
  std::memcpy(&kind, frame.data(), 1);
  std::memcpy(&n, frame.data() + 1, sizeof n);
  if (n > kMaxPayload || frame.size() != 9 + n) throw IsolatedCallFailed(what + ": the child process's result is corrupt");
  std::string payload = frame.substr(9);
  if (kind == std::uint8_t(Kind::Failure)) throw Error(payload);
  if (kind != std::uint8_t(Kind::Result)) throw IsolatedCallFailed(what + ": the child process's result is corrupt");
  return payload;
}

}  // namespace handson
