#pragma once
// Running a library call that may crash, abort or hang on malformed input (MetaIO's header parser)
// in a child process (sim/base/child_process), so that the app, its session and its unsaved work survive
// it: the child's result comes back through a pipe; a child that dies by a signal, exits without a
// result or runs past its time is reported as an error.
#include <functional>
#include <string>

#include "sim/base/child_process.h"
#include "sim/base/error.h"

namespace handson {

/// The child stopped on a signal, ended without a result or ran out of time.
class IsolatedCallFailed : public Error {
 public:
  using Error::Error;
};

/// Runs `work` in a forked child and returns the bytes it returns (at most 16 MiB; a larger result
/// counts as none). A
/// handson::Error thrown by `work` is thrown here with the same message; any other failure of the
/// child (a signal, an exit without a result, more than `timeoutS` seconds: it is killed) throws
/// IsolatedCallFailed with a message that begins with `what`.
std::string runIsolated(const std::function<std::string()>& work, double timeoutS, const std::string& what);


}  // namespace handson
