#pragma once
// Writing a file so that a failure never leaves a half-written result: the data goes to a unique
// temporary file beside the destination (mkstemp, the permissions a new file gets under the umask),
// which commit() flushes to the disk (fsync) and renames into place. Without commit() - an error,
// an exception - the temporary file is removed. The one writer of every output: images, meshes,
// PNGs, scripts, logs and the preprocessing cache.
//
// Data goes in through write(), through fd() (e.g. a gzip stream on a dup of it), or by a library
// that opens tempPath() by name itself (libpng, teem, MetaIO); fsync at commit() flushes the file
// whichever descriptor wrote it.
#include <cstddef>
#include <string>

namespace handson {

class AtomicFile {
 public:
  /// Creates the temporary file. `what` names the file in messages ("NIfTI file", "the simulation
  /// cache"; empty: none). Throws handson::Error: no such directory, not writable, ...
  explicit AtomicFile(std::string path, std::string what = "");
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& tempPath() const { return temp_; }
  const std::string& path() const { return path_; }
  /// The temporary file's descriptor (open until commit()).
  int fd() const { return fd_; }
  /// Writes all of data (retrying interrupted and partial writes). Throws handson::Error (disk full).
  void write(const void* data, std::size_t n);
  /// fsync, close, rename over the destination. Throws handson::Error; the temporary file is then
  /// removed by the destructor.
  void commit();
  /// Throws handson::Error "cannot write <what> '<path>': <why>".
  [[noreturn]] void fail(const std::string& why) const;

 private:
  std::string path_, what_, temp_;
  int fd_ = -1;
  bool committed_ = false;
};

}  // namespace handson
