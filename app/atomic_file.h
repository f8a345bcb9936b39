#pragma once
// Writing a file so that a failure never leaves a half-written result: the data goes to a unique
// temporary file beside the destination (mkstemp), which commit() renames into place. Without
// commit() the temporary file is removed.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "sim/error.h"

namespace handson {

class AtomicFile {
 public:
  explicit AtomicFile(std::string path) : path_(std::move(path)) {
    if (path_.empty()) throw Error("output path is empty");
    const std::filesystem::path p(path_);
    const auto dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) throw Error("cannot write '" + path_ + "': directory '" + dir.string() + "' does not exist");
    std::string templ = path_ + ".tmp-XXXXXX";
    std::vector<char> name(templ.begin(), templ.end());
    name.push_back('\0');
    const int fd = mkstemp(name.data());
    if (fd < 0) throw Error("cannot write '" + path_ + "': " + std::strerror(errno));
    ::close(fd);  // reopened by name by the writer (libpng takes a FILE*)
    temp_ = name.data();
    ::chmod(temp_.c_str(), 0644);  // mkstemp creates 0600
  }
  ~AtomicFile() {
    if (!committed_) ::unlink(temp_.c_str());
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& tempPath() const { return temp_; }
  const std::string& path() const { return path_; }
  void commit() {
    if (std::rename(temp_.c_str(), path_.c_str()) != 0) throw Error("cannot write '" + path_ + "': " + std::strerror(errno));
    committed_ = true;
  }

 private:
  std::string path_, temp_;
  bool committed_ = false;
};

}  // namespace handson
