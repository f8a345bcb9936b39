#include "isolated_call.h"

#include <cstdint>
#include <exception>

#include "sim/base/child_process.h"

namespace handson {

namespace {
// The child sends one frame: its result, or the message of what it threw.
enum Kind : std::uint8_t { kResult = 1, kFailure = 2 };
}  // namespace

std::string runIsolated(const std::function<std::string()>& work, double timeoutS, const std::string& what) {
  std::uint8_t kind = 0;
  std::string payload;
  bool got = false;
  ChildEnd end;
  try {
    end = runInChild(
        [&](ChildWriter& w) {
          std::uint8_t k = kFailure;
          std::string out;
          try {
            out = work();
            k = kResult;
          } catch (const Error& e) {
            out = e.what();
          } catch (const std::exception& e) {
            out = what + " failed: " + e.what();
          } catch (...) {
            out = what + " failed with an unknown exception";
          }
          return w.frame(k, out) ? 0 : 3;
        },
        [&](ChildReader& r) { got = r.frame(kind, payload); }, timeoutS, what);
  } catch (const IsolatedCallFailed&) {
    throw;
  } catch (const Error& e) {  // no pipe, no child process
    throw IsolatedCallFailed(e.what());
  }
  if (end.timedOut) throw IsolatedCallFailed(what + ": did not finish within " + std::to_string(int(timeoutS)) + " s (stopped)");
  if (end.signal) throw IsolatedCallFailed(what + ": stopped on the malformed input (" + signalName(end.signal) + ")");
  if (!got || end.exitCode != 0) throw IsolatedCallFailed(what + ": the child process ended without a result");
  if (kind == kFailure) throw Error(payload);
  if (kind != kResult) throw IsolatedCallFailed(what + ": the child process's result is corrupt");
  return payload;
}

}  // namespace handson
