#pragma once
// Running work that may crash, abort or hang - a library's broken error path (TetGen), a parser on
// malformed input (GDCM, MetaIO) - in a forked child process, so that this process, its session
// and its unsaved work survive it. The one helper behind every such call: the child sends frames
// ([kind u8][length u64][bytes], each at most 16 MiB) and, after one, raw bytes of any size (a
// volume); the parent reads them as they come (progress as it goes), with an optional deadline;
// then the child is reaped and how it ended - an exit status, a signal, killed at the deadline -
// is returned for the caller to word its own message.
//
// What is safe in the child of a threaded process. fork() copies only the calling thread: the app's
// other threads (the render loop, the simulation worker, the scene builder, OpenBLAS's and the
// Vulkan driver's pools) do not exist in the child, but every lock they held at that instant is
// copied held and is never released. POSIX promises only async-signal-safe calls there; glibc also
// makes malloc usable (its fork handlers reset the allocator's locks) and C++ exceptions work (the
// unwinder's loader lock is glibc's too), and the children here rely on that and no more:
// single-threaded parsing or meshing (GDCM, MetaIO, TetGen) on memory they allocate themselves,
// errors thrown and caught inside, results written to the pipe, then _Exit (no atexit handlers, no
// destructors, no flush of the parent's stdio buffers, which runInChild flushes before forking). A
// child must not take a lock another thread may hold (the app's mutexes, iostreams shared with
// other threads, the sim's progress callbacks), start threads or call a threaded library (BLAS,
// the Vulkan driver), or touch Vulkan or SDL objects.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace handson {

/// The child's end of the pipe.
class ChildWriter {
 public:
  explicit ChildWriter(int fd) : fd_(fd) {}
  /// False when the parent stopped reading (the pipe closed).
  bool frame(std::uint8_t kind, const std::string& payload);
  bool raw(const void* data, std::size_t n);

 private:
  int fd_;
};

/// The parent's end: what the child sends, as it comes.
class ChildReader {
 public:
  ChildReader(int fd, double timeoutS);
  /// The next frame; false when the pipe closed first, the frame is larger than 16 MiB, or the
  /// deadline passed (timedOut()).
  bool frame(std::uint8_t& kind, std::string& payload);
  /// Exactly n raw bytes into data; false as frame().
  bool raw(void* data, std::size_t n);
  bool timedOut() const { return timedOut_; }

 private:
  bool read(void* data, std::size_t n);
  int fd_;
  double deadline_;  ///< steady-clock seconds; infinity: none
  bool timedOut_ = false;
};

struct ChildEnd {
  bool timedOut = false;  ///< killed at the deadline
  int signal = 0;         ///< the signal that ended it (0: none)
  int exitCode = -1;      ///< its exit status when it exited by itself (-1: it did not)
  bool clean() const { return !timedOut && signal == 0 && exitCode == 0; }
};

/// Forks. The child runs child(writer) and exits with its return value at once (_Exit: no atexit
/// handlers, no destructors of this process's objects; an exception escaping it exits with 4). The
/// parent runs parent(reader) - it may stop reading early - then closes its end and reaps the child
/// (killing it if the deadline passed). `timeoutS` <= 0 or infinite: no deadline. An exception from
/// `parent` kills and reaps the child and propagates. Throws handson::Error, naming `what`, when no
/// pipe or no child process can be made.
ChildEnd runInChild(const std::function<int(ChildWriter&)>& child, const std::function<void(ChildReader&)>& parent, double timeoutS,
                    const std::string& what);

/// "SIGABRT, an assertion or abort", "SIGSEGV, an invalid memory access", ...: for messages.
std::string signalName(int sig);

}  // namespace handson
