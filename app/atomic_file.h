#pragma once
// Writing a file so that a failure never leaves a half-written result: write to a temporary file
// beside the destination, then rename it into place with commit(). Without commit() the
// temporary file is removed.
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <system_error>

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
    std::random_device rd;
    temp_ = path_ + ".tmp-" + std::to_string(rd() % 1000000u);
  }
  ~AtomicFile() {
    if (!committed_) {
      std::error_code ec;
      std::filesystem::remove(temp_, ec);
    }
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& tempPath() const { return temp_; }
  const std::string& path() const { return path_; }
  void commit() {
    std::error_code ec;
    std::filesystem::rename(temp_, path_, ec);
    if (ec) throw Error("cannot write '" + path_ + "': " + ec.message());
    committed_ = true;
  }

 private:
  std::string path_, temp_;
  bool committed_ = false;
};

}  // namespace handson
