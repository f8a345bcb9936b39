#include "sim/base/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

#include "sim/base/error.h"

namespace handson {

namespace {

/// The process's umask, read without changing it (umask() would, for every thread).
mode_t currentUmask() {
  const int fd = ::open("/proc/self/status", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return 022;
  char buf[4096];
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (n <= 0) return 022;
  buf[n] = '\0';
  const char* u = std::strstr(buf, "Umask:");
  if (!u) return 022;
  return static_cast<mode_t>(std::strtoul(u + 6, nullptr, 8));
}

}  // namespace

AtomicFile::AtomicFile(std::string path, std::string what) : path_(std::move(path)), what_(std::move(what)) {
  if (path_.empty()) throw Error("cannot write " + (what_.empty() ? std::string("a file") : what_) + ": the output path is empty");
  const std::filesystem::path p(path_);
  const auto dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) fail("directory '" + dir.string() + "' does not exist");
  std::string templ = path_ + ".tmp-XXXXXX";
  std::vector<char> name(templ.begin(), templ.end());
  name.push_back('\0');
  fd_ = ::mkstemp(name.data());
  if (fd_ < 0) {
    const int err = errno;
    fail("cannot create a file in '" + dir.string() + "': " + std::strerror(err));
  }
  temp_ = name.data();
  ::fchmod(fd_, 0666 & ~currentUmask());  // mkstemp creates 0600: give the file normal permissions
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_.empty()) ::unlink(temp_.c_str());
}

void AtomicFile::fail(const std::string& why) const {
  throw Error("cannot write " + (what_.empty() ? std::string() : what_ + " ") + "'" + path_ + "': " + why);
}

void AtomicFile::write(const void* data, std::size_t n) {
  if (fd_ < 0) fail("the file is already closed");
  const auto* p = static_cast<const unsigned char*>(data);
  std::size_t done = 0;
  while (done < n) {
    const std::size_t want = std::min<std::size_t>(n - done, std::size_t{16} << 20);
    const ssize_t r = ::write(fd_, p + done, want);
    if (r < 0) {
      if (errno == EINTR) continue;
      fail(std::strerror(errno));
    }
    if (r == 0) fail("the disk accepted no more data");
    done += static_cast<std::size_t>(r);
  }
}

void AtomicFile::commit() {
  if (fd_ < 0) fail("the file is already closed");
  if (::fsync(fd_) != 0 && errno != EINVAL && errno != EROFS) fail(std::strerror(errno));
  const int r = ::close(fd_);
  fd_ = -1;
  if (r != 0) fail(std::strerror(errno));
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) fail(std::strerror(errno));
  committed_ = true;
}

}  // namespace handson
