#pragma once
// Whole reads and writes on a file descriptor (a pipe to or from a child process), retried on
// EINTR and short transfers.
#include <unistd.h>

#include <cerrno>
#include <cstddef>

namespace handson {

/// Writes all `size` bytes; false on an error (a closed pipe).
inline bool writeAll(int fd, const void* data, std::size_t size) {
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

/// Reads exactly `size` bytes; false at end of file (or on an error) before that.
inline bool readAll(int fd, void* data, std::size_t size) {
  char* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= std::size_t(n);
  }
  return true;
}

}  // namespace handson
